// Relief editor (wang2003 §3.3, Fig. 6): brush on the texture to raise or lower
// the bark; each edit spreads to the places whose neighbourhood looks alike
// (the server's HeightEditor) and the trunk relights at once. The page keeps
// the edit list (strokes, for undo and redo) and sends it whole; the server
// answers the edited height (float32) from the heights it kept, so an undo
// costs nothing. The trunk panel's Photo light relights the texture drawn here
// (with the photo's light L carried to the result), and its Depth and Photo
// light go into the edit list beside the edits. Save makes a new result with
// the edits replayed and the depth and light given to its set, as
// `barkgen generate --material --edits edits.json` does.

import { showError } from "./api.js";

/** The edits of a stroke are at least this many result pixels apart. */
const MIN_SPACING = 2;
/** The gain the relit texture is capped at either way (barkgen.material.illumination.MAX_GAIN). */
const MAX_GAIN = 8;
/** Steps of ln L the relit texture looks its gain up in (4096 over L's range: under 0.1 % apart). */
const LIGHT_STEPS = 4096;

/** sRGB 0..255 -> linear light, and linear light in 4096 steps of 0..1 -> sRGB 0..255
 * (to MAX_GAIN: the brightest pixel relit as far as it goes, 255 beyond 1). */
const TO_LINEAR = Float32Array.from({ length: 256 }, (_, v) => {
  const c = v / 255;
  return c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4;
});
const TO_SRGB = Uint8ClampedArray.from({ length: 4096 * MAX_GAIN + 1 }, (_, i) => {
  const c = Math.min(1, i / 4096);
  return Math.round((c <= 0.0031308 ? c * 12.92 : 1.055 * c ** (1 / 2.4) - 0.055) * 255);
});

export class ReliefEditor {
  /**
   * @param {object} o
   * @param {HTMLCanvasElement} o.canvas   drawn: the texture and the change so far
   * @param {HTMLImageElement} o.texture  the result's texture
   * @param {number} o.resultId
   * @param {boolean} o.tile               the result tiles (the trunk's normals wrap)
   * @param {object} o.inputs             {radius, strength} number inputs
   * @param {object} o.buttons            {raise, lower, undo, redo, reset}
   * @param {HTMLAnchorElement} o.download  edits.json link
   * @param {HTMLElement} o.status
   * @param {HTMLElement} o.errorBox
   * @param {(height: Float32Array, width: number, rows: number) => void} o.onHeight
   * @param {() => object} o.adjustments  the sliders' {relief, light_equalization} where
   *   they differ from the result's own (for the edit list beside the edits)
   */
  constructor(o) {
    Object.assign(this, o);
    this.strokes = [];
    this.undone = [];
    this.stroke = null;
    this.sign = 1;
    this.inFlight = false;
    this.dirty = false;
    this.base = null;
    this.height = null;
    this.width = 0;
    this.rows = 0;
    this.pending = []; // times the edits not yet answered were made
    this.latencies = [];
    this.texturePixels = null; // the texture's RGBA, read once
    this.light = null; // {index, low, step}: ln L of the photo's light, in LIGHT_STEPS steps
    this.lightPower = 0; // the texture is shown times L^lightPower (in linear light)
    this.relightQueued = false;
    this.ctx = this.canvas.getContext("2d");
    this.bind();
  }

  get edits() {
    return this.strokes.flat();
  }

  bind() {
    const { raise, lower, undo, redo, reset } = this.buttons;
    const pick = (sign) => {
      this.sign = sign;
      raise.classList.toggle("selected", sign > 0);
      lower.classList.toggle("selected", sign < 0);
      raise.setAttribute("aria-pressed", String(sign > 0));
      lower.setAttribute("aria-pressed", String(sign < 0));
    };
    raise.addEventListener("click", () => pick(1));
    lower.addEventListener("click", () => pick(-1));
    undo.addEventListener("click", () => this.undo());
    redo.addEventListener("click", () => this.redo());
    reset.addEventListener("click", () => {
      if (!this.strokes.length) return;
      this.undone = [];
      this.strokes = [];
      this.changed();
    });
    this.canvas.addEventListener("pointerdown", (e) => this.down(e));
    this.canvas.addEventListener("pointermove", (e) => this.move(e));
    for (const type of ["pointerup", "pointercancel", "pointerleave"]) {
      this.canvas.addEventListener(type, () => {
        this.stroke = null;
      });
    }
  }

