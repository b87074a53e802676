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
  "label_weight", "feature_weight", "blend", "preset"];

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

  const download = $("download");
  download.href = result.download_url;
  download.removeAttribute("download"); // the server names the zip after the photo
  const glb = result.files && result.files["trunk.glb"];
  $("download-glb").hidden = !glb;
  if (glb) {
    $("download-glb").href = glb;
    $("download-glb").setAttribute("download", `barkgen-result-${result.id}-trunk.glb`);
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
    add("Relief depth", `${Number(result.displacement_depth_px).toFixed(1)} px`);
  }
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
    displacement: $("displacement"),
    repeat: $("repeat"),
    reset: $("trunk-reset"),
  };
}

/** Keep each range's <output> showing its value. */
function setupRangeOutputs() {
  const format = {
    "light-azimuth": (v) => `${v}°`,
    "light-elevation": (v) => `${v}°`,
    displacement: (v) => Number(v).toFixed(3),
    repeat: (v) => `${v}×`,
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

async function setupTrunk(result) {
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
    return await trunk.initTrunk({ canvas, result, controls: trunkControls(), onStatus: say });
  } catch (err) {
    console.warn("3D trunk failed:", err);
    const noWebGL = /webgl/i.test(String(err && err.message));
    disable(noWebGL ? "The 3D view is unavailable: this browser has no WebGL." : `The 3D view failed: ${err.message || err}`);
    return null;
  }
}

// ---------------------------------------------------------------------------
// Relief editor (results with material maps)

async function setupRelief(result, trunkReady) {
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
  });
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
    if (!edits.length) {
      showError(errorBox, "There is nothing to save yet: drag on the texture first.");
      return;
    }
    const body = {
      exemplar_id: result.exemplar_id,
      ...jobOptions(result.params || {}),
      relief_edits: { result_id: result.id, edits },
    };
    try {
      await panel.start(body);
    } catch (err) {
      showError(errorBox, err.message);
    }
  });
  trunk = await trunkReady;
  await editor.start();
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
  const trunkReady = setupTrunk(result);
  setupRelief(result, trunkReady).catch((err) => showError($("relief-error"), `The relief editor failed: ${err.message}`));
  setupPainter(result).catch((err) => showError($("paint-error"), `The label painter failed: ${err.message}`));
}

main();
