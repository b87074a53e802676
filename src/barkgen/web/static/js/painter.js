// Label painter: paint palette colours onto one level of a result's output
// label map.
//
// The server only accepts pixels whose colour is exactly a palette colour, so
// painting edits the canvas' ImageData pixel by pixel (no canvas paths: their
// anti-aliasing would blend colours). The level is shown at its natural size
// in the canvas and scaled up with CSS (image-rendering: pixelated), over a
// faded view of the bark (the result's texture, stretched to the same box), so
// the labels can be painted where the bark should change. Strokes and fills
// are undone and redone (Ctrl+Z, Ctrl+Shift+Z) from a history of snapshots.

const HISTORY = 50; // undo steps kept

const DISPLAY_WIDTH = 512; // about how wide the level is shown, in CSS px
const MIN_DEFAULT_WIDTH = 64; // default level: the coarsest one at least this wide

const rgbKey = (r, g, b) => (r << 16) | (g << 8) | b;
const cssColour = ([r, g, b]) => `rgb(${r}, ${g}, ${b})`;

/** Decode an image URL into something drawImage can use, without colour management. */
async function loadBitmap(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`Could not load the label map level (${response.status}).`);
  const blob = await response.blob();
  if (typeof createImageBitmap === "function") {
    try {
      return await createImageBitmap(blob, { colorSpaceConversion: "none", premultiplyAlpha: "none" });
    } catch {
      // Fall back to an <img> below.
    }
  }
  const objectUrl = URL.createObjectURL(blob);
  try {
    const img = new Image();
    img.src = objectUrl;
    await img.decode();
    return img;
  } finally {
    URL.revokeObjectURL(objectUrl);
  }
}

export class LabelPainter {
  /**
   * @param {object} els  canvas, levelSelect, swatches (container), radiusInput,
   *                      resetBtn, statusEl, errorBox; optional bark (img under the
   *                      canvas), opacity (+ opacityValue), undoBtn, redoBtn,
   *                      brushBtn, fillBtn
   */
  constructor(els) {
    Object.assign(this, els);
    this.tool = "brush";
    this.undoStack = [];
    this.redoStack = [];
    this.ctx = this.canvas.getContext("2d", { willReadFrequently: true });
    this.palette = [];
    this.levels = [];
    this.colour = 0; // index into palette
    this.wrap = false; // paint across the edges (tileable results)
    this.image = null; // the ImageData being edited
    this.original = null; // pristine copy, for Reset
    this.dirty = false;
    this.loadToken = 0;
    this.last = null; // last painted point while dragging
    this.onChange = () => {};

    this.levelSelect.addEventListener("change", () => this.loadLevel(Number(this.levelSelect.value)));
    this.resetBtn.addEventListener("click", () => this.reset());
    if (this.undoBtn) this.undoBtn.addEventListener("click", () => this.undo());
    if (this.redoBtn) this.redoBtn.addEventListener("click", () => this.redo());
    if (this.brushBtn) this.brushBtn.addEventListener("click", () => this.selectTool("brush"));
    if (this.fillBtn) this.fillBtn.addEventListener("click", () => this.selectTool("fill"));
    if (this.opacity) {
      const apply = () => {
        this.canvas.style.opacity = this.opacity.value;
        if (this.opacityValue) this.opacityValue.textContent = `${Math.round(Number(this.opacity.value) * 100)} %`;
      };
      this.opacity.addEventListener("input", apply);
      apply();
    }
    this.setupPointer();
    this.setupKeys();
  }

  selectTool(tool) {
    this.tool = tool;
    for (const [name, button] of [["brush", this.brushBtn], ["fill", this.fillBtn]]) {
      if (!button) continue;
      button.classList.toggle("selected", name === tool);
      button.setAttribute("aria-pressed", String(name === tool));
    }
    this.canvas.style.cursor = tool === "fill" ? "cell" : "crosshair";
  }

  // -------------------------------------------------------------------------
  // Undo and redo: a snapshot of the level before each stroke or fill

