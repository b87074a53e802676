// Relief editor (wang2003 §3.3, Fig. 6): brush on the texture to raise or lower
// the bark; each edit spreads to the places whose neighbourhood looks alike
// (the server's HeightEditor) and the trunk relights at once. The page keeps
// the edit list (strokes, for undo and redo) and sends it whole; the server
// answers the edited height (float32) from the heights it kept, so an undo
// costs nothing. Save makes a new result with the edits replayed, as
// `barkgen generate --material --edits edits.json` does.

import { showError } from "./api.js";

/** The edits of a stroke are at least this many result pixels apart. */
const MIN_SPACING = 2;

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

  /** The texture, tinted where the height changed (red raised, blue lowered). */
  draw() {
    const { ctx, width, rows } = this;
    ctx.drawImage(this.texture, 0, 0, width, rows);
    if (!this.height || this.height === this.base) return;
    const image = ctx.getImageData(0, 0, width, rows);
    const px = image.data;
    let most = 0;
    for (let i = 0; i < this.height.length; i++) most = Math.max(most, Math.abs(this.height[i] - this.base[i]));
    if (most <= 0) return;
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
    if (this.downloadUrl) URL.revokeObjectURL(this.downloadUrl);
    this.downloadUrl = URL.createObjectURL(
      new Blob([JSON.stringify({ version: 1, edits }, null, 1) + "\n"], { type: "application/json" })
    );
    this.download.href = this.downloadUrl;
    this.download.classList.toggle("is-disabled", !edits.length);
    this.download.setAttribute("aria-disabled", String(!edits.length));
    if (!edits.length) this.status.textContent = "No edits yet: drag on the texture.";
  }
}