  /** Load the base height and draw; false when the result has none. */
  async start() {
    const answer = await this.fetchHeight([]);
    if (!answer) return false;
    this.base = answer.height;
    this.height = answer.height;
    this.width = answer.width;
    this.rows = answer.rows;
    this.canvas.width = this.width;
    this.canvas.height = this.rows;
    if (!this.texture.complete) await new Promise((ok) => this.texture.addEventListener("load", ok, { once: true }));
    this.draw();
    this.updateButtons();
    return true;
  }

  async fetchHeight(edits) {
    const response = await fetch(`/api/results/${this.resultId}/relief`, {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ edits }),
    });
    if (!response.ok) {
      let detail = `the server answered ${response.status}`;
      try {
        detail = (await response.json()).detail || detail;
      } catch {
        /* not JSON */
      }
      showError(this.errorBox, `Relief: ${detail}`);
      return null;
    }
    const [width, rows] = response.headers.get("X-Height-Size").split("x").map(Number);
    return { height: new Float32Array(await response.arrayBuffer()), width, rows };
  }

  /** The result pixel under a pointer event. */
  pixel(e) {
    const rect = this.canvas.getBoundingClientRect();
    const x = Math.floor(((e.clientX - rect.left) / rect.width) * this.width);
    const y = Math.floor(((e.clientY - rect.top) / rect.height) * this.rows);
    return [Math.min(Math.max(x, 0), this.width - 1), Math.min(Math.max(y, 0), this.rows - 1)];
  }

  edit(x, y) {
    const radius = Math.max(1, Math.min(16, Math.round(Number(this.inputs.radius.value) || 4)));
    const strength = Math.max(0.1, Math.min(20, Number(this.inputs.strength.value) || 1));
    this.stroke.push({ x, y, delta: Math.round(this.sign * strength * 1000) / 1000, radius });
    this.pending.push(performance.now());
    this.changed(true);
  }

  down(e) {
    if (!this.base || e.button !== 0) return;
    e.preventDefault();
    this.canvas.setPointerCapture(e.pointerId);
    this.stroke = [];
    this.strokes.push(this.stroke);
    this.undone = [];
    this.last = this.pixel(e);
    this.edit(...this.last);
  }

  move(e) {
    if (!this.stroke) return;
    const [x, y] = this.pixel(e);
    const radius = Number(this.inputs.radius.value) || 4;
    if (Math.hypot(x - this.last[0], y - this.last[1]) < Math.max(MIN_SPACING, radius)) return;
    this.last = [x, y];
    this.edit(x, y);
  }

  undo() {
    if (!this.strokes.length) return;
    this.undone.push(this.strokes.pop());
    this.changed();
  }

  redo() {
    if (!this.undone.length) return;
    this.strokes.push(this.undone.pop());
    this.changed();
  }

  /** The list changed: ask for its height (one request at a time, the last list wins). */
  changed(timed = false) {
    if (!timed) this.pending = [];
    this.updateButtons();
    if (this.inFlight) {
      this.dirty = true;
      return;
    }
    this.send();
  }

  async send() {
    this.inFlight = true;
    this.dirty = false;
    const edits = this.edits;
    const waiting = this.pending.length;
    const t0 = performance.now();
    const answer = await this.fetchHeight(edits).catch((err) => {
      showError(this.errorBox, `Relief: ${err.message}`);
      return null;
    });
    this.inFlight = false;
    if (answer) {
      const t1 = performance.now();
      this.height = answer.height;
      this.onHeight(answer.height, answer.width, answer.rows);
      const t2 = performance.now();
      this.draw();
      const now = performance.now();
      for (const t of this.pending.splice(0, waiting)) this.latencies.push(now - t);
      // where the time went: the server's answer, the trunk relit, the overlay drawn
      this.canvas.dataset.phases = JSON.stringify({ fetch: t1 - t0, trunk: t2 - t1, draw: now - t2 });
      this.report(edits.length);
    }
    if (this.dirty) this.send();
  }

  report(count) {
    const last = this.latencies.length ? this.latencies[this.latencies.length - 1] : null;
    this.canvas.dataset.edits = String(count);
    this.canvas.dataset.latencies = JSON.stringify(this.latencies.map((v) => Math.round(v)));
    this.status.textContent =
      `${count} edit${count === 1 ? "" : "s"}` + (last === null ? "" : ` · last took ${Math.round(last)} ms`);
  }

  /**
   * The photo's light carried to the result (L, one value a pixel), for
   * setLightPower: ln L in LIGHT_STEPS steps over its range (a gain table of
   * that many entries then relights a pixel with one look-up).
   */
  setLight(light) {
    if (light.length !== this.width * this.rows) return;
    let low = Infinity;
    let high = -Infinity;
    for (const v of light) {
      low = Math.min(low, v);
      high = Math.max(high, v);
    }
    [low, high] = [Math.log(low), Math.log(high)];
    const step = (high - low) / (LIGHT_STEPS - 1) || 1;
    const index = Uint16Array.from(light, (v) => Math.round((Math.log(v) - low) / step));
    this.light = { index, low, step };
  }

  /**
   * Show the texture relit, times L^power in linear light (0: as it is): drawn
   * once the trunk's next frame is out, with the last power asked for.
   */
  setLightPower(power) {
    const next = this.light ? power : 0;
    if (next === this.lightPower) return;
    this.lightPower = next;
    if (!this.base || this.relightQueued) return;
    this.relightQueued = true;
    requestAnimationFrame(() =>
      setTimeout(() => {
        this.relightQueued = false;
        const t0 = performance.now();
        this.draw();
        this.canvas.dataset.relit = String(Math.round(performance.now() - t0));
        this.canvas.dataset.lightPower = String(this.lightPower);
      }, 0)
    );
  }

  /** The texture's pixels, relit by the photo light chosen. */
  texturePixelsLit() {
    const { ctx, width, rows } = this;
    if (!this.texturePixels) {
      ctx.drawImage(this.texture, 0, 0, width, rows);
      this.texturePixels = ctx.getImageData(0, 0, width, rows);
    }
    const image = new ImageData(new Uint8ClampedArray(this.texturePixels.data), width, rows);
    if (!this.lightPower) return image;
    const px = image.data;
    const { index, low, step } = this.light;
    // the gain of each step of ln L (capped either way), times the sRGB table's 4096 steps
    const gains = new Float32Array(LIGHT_STEPS);
    for (let k = 0; k < LIGHT_STEPS; k++) {
      const gain = Math.exp((low + k * step) * this.lightPower);
      gains[k] = Math.min(MAX_GAIN, Math.max(1 / MAX_GAIN, gain)) * 4096;
    }
    for (let i = 0, o = 0; i < index.length; i++, o += 4) {
      const gain = gains[index[i]];
      px[o] = TO_SRGB[(TO_LINEAR[px[o]] * gain + 0.5) | 0];
      px[o + 1] = TO_SRGB[(TO_LINEAR[px[o + 1]] * gain + 0.5) | 0];
      px[o + 2] = TO_SRGB[(TO_LINEAR[px[o + 2]] * gain + 0.5) | 0];
    }
    return image;
  }

  /** The texture (relit), tinted where the height changed (red raised, blue lowered). */
  draw() {
    const { ctx, width, rows } = this;
    const image = this.texturePixelsLit();
    const px = image.data;
    if (!this.height || this.height === this.base) {
      ctx.putImageData(image, 0, 0);
      return;
    }
    let most = 0;
    for (let i = 0; i < this.height.length; i++) most = Math.max(most, Math.abs(this.height[i] - this.base[i]));
    if (most <= 0) {
      ctx.putImageData(image, 0, 0);
      return;
    }
    for (let i = 0; i < this.height.length; i++) {
      const change = (this.height[i] - this.base[i]) / most;
      const a = Math.min(1, Math.abs(change)) * 0.6;
      if (a <= 0) continue;
      const o = i * 4;
      const [r, g, b] = change > 0 ? [230, 60, 40] : [40, 110, 230];
      px[o] = px[o] * (1 - a) + r * a;
      px[o + 1] = px[o + 1] * (1 - a) + g * a;
      px[o + 2] = px[o + 2] * (1 - a) + b * a;
    }
    ctx.putImageData(image, 0, 0);
  }

  updateButtons() {
    this.buttons.undo.disabled = !this.strokes.length;
    this.buttons.redo.disabled = !this.undone.length;
    this.buttons.reset.disabled = !this.strokes.length;
    const edits = this.edits;
    const adjustments = this.adjustments();
    const something = edits.length > 0 || Object.keys(adjustments).length > 0;
    if (this.downloadUrl) URL.revokeObjectURL(this.downloadUrl);
    this.downloadUrl = URL.createObjectURL(
      new Blob([JSON.stringify({ version: 1, edits, ...adjustments }, null, 1) + "\n"], { type: "application/json" })
    );
    this.download.href = this.downloadUrl;
    this.download.classList.toggle("is-disabled", !something);
    this.download.setAttribute("aria-disabled", String(!something));
    if (!edits.length) this.status.textContent = "No edits yet: drag on the texture.";
  }
}