  snapshot() {
    return new ImageData(new Uint8ClampedArray(this.image.data), this.image.width, this.image.height);
  }

  remember() {
    this.undoStack.push(this.snapshot());
    if (this.undoStack.length > HISTORY) this.undoStack.shift();
    this.redoStack = [];
    this.updateHistory();
  }

  restore(from, to) {
    if (!from.length || !this.image) return;
    to.push(this.snapshot());
    this.image = from.pop();
    this.ctx.putImageData(this.image, 0, 0);
    this.setDirty(!this.sameAs(this.original));
    this.updateHistory();
  }

  undo() {
    this.restore(this.undoStack, this.redoStack);
  }

  redo() {
    this.restore(this.redoStack, this.undoStack);
  }

  sameAs(other) {
    if (!other) return false;
    const a = this.image.data;
    const b = other.data;
    for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
    return true;
  }

  /** Drop the snapshot taken for a stroke or fill that changed nothing. */
  forgetIfUnchanged() {
    if (!this.strokeChanged && this.undoStack.length) {
      this.undoStack.pop();
      this.updateHistory();
    }
  }

  updateHistory() {
    if (this.undoBtn) this.undoBtn.disabled = this.undoStack.length === 0;
    if (this.redoBtn) this.redoBtn.disabled = this.redoStack.length === 0;
  }

  /** Fill the controls from a result object and load the default level. */
  async setResult(result) {
    this.palette = (result.palette || []).map((c) => c.slice(0, 3).map(Number));
    this.looks = result.label_looks || null;
    this.levels = [...(result.levels || [])].sort((a, b) => a.level - b.level);
    this.wrap = Boolean(result.params && result.params.tile);
    const texture = result.files && result.files["texture.png"];
    if (this.bark && texture) this.bark.src = texture;
    this.paletteIndex = new Map(this.palette.map((c, i) => [rgbKey(...c), i]));
    this.buildSwatches();

    if (!this.levels.length) {
      this.statusEl.textContent = "This result has no label map levels to paint.";
      this.levelSelect.disabled = true;
      return false;
    }
    this.levelSelect.replaceChildren(
      ...this.levels.map((lv) => {
        const option = document.createElement("option");
        option.value = String(lv.level);
        option.textContent = `Level ${lv.level} — ${lv.width} × ${lv.height}${lv.level === 0 ? " (full size)" : ""}`;
        return option;
      })
    );
    // Default: the coarsest level that is still at least 64 px wide.
    const wide = this.levels.filter((lv) => lv.width >= MIN_DEFAULT_WIDTH);
    const chosen = wide.length ? wide[wide.length - 1] : this.levels[0];
    this.levelSelect.value = String(chosen.level);
    await this.loadLevel(chosen.level);
    return true;
  }

  /** The level number currently shown. */
  get level() {
    return Number(this.levelSelect.value);
  }

  /** The painted level as a PNG data URL. */
  toDataURL() {
    return this.canvas.toDataURL("image/png");
  }

  // -------------------------------------------------------------------------
  // Palette swatches

  buildSwatches() {
    this.swatches.replaceChildren(
      ...this.palette.map((colour, i) => {
        const button = document.createElement("button");
        button.type = "button";
        button.className = "swatch";
        button.dataset.testid = "paint-swatch";
        button.dataset.index = String(i);
        button.style.backgroundColor = cssColour(colour);
        // the label's average colour in the photo as a stripe: what this label *is*
        const look = this.looks && this.looks[i];
        const share = look ? ` — ${Math.round(look.share * 100)} % of the photo` : "";
        if (look) button.style.boxShadow = `inset 0 -12px 0 ${cssColour(look.colour)}`;
        button.title = `Label ${i + 1}${share} (key ${i + 1}); the bottom stripe is its average colour in the photo`;
        button.setAttribute("aria-label", `Label ${i + 1}${share}`);
        button.textContent = String(i + 1);
        // Dark or light digit, whichever reads better on the colour.
        const luma = 0.299 * colour[0] + 0.587 * colour[1] + 0.114 * colour[2];
        button.style.color = luma > 140 ? "#000" : "#fff";
        button.addEventListener("click", () => this.selectColour(i));
        return button;
      })
    );
    this.selectColour(Math.min(this.colour, Math.max(0, this.palette.length - 1)));
  }

