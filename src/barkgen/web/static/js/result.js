// Result page: the texture (with a 2×2 tiling check), the 3D trunk, label
// maps, material maps, download, the relief editor (height edits spread to
// self-similar places, the trunk relit at once) and the label painter that
// continues the synthesis from an edited level.

import { api, el, idFromPath, showError, formatDate, describeParams } from "./api.js";
import { JobPanel, jobPanelIn, jobIdFromUrl } from "./jobs.js";
import { LabelPainter } from "./painter.js";
import { ReliefEditor } from "./relief.js";

const $ = (testid) => document.querySelector(`[data-testid="${testid}"]`);

const resultId = idFromPath();

/** Order and labels of the material maps. */
const MAP_NAMES = {
  Color: "Colour",
  Displacement: "Height (displacement)",
  NormalGL: "Normal (OpenGL)",
  NormalDX: "Normal (DirectX)",
  AmbientOcclusion: "Ambient occlusion",
  Roughness: "Roughness",
};

/** The options a result's params may carry that a new job takes as they are. */
const JOB_OPTIONS = ["k", "tile", "material", "method", "strategy", "rotations", "relief", "light", "structure", "model",
  "label_weight", "feature_weight", "blend", "preset", "equalize_light", "width_m"];

/** The job body of a result's settings (its size as "WxH"). */
function jobOptions(p) {
  const body = { size: sizeString(p.size), seed: p.seed };
  for (const name of JOB_OPTIONS) if (p[name] !== undefined && p[name] !== null) body[name] = p[name];
  return body;
}

/** params.size as "WxH" (the job API's format). */
function sizeString(size) {
  if (Array.isArray(size)) return `${size[0]}x${size[1]}`;
  return String(size || "");
}

// ---------------------------------------------------------------------------
// Header and images

function renderHeader(result) {
  const p = result.params || {};
  document.title = `barkgen — result #${result.id}`;
  $("result-title").textContent = `Result #${result.id}`;
  const exemplarUrl = `/exemplars/${result.exemplar_id}`;
  $("exemplar-link").href = exemplarUrl;
  $("crumb-exemplar").href = exemplarUrl;
  const bits = [describeParams({ ...p, resumed_from: null })];
  if (p.resumed_from) bits.push(`painted from result #${p.resumed_from.result_id}, level ${p.resumed_from.level}`);
  bits.push(formatDate(result.created));
  $("result-params").textContent = " · " + bits.filter(Boolean).join(" · ");

  // each download under the material set's name, as an artist's library sorts it
  // (ASSET_VARIANT_SIZE.zip, ASSET_VARIANT_SIZE_trunk.glb, ASSET_VARIANT_SIZE_blender.zip)
  const downloads = result.downloads || {};
  for (const [testId, item] of [
    ["download", downloads.zip || { url: result.download_url, name: "" }],
    ["download-glb", downloads.glb],
    ["download-blender", downloads.blender],
  ]) {
    const link = $(testId);
    link.hidden = !item;
    if (!item) continue;
    link.href = item.url;
    if (item.name) link.setAttribute("download", item.name);
    else link.removeAttribute("download"); // (the server's name)
    link.title = item.name ? `Saved as ${item.name}` : "";
  }

  // "Generate another seed": the exemplar page with these settings pre-filled.
  const query = new URLSearchParams({
    size: sizeString(p.size),
    k: String(p.k ?? 3),
    tile: p.tile ? "1" : "0",
    material: p.material ? "1" : "0",
    kind: p.structure === "cracks" ? "cracks" : p.model === "bilayer" ? "bilayer" : "labels",
  });
  for (const name of ["method", "strategy", "preset"]) if (p[name]) query.set(name, p[name]);
  for (const name of ["relief", "equalize_light", "width_m"]) if (typeof p[name] === "number") query.set(name, String(p[name]));
  $("another-seed").href = `${exemplarUrl}?${query}`;
}

/** Fill in the exemplar's name once it is known (cosmetic; failures ignored). */
async function renderExemplarName(exemplarId) {
  try {
    const ex = await api.getExemplar(exemplarId);
    const name = ex.name || `Photo #${ex.id}`;
    $("exemplar-link").textContent = name;
    $("crumb-exemplar").textContent = name;
  } catch {
    $("exemplar-link").textContent = `photo #${exemplarId}`;
  }
}