  selectColour(index) {
    this.colour = index;
    for (const button of this.swatches.querySelectorAll(".swatch")) {
      const selected = Number(button.dataset.index) === index;
      button.classList.toggle("selected", selected);
      button.setAttribute("aria-pressed", String(selected));
    }
  }

  setupKeys() {
    // Ctrl+Z / Ctrl+Shift+Z (or Ctrl+Y) undo and redo; keys 1..k pick a colour while the
    // pointer is over the painter.
    document.addEventListener("keydown", (event) => {
      const typing = event.target && /^(INPUT|SELECT|TEXTAREA)$/.test(event.target.tagName);
      if ((event.ctrlKey || event.metaKey) && !typing && this.image) {
        const key = event.key.toLowerCase();
        if (key === "z" && !event.shiftKey) {
          event.preventDefault();
          this.undo();
          return;
        }
        if ((key === "z" && event.shiftKey) || key === "y") {
          event.preventDefault();
          this.redo();
          return;
        }
      }
      if (!this.canvas.matches(":hover") || event.ctrlKey || event.metaKey || event.altKey) return;
      const index = Number(event.key) - 1;
      if (Number.isInteger(index) && index >= 0 && index < this.palette.length) this.selectColour(index);
    });
  }

  // -------------------------------------------------------------------------
  // Loading a level

  async loadLevel(levelNumber) {
    const level = this.levels.find((lv) => lv.level === levelNumber);
    if (!level) return;
    const token = ++this.loadToken;
    this.showError("");
    this.statusEl.textContent = "Loading the level…";
    let bitmap;
    try {
      bitmap = await loadBitmap(level.url);
    } catch (err) {
      if (token === this.loadToken) {
        this.showError(err.message);
        this.statusEl.textContent = "";
      }
      return;
    }
    if (token !== this.loadToken) return; // another level was picked meanwhile

    const width = bitmap.width;
    const height = bitmap.height;
    this.canvas.width = width;
    this.canvas.height = height;
    this.ctx.imageSmoothingEnabled = false;
    this.ctx.clearRect(0, 0, width, height);
    this.ctx.drawImage(bitmap, 0, 0); // 1:1, so smoothing never applies
    if (bitmap.close) bitmap.close();

    this.image = this.ctx.getImageData(0, 0, width, height);
    const fixed = this.snapToPalette(this.image);
    this.ctx.putImageData(this.image, 0, 0);
    this.original = new ImageData(new Uint8ClampedArray(this.image.data), width, height);
    this.undoStack = [];
    this.redoStack = [];
    this.updateHistory();
    this.setDirty(false);

    // Show it about DISPLAY_WIDTH px wide: an integer zoom when enlarging.
    const zoom = width >= DISPLAY_WIDTH ? DISPLAY_WIDTH / width : Math.floor(DISPLAY_WIDTH / width);
    this.canvas.style.width = `${Math.round(width * zoom)}px`;
    this.canvas.style.height = "auto";
    this.zoomText = zoom >= 1 ? `shown ${zoom}× enlarged` : "shown reduced";
    this.updateStatus();
    if (fixed) console.warn(`painter: ${fixed} pixels were not palette colours and were snapped to the nearest one`);
  }