function renderTexture(result) {
  const url = (result.files && result.files["texture.png"]) || (result.maps && result.maps.Color);
  const img = $("result-texture");
  const tiled = $("texture-tiled");
  img.src = url;
  tiled.style.backgroundImage = `url("${url}")`;
  const [w, h] = Array.isArray(result.params && result.params.size) ? result.params.size : [1, 1];
  tiled.style.aspectRatio = `${w} / ${h}`;

  const toggle = $("tile-toggle");
  const apply = () => {
    tiled.hidden = !toggle.checked;
    img.hidden = toggle.checked;
  };
  toggle.addEventListener("change", apply);
  apply();
  if (result.params && result.params.tile === false) {
    $("texture-hint").textContent =
      "This result was made without “Tileable”, so the 2×2 view will show seams.";
  }
}

function renderLabels(result) {
  $("labels-in").src = result.labels_in_url;
  $("labels-out").src = result.labels_out_url;
}

function renderMaps(result) {
  const maps = result.maps;
  if (!maps) return;
  const names = [...Object.keys(MAP_NAMES).filter((n) => maps[n]), ...Object.keys(maps).filter((n) => !(n in MAP_NAMES))];
  $("maps-grid").replaceChildren(
    ...names.map((name) =>
      el(
        "a",
        { class: "map-card", href: maps[name], target: "_blank", rel: "noopener", "data-testid": "material-map", dataset: { map: name } },
        el("img", { src: maps[name], alt: MAP_NAMES[name] || name, loading: "lazy" }),
        el("span", { text: MAP_NAMES[name] || name })
      )
    )
  );
  $("maps-section").hidden = names.length === 0;
}

function renderTimings(result) {
  const list = $("timings-list");
  const rows = [];
  const add = (term, value) => rows.push(el("dt", { text: term }), el("dd", { text: value }));
  const p = result.params || {};
  add("Size", sizeString(p.size).replace("x", " × "));
  add("Labels (k)", String(p.k ?? "—"));
  add("Seed", String(p.seed ?? "—"));
  add("Tileable", p.tile ? "yes" : "no");
  add("Material maps", p.material ? "yes" : "no");
  if (result.displacement_depth_px !== null && result.displacement_depth_px !== undefined) {
    const metres = result.material && result.material.displacement_depth_m;
    add("Relief depth", `${Number(result.displacement_depth_px).toFixed(1)} px` + (metres ? ` (${(metres * 1000).toFixed(1)} mm)` : ""));
  }
  const record = result.material;
  if (record && record.width_m) add("Real size", `${Math.round(record.width_m * 1000)} × ${Math.round(record.height_m * 1000)} mm (${record.real_size})`);
  for (const [name, value] of Object.entries(result.timings || {})) {
    add(`Time: ${name}`, typeof value === "number" ? `${value.toFixed(2)} s` : String(value));
  }
  list.replaceChildren(...rows);
}

// ---------------------------------------------------------------------------
// 3D trunk (optional: three.js or WebGL may be missing)

function trunkControls() {
  return {
    azimuth: $("light-azimuth"),
    elevation: $("light-elevation"),
    repeat: $("repeat"),
    depth: $("relief-depth"),
    light: $("photo-light"),
    reset: $("trunk-reset"),
  };
}

/** Keep each range's <output> showing its value. */
function setupRangeOutputs() {
  const format = {
    "light-azimuth": (v) => `${v}°`,
    "light-elevation": (v) => `${v}°`,
    repeat: (v) => `${v}×` + ($("repeat").disabled ? " · real size" : ""),
    "photo-light": (v) => `${v} %`,
  };
  for (const [testid, fmt] of Object.entries(format)) {
    const input = $(testid);
    const output = document.querySelector(`output[data-for="${testid}"]`);
    const update = () => {
      output.textContent = fmt(input.value);
    };
    input.addEventListener("input", update);
    input.addEventListener("change", update);
    update();
  }
}

// ---------------------------------------------------------------------------
// Depth and Photo light: the set as it would be, on the trunk and in the relief
// editor at once; the relief editor's Save keeps them

/** The Depth output: the multiple and the depth it gives (mm at the set's real size, else px). */
function setupDepth(result) {
  const input = $("relief-depth");
  const output = $("relief-depth-value");
  const record = result.material;
  const update = () => {
    const relief = 2 ** Number(input.value);
    let depth = "";
    if (record && record.displacement_depth_m) depth = ` · ${(record.displacement_depth_m * relief * 1000).toFixed(1)} mm`;
    else if (record && record.displacement_depth_px) depth = ` · ${(record.displacement_depth_px * relief).toFixed(1)} px`;
    output.textContent = `${relief.toFixed(2)}×${depth}`;
  };
  input.addEventListener("input", update);
  update();
  if (!record) {
    // a texture without material maps has no relief to deepen or colour to relight
    input.disabled = true;
    input.closest("label").hidden = true;
    $("photo-light").closest("label").hidden = true;
  }
}