  /** Make every pixel an exact palette colour (guards against any decoding drift). */
  snapToPalette(image) {
    if (!this.palette.length) return 0;
    const data = image.data;
    let fixed = 0;
    let lastKey = -1;
    let lastColour = null;
    for (let p = 0; p < data.length; p += 4) {
      const key = rgbKey(data[p], data[p + 1], data[p + 2]);
      if (data[p + 3] === 255 && this.paletteIndex.has(key)) continue;
      let colour;
      if (key === lastKey) {
        colour = lastColour;
      } else {
        let best = Infinity;
        for (const c of this.palette) {
          const d = (c[0] - data[p]) ** 2 + (c[1] - data[p + 1]) ** 2 + (c[2] - data[p + 2]) ** 2;
          if (d < best) {
            best = d;
            colour = c;
          }
        }
        lastKey = key;
        lastColour = colour;
      }
      data[p] = colour[0];
      data[p + 1] = colour[1];
      data[p + 2] = colour[2];
      data[p + 3] = 255;
      fixed++;
    }
    return fixed;
  }

  reset() {
    if (!this.original) return;
    if (this.dirty) this.remember();
    this.image = new ImageData(new Uint8ClampedArray(this.original.data), this.original.width, this.original.height);
    this.ctx.putImageData(this.image, 0, 0);
    this.setDirty(false);
  }

  setDirty(dirty) {
    this.dirty = dirty;
    this.updateStatus();
    this.onChange(dirty);
  }

  updateStatus() {
    if (!this.image) return;
    const { width, height } = this.image;
    const edited = this.dirty ? " · edited" : " · not edited yet";
    this.statusEl.textContent = `Level ${this.level}: ${width} × ${height} px, ${this.zoomText}${edited}`;
  }

  showError(message) {
    this.errorBox.textContent = message;
    this.errorBox.hidden = !message;
  }

  // -------------------------------------------------------------------------
  // Painting

  /** Pointer position in level pixel coordinates (fractional). */
  toLevel(event) {
    const rect = this.canvas.getBoundingClientRect();
    return {
      x: ((event.clientX - rect.left) / rect.width) * this.canvas.width,
      y: ((event.clientY - rect.top) / rect.height) * this.canvas.height,
    };
  }

  radius() {
    const r = Math.round(Number(this.radiusInput.value));
    return Number.isFinite(r) ? Math.min(64, Math.max(0, r)) : 3;
  }

  setupPointer() {
    const canvas = this.canvas;
    canvas.addEventListener("pointerdown", (event) => {
      if (!this.image || event.button !== 0) return;
      event.preventDefault();
      canvas.setPointerCapture(event.pointerId);
      const point = this.toLevel(event);
      if (event.altKey) {
        this.pickColour(point); // Alt-click: take the colour under the pointer
        return;
      }
      this.remember();
      this.strokeChanged = false;
      if (this.tool === "fill") {
        this.strokeChanged = this.fill(point);
        this.forgetIfUnchanged();
        return;
      }
      this.last = point;
      this.stroke(point, point);
    });
    canvas.addEventListener("pointermove", (event) => {
      if (!this.image || !this.last || !(event.buttons & 1)) return;
      const point = this.toLevel(event);
      this.stroke(this.last, point);
      this.last = point;
    });
    const end = () => {
      if (this.last) this.forgetIfUnchanged();
      this.last = null;
    };
    canvas.addEventListener("pointerup", end);
    canvas.addEventListener("pointercancel", end);
    canvas.addEventListener("lostpointercapture", end);
  }

  pickColour({ x, y }) {
    const px = Math.floor(x);
    const py = Math.floor(y);
    if (px < 0 || py < 0 || px >= this.image.width || py >= this.image.height) return;
    const p = (py * this.image.width + px) * 4;
    const d = this.image.data;
    const index = this.paletteIndex.get(rgbKey(d[p], d[p + 1], d[p + 2]));
    if (index !== undefined) this.selectColour(index);
  }