/**
 * The photo's light carried to the result (GET .../illumination, fetched once),
 * and the Photo light slider on it: starting at the set's own, off with a
 * one-line reason where the result has none.
 * @returns {Promise<?{light: Float32Array, width: number, rows: number}>}
 */
async function loadIllumination(result) {
  const input = $("photo-light");
  const note = $("photo-light-note");
  const record = result.material;
  const off = (text) => {
    input.disabled = true;
    note.textContent = text;
    note.hidden = !text;
    input.dispatchEvent(new Event("input"));
  };
  if (!record) {
    off("");
    return null;
  }
  input.value = String(Math.round(Number(record.light_equalization ?? 1) * 100));
  input.dispatchEvent(new Event("input"));
  if (!record.illumination_url) {
    off("Photo light: this result has no record of its photo's light (it was made before barkgen kept it).");
    return null;
  }
  try {
    const response = await fetch(record.illumination_url);
    if (!response.ok) throw new Error(`the server answered ${response.status}`);
    const [width, rows] = response.headers.get("X-Height-Size").split("x").map(Number);
    const answer = { light: new Float32Array(await response.arrayBuffer()), width, rows };
    input.disabled = false;
    return answer;
  } catch (err) {
    off(`Photo light: the photo's light could not be loaded (${err.message}).`);
    return null;
  }
}

async function setupTrunk(result, illumination) {
  const canvas = $("trunk-canvas");
  const message = $("trunk-message");
  const say = (text) => {
    message.textContent = text;
    message.hidden = !text;
  };
  const disable = (text) => {
    say(text);
    message.classList.add("is-error");
    canvas.classList.add("is-unavailable");
    for (const input of Object.values(trunkControls())) input.disabled = true;
  };
  let trunk;
  try {
    trunk = await import("./trunk.js");
  } catch (err) {
    console.warn("three.js could not be loaded:", err);
    disable("The 3D view is unavailable: three.js could not be loaded.");
    return;
  }
  try {
    return await trunk.initTrunk({ canvas, result, controls: trunkControls(), illumination, onStatus: say });
  } catch (err) {
    console.warn("3D trunk failed:", err);
    const noWebGL = /webgl/i.test(String(err && err.message));
    disable(noWebGL ? "The 3D view is unavailable: this browser has no WebGL." : `The 3D view failed: ${err.message || err}`);
    return null;
  }
}

// ---------------------------------------------------------------------------
// Relief editor (results with material maps)

async function setupRelief(result, trunkReady, illumination) {
  if (!result.maps || !result.maps.Displacement) return;
  $("relief-toggle-label").hidden = false;
  const toggle = $("relief-toggle");
  const tiling = $("tile-toggle");
  const show = () => {
    // sculpting takes the texture's place, beside the trunk it relights
    const on = toggle.checked;
    $("relief").hidden = !on;
    $("relief-canvas").hidden = !on;
    $("texture-hint").hidden = on;
    tiling.disabled = on;
    if (on) {
      $("result-texture").hidden = true;
      $("texture-tiled").hidden = true;
    } else {
      tiling.dispatchEvent(new Event("change")); // the image or its 2x2 view, as ticked
    }
  };
  toggle.addEventListener("change", show);
  const errorBox = $("relief-error");
  const tile = Boolean(result.params && result.params.tile);
  const lightInput = $("photo-light");
  const depthInput = $("relief-depth");
  const ownLight = Math.round(Number(result.material.light_equalization ?? 1) * 100);
  /** The sliders' depth and light where they differ from the result's own (as the edit list holds them). */
  const adjustments = () => {
    const chosen = {};
    const relief = Math.round(2 ** Number(depthInput.value) * 1e4) / 1e4;
    if (relief !== 1) chosen.relief = relief;
    if (!lightInput.disabled && Number(lightInput.value) !== ownLight) chosen.light_equalization = Number(lightInput.value) / 100;
    return chosen;
  };
  const texture = new Image();
  texture.src = (result.files && result.files["texture.png"]) || result.maps.Color;
  let trunk = null;
  const editor = new ReliefEditor({
    canvas: $("relief-canvas"),
    texture,
    resultId: result.id,
    inputs: { radius: $("relief-radius"), strength: $("relief-strength") },
    buttons: {
      raise: $("relief-raise"),
      lower: $("relief-lower"),
      undo: $("relief-undo"),
      redo: $("relief-redo"),
      reset: $("relief-reset"),
    },
    download: $("relief-download"),
    status: $("relief-status"),
    errorBox,
    onHeight: (height, width, rows) => {
      if (trunk) trunk.setRelief(height, width, rows, tile);
    },
    adjustments,
  });
  // the photo light relights the texture here too (texture.png is as the run equalised it)
  const textureLight = Number(result.material.texture_light_equalization ?? 1);
  const relight = () => editor.setLightPower(lightInput.disabled ? 0 : textureLight - lightInput.value / 100);
  lightInput.addEventListener("input", relight);
  for (const input of [lightInput, depthInput]) input.addEventListener("change", () => editor.updateButtons());
  const save = $("relief-save");
  const root = $("relief-job-panel");
  const panel = new JobPanel({
    root,
    stateEl: $("relief-job-state"),
    progressEl: $("relief-job-progress"),
    cancelBtn: $("relief-job-cancel"),
    onBusy: (busy) => {
      save.disabled = busy;
      save.textContent = busy ? "Saving…" : "Save relief as a new result";
    },
  });
  save.addEventListener("click", async () => {
    showError(errorBox, "");
    const edits = editor.edits;
    const chosen = adjustments();
    if (!edits.length && !Object.keys(chosen).length) {
      showError(errorBox, "There is nothing to save yet: drag on the texture, or move Depth or Photo light.");
      return;
    }
    const body = {
      exemplar_id: result.exemplar_id,
      ...jobOptions(result.params || {}),
      relief_edits: { result_id: result.id, edits, ...chosen },
    };
    try {
      await panel.start(body);
    } catch (err) {
      showError(errorBox, err.message);
    }
  });
  trunk = await trunkReady;
  await editor.start();
  const answer = await illumination;
  if (answer) editor.setLight(answer.light);
  relight();
  $("relief-canvas").dataset.ready = "1";
}

// ---------------------------------------------------------------------------
// Label painter and "continue synthesis"

async function setupPainter(result) {
  if (result.params && result.params.structure === "cracks") {
    $("painter").querySelector(".hint").textContent =
      "A crack network is grown from the photo's statistics, not painted: generate another seed for another network.";
    $("painter").querySelector(".painter-layout").hidden = true;
    return;
  }
  const painter = new LabelPainter({
    canvas: $("paint-canvas"),
    levelSelect: $("paint-level"),
    swatches: $("paint-swatches"),
    radiusInput: $("paint-radius"),
    resetBtn: $("paint-reset"),
    statusEl: $("paint-status"),
    errorBox: $("paint-error"),
    bark: $("paint-bark"),
    opacity: $("paint-opacity"),
    opacityValue: $("paint-opacity-value"),
    undoBtn: $("paint-undo"),
    redoBtn: $("paint-redo"),
    brushBtn: $("paint-tool-brush"),
    fillBtn: $("paint-tool-fill"),
  });
  const continueBtn = $("paint-continue");
  const errorBox = $("paint-error");

  const panel = jobPanelIn($("painter").querySelector('[data-testid="job-panel"]'), (busy) => {
    continueBtn.disabled = busy;
    continueBtn.textContent = busy ? "Working…" : "Continue synthesis from this level";
  });

  continueBtn.addEventListener("click", async () => {
    showError(errorBox, "");
    if (!painter.image) {
      showError(errorBox, "The label map level is not loaded yet.");
      return;
    }
    const body = {
      exemplar_id: result.exemplar_id,
      ...jobOptions(result.params || {}),
      resume: { result_id: result.id, level: painter.level, labels: painter.toDataURL() },
    };
    try {
      await panel.start(body);
    } catch (err) {
      showError(errorBox, err.message);
    }
  });

  const jobId = jobIdFromUrl();
  if (jobId) panel.resume(jobId);

  const ok = await painter.setResult(result);
  if (!ok) continueBtn.disabled = true;
}

// ---------------------------------------------------------------------------

async function main() {
  setupRangeOutputs();
  if (resultId === null) {
    showError($("page-error"), "This address does not name a result. Go back to the library.");
    return;
  }
  let result;
  try {
    result = await api.getResult(resultId);
  } catch (err) {
    showError(
      $("page-error"),
      err.status === 404 ? "This result does not exist (any more): it was deleted, or the address is wrong." : err.message
    );
    return;
  }
  $("result-body").hidden = false;
  renderHeader(result);
  renderTexture(result);
  renderLabels(result);
  renderMaps(result);
  renderTimings(result);
  renderExemplarName(result.exemplar_id);
  // The trunk, the relief editor and the painter are independent: one failing
  // leaves the others (the editor relights the trunk when there is one).
  setupDepth(result);
  const illumination = loadIllumination(result);
  const trunkReady = setupTrunk(result, illumination);
  setupRelief(result, trunkReady, illumination).catch((err) => showError($("relief-error"), `The relief editor failed: ${err.message}`));
  setupPainter(result).catch((err) => showError($("paint-error"), `The label painter failed: ${err.message}`));
}

main();