  /** Stamp discs along the segment a→b, then push the changed area to the canvas. */
  stroke(a, b) {
    const colour = this.palette[this.colour];
    if (!colour) return;
    const r = this.radius();
    const length = Math.hypot(b.x - a.x, b.y - a.y);
    const steps = Math.max(1, Math.ceil(length / Math.max(0.5, r / 2)));
    let changed = false;
    for (let s = 0; s <= steps; s++) {
      const t = s / steps;
      changed = this.stamp(a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, r, colour) || changed;
    }
    if (!changed) return;
    this.strokeChanged = true;
    // The stroke's bounding box (whole canvas when wrapping across an edge).
    const { width, height } = this.image;
    let x0 = Math.floor(Math.min(a.x, b.x)) - r;
    let y0 = Math.floor(Math.min(a.y, b.y)) - r;
    let x1 = Math.floor(Math.max(a.x, b.x)) + r + 1;
    let y1 = Math.floor(Math.max(a.y, b.y)) + r + 1;
    if (this.wrap && (x0 < 0 || y0 < 0 || x1 > width || y1 > height)) {
      [x0, y0, x1, y1] = [0, 0, width, height];
    }
    x0 = Math.max(0, x0);
    y0 = Math.max(0, y0);
    x1 = Math.min(width, x1);
    y1 = Math.min(height, y1);
    if (x1 > x0 && y1 > y0) this.ctx.putImageData(this.image, 0, 0, x0, y0, x1 - x0, y1 - y0);
    if (!this.dirty) this.setDirty(true);
  }

  /** Flood-fill the region of one label under the point (4-connected; across the edges of a
   * tileable result) with the chosen colour. Returns whether anything changed. */
  fill({ x, y }) {
    const colour = this.palette[this.colour];
    const { width, height, data } = this.image;
    const px = Math.floor(x);
    const py = Math.floor(y);
    if (!colour || px < 0 || py < 0 || px >= width || py >= height) return false;
    const start = py * width + px;
    const target = rgbKey(data[start * 4], data[start * 4 + 1], data[start * 4 + 2]);
    if (target === rgbKey(...colour)) return false;
    const seen = new Uint8Array(width * height);
    const stack = [start];
    seen[start] = 1;
    while (stack.length) {
      const i = stack.pop();
      const p = i * 4;
      data[p] = colour[0];
      data[p + 1] = colour[1];
      data[p + 2] = colour[2];
      data[p + 3] = 255;
      const cx = i % width;
      const cy = (i - cx) / width;
      for (const [dx, dy] of [[1, 0], [-1, 0], [0, 1], [0, -1]]) {
        let nx = cx + dx;
        let ny = cy + dy;
        if (this.wrap) {
          nx = (nx + width) % width;
          ny = (ny + height) % height;
        } else if (nx < 0 || ny < 0 || nx >= width || ny >= height) {
          continue;
        }
        const j = ny * width + nx;
        if (seen[j]) continue;
        const q = j * 4;
        if (rgbKey(data[q], data[q + 1], data[q + 2]) !== target) continue;
        seen[j] = 1;
        stack.push(j);
      }
    }
    this.ctx.putImageData(this.image, 0, 0);
    this.setDirty(true);
    return true;
  }

  /** Set every pixel within r of the pixel under (x, y) to colour. */
  stamp(x, y, r, colour) {
    const { width, height, data } = this.image;
    const cx = Math.floor(x);
    const cy = Math.floor(y);
    let changed = false;
    for (let dy = -r; dy <= r; dy++) {
      for (let dx = -r; dx <= r; dx++) {
        if (dx * dx + dy * dy > r * r) continue;
        let px = cx + dx;
        let py = cy + dy;
        if (this.wrap) {
          px = ((px % width) + width) % width;
          py = ((py % height) + height) % height;
        } else if (px < 0 || py < 0 || px >= width || py >= height) {
          continue;
        }
        const p = (py * width + px) * 4;
        if (data[p] === colour[0] && data[p + 1] === colour[1] && data[p + 2] === colour[2]) continue;
        data[p] = colour[0];
        data[p + 1] = colour[1];
        data[p + 2] = colour[2];
        data[p + 3] = 255;
        changed = true;
      }
    }
    return changed;
  }
}
