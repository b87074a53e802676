// Exemplar page: the photo, its label map for the chosen k (or, for cracks, the crack view:
// the photo's crack network to edit), the parameter form, the job panel and the earlier
// results of this photo.

import { api, el, idFromPath, serverSettings, showError, formatDate, describeParams } from "./api.js";
import { crackViewIn } from "./crackview.js";
import { jobPanelIn, jobIdFromUrl } from "./jobs.js";

const $ = (testid) => document.querySelector(`[data-testid="${testid}"]`);

let K_MIN = 2;
let K_MAX = 8;
/** The server's largest output side (from /api/options). */
let MAX_SIDE = 4096;
/** The material set's real-world width in metres: the option's range (from /api/options). */
let WIDTH_M = [0.001, 1000];
/** The generate options the server offers (GET /api/options: name, kind, default, range,
 * choices, help, group, needs), in their declared order: the form's fields. */
let FIELDS = [];
/** The options the kind select sets (structure, model) and those the page reads itself. */
const KIND_GROUP = "kind";
/** The kinds of bark and the option values each is (structure, model). */
const KINDS = {
  labels: { structure: "labels", model: "patches" },
  cracks: { structure: "cracks", model: "patches" },
  bilayer: { structure: "labels", model: "bilayer" },
};
/** What the photo suits (GET .../kinds), once known. */
let kinds = null;
/** How often a label job is checked while the label map is made (ms). */
const LABEL_POLL_MS = 100;
/** The longest the kinds of bark wait for the first label map (ms). */
const KINDS_AFTER_MS = 8000;

const exemplarId = idFromPath();
/** The crack view (shown for the kind "cracks"). */
const cracks = exemplarId === null ? null : crackViewIn($("crack-view"), exemplarId);

/** A random seed in 0..99999. */
const randomSeed = () => Math.floor(Math.random() * 100000);

/** The k field as an integer in range, or null. */
function currentK() {
  const k = Number($("param-k").value);
  return Number.isInteger(k) && k >= K_MIN && k <= K_MAX ? k : null;
}

// ---------------------------------------------------------------------------
// Header, photo, earlier results

// a scanned set's map kinds (barkgen.io.recognise_set) as people say them
const MAP_NAMES = {
  normal_gl: "normal", normal_dx: "normal (DirectX)", normal: "normal", height: "height",
  roughness: "roughness", gloss: "gloss", ao: "AO", metalness: "metalness", opacity: "opacity",
  arm: "AO/roughness/metal", cavity: "cavity",
};
const mapName = (kind) => MAP_NAMES[kind] || kind;

function renderExemplar(ex) {
  const name = ex.name || `Photo #${ex.id}`;
  document.title = `barkgen — ${name}`;
  $("exemplar-name").textContent = name;
  const meta = [
    ex.species,
    ex.bark_type,
    ex.width && ex.height ? `${ex.width} × ${ex.height} px` : null,
    ex.licence ? `licence: ${ex.licence}` : null,
    ex.source ? `source: ${ex.source}` : null,
    ex.maps && ex.maps.length ? `scanned set: colour + ${ex.maps.map(mapName).join(", ")}` : null,
  ].filter(Boolean);
  $("exemplar-meta").textContent = meta.join(" · ");
  if (ex.maps && ex.maps.length) {
    $("material-hint").textContent = "the set's own maps, carried with the colour + 3D trunk";
    // a scanned set is there for its maps: the material set is on (as `barkgen generate SET/`)
    if (!new URLSearchParams(location.search).has("material")) $("param-material").checked = true;
    updateFields();
  }
  const photo = $("exemplar-photo");
  photo.src = ex.photo_url;
  photo.alt = `Bark photo: ${name}`;
  $("crack-photo").src = ex.photo_url;
  renderResults(ex.results || []);
}

function renderResults(results) {
  const status = $("results-status");
  status.textContent = results.length ? "" : "None yet — your results will appear here.";
  status.hidden = results.length > 0;
  $("results-grid").replaceChildren(
    ...results.map((r) =>
      el(
        "a",
        { class: "card", href: `/results/${r.id}`, "data-testid": "result-card", dataset: { id: r.id } },
        el("div", { class: "card-thumb" }, el("img", { src: r.thumbnail_url, alt: `Result #${r.id}`, loading: "lazy" })),
        el(
          "div",
          { class: "card-body" },
          el("div", { class: "card-title", text: `Result #${r.id}` }),
          el("div", { class: "card-meta", text: describeParams(r.params) }),
          el("div", { class: "card-meta", text: formatDate(r.created) })
        )
      )
    )
  );
}

// ---------------------------------------------------------------------------
// Input label map (reloaded when k changes)

/** Follow the label maps the form asks for; resolves once the first is shown (or has failed). */
function setupLabels() {
  const img = $("labels-in");
  const loading = $("labels-loading");
  const errorBox = $("labels-error");
  let shownK = null;
  let settle;
  const first = new Promise((resolve) => {
    settle = resolve;
  });

  const fail = (message) => {
    settle();
    loading.hidden = true;
    showError(errorBox, message);
    shownK = null; // allow a retry with the same k
  };

  // The label map is made by a label job in the server's worker (it takes seconds on a large
  // photo): ask for it, follow the job, then show the picture.
  const load = async () => {
    const k = currentK();
    const method = $("param-method").value || "color";
    const wanted = k === null ? null : `${k}/${method}`;
    if (wanted === null || wanted === shownK) return;
    shownK = wanted;
    $("labels-k").textContent = String(k);
    showError(errorBox, "");
    loading.hidden = false;
    img.classList.add("is-loading");
    try {
      // a read-only server makes no label map: it shows the one made before, if any
      const readOnly = (await serverSettings).read_only;
      const answer = readOnly
        ? { url: `/api/exemplars/${exemplarId}/labels.png?k=${k}&method=${encodeURIComponent(method)}`, job: null }
        : await api.requestLabels(exemplarId, k, method);
      let job = answer.job;
      while (job && job.state !== "done") {
        if (job.state === "failed" || job.state === "cancelled") {
          throw new Error(job.error || `the label job was ${job.state}`);
        }
        await new Promise((resolve) => setTimeout(resolve, LABEL_POLL_MS));
        if (shownK !== wanted) return; // k or the method changed meanwhile: that load takes over
        job = await api.getJob(job.id);
      }
      if (shownK === wanted) img.src = answer.url;
    } catch (err) {
      if (shownK === wanted) fail(`Could not compute the label map for k = ${k}: ${err.message}`);
    }
  };
  img.addEventListener("load", () => {
    settle();
    loading.hidden = true;
    img.classList.remove("is-loading");
  });
  img.addEventListener("error", () => {
    if (!img.getAttribute("src")) return;
    fail(`Could not load the label map (${shownK}).`);
  });

  // Typing in a number field fires many input events: wait for a pause.
  let timer = null;
  const kInput = $("param-k");
  kInput.addEventListener("input", () => {
    clearTimeout(timer);
    timer = setTimeout(load, 250);
  });
  kInput.addEventListener("change", () => {
    clearTimeout(timer);
    load();
  });
  $("param-method").addEventListener("change", load);
  load();
  return first;
}

// ---------------------------------------------------------------------------
// Parameter form and job

/** Set a size into the preset select and the width and height fields. */
function setSize(text) {
  const m = /^(\d+)x(\d+)$/.exec(String(text || ""));
  if (!m) return;
  $("param-width").value = m[1];
  $("param-height").value = m[2];
  const preset = $("param-size");
  preset.value = [...preset.options].some((o) => o.value === text) ? text : "custom";
}

/** A number given as a number or as its text (not null, nor empty). */
const isNumber = (v) => v !== undefined && v !== null && v !== "" && Number.isFinite(Number(v));

/** Set the relief, the photo light (a share 0..1, shown in %) and the set's width in metres
 * where a value is given (a width of null: none, the assumed one). */
function setMaterialValues({ relief, equalize_light: light, width_m: width }) {
  if (isNumber(relief)) $("param-relief").value = String(relief);
  if (isNumber(light)) $("param-equalize-light").value = String(Math.round(Number(light) * 100));
  if (width !== undefined) $("param-width-m").value = isNumber(width) ? String(Number(width)) : "";
}

/** The control of an option: the page's own (`param-NAME`: the size's width × height, the
 * sliders, the selects) or one built from its declaration. */
const controlOf = (name) => $(`param-${name.replaceAll("_", "-")}`);

/** "label_weight" → "Label weight". */
const labelOf = (name) => name.charAt(0).toUpperCase() + name.slice(1).replaceAll("_", " ");

/** A plain control for an option the page has no control of its own for, from its declaration:
 * a select of its choices, a check box, or a number or text field with its range. */
function buildControl(field) {
  const testid = `param-${field.name.replaceAll("_", "-")}`;
  const common = { name: field.name, "data-testid": testid, title: field.help, dataset: { option: "built" } };
  if (field.kind === "bool") {
    return el(
      "label",
      { class: "field field-check" },
      el("input", { type: "checkbox", ...common }),
      el("span", { class: "check-text" }, el("span", { class: "field-label", text: labelOf(field.name) }))
    );
  }
  let input;
  if (field.choices) {
    input = el("select", common, ...field.choices.map((c) => el("option", { value: c, text: c })));
  } else if (field.kind === "int" || field.kind === "float") {
    input = el("input", {
      type: "number",
      ...common,
      min: field.minimum ?? null,
      max: field.maximum ?? null,
      step: field.kind === "int" ? "1" : "any",
      inputmode: field.kind === "int" ? "numeric" : "decimal",
    });
  } else {
    input = el("input", { type: "text", ...common, placeholder: field.default === null ? "default" : null });
  }
  return el("label", { class: "field" }, el("span", { class: "field-label", text: labelOf(field.name) }), input);
}

/** The section that holds an option's built control: the main form, More settings, or an
 * Advanced section inside it (made when an option asks for it). */
function sectionOf(group) {
  if (!group) return { holder: $("params-form"), before: $("more-settings") };
  if (group === "more") return { holder: $("more-settings"), before: null };
  let section = document.querySelector(`[data-testid="${group}-settings"]`);
  if (!section) {
    section = el("details", { class: "more", "data-testid": `${group}-settings` }, el("summary", { text: labelOf(group) }));
    $("more-settings").append(section);
  }
  return { holder: section, before: null };
}

/** The form's fields from the options the server offers: each option without a control of the
 * page's own gets one built from its declaration, in its group's section, two to a row. */
function buildFields(fields) {
  FIELDS = fields;
  const rows = new Map();
  for (const field of fields) {
    if (field.group === KIND_GROUP || field.name === "size" || controlOf(field.name)) continue;
    const { holder, before } = sectionOf(field.group);
    let row = rows.get(holder);
    if (!row || row.children.length >= 2) {
      row = el("div", { class: "field-row" });
      holder.insertBefore(row, before);
      rows.set(holder, row);
    }
    row.append(buildControl(field));
  }
}

/** Set a built control to a value (a default, the URL's, a job's). */
function setBuilt(field, value) {
  const control = controlOf(field.name);
  if (!control || control.dataset.option !== "built" || value === undefined) return;
  if (field.kind === "bool") control.checked = value === true || value === "1" || value === "true";
  else control.value = value === null ? "" : String(value);
}

/** A built control's value for the job, or undefined where it is the option's default (a
 * job's params hold the options it changed) or empty; throws Error(message) when out of range. */
function readBuilt(field) {
  const control = controlOf(field.name);
  if (!control || control.dataset.option !== "built" || control.disabled) return undefined;
  let value;
  if (field.kind === "bool") value = control.checked;
  else if (field.kind === "int" || field.kind === "float") {
    const text = control.value.trim();
    if (!text) return undefined;
    value = Number(text);
    const whole = field.kind === "int" ? Number.isInteger(value) : Number.isFinite(value);
    if (!whole || (field.minimum !== null && value < field.minimum) || (field.maximum !== null && value > field.maximum)) {
      const range = [field.minimum, field.maximum].map((v) => (v === null ? "" : v)).join(" to ");
      throw new Error(`${labelOf(field.name)} must be a ${field.kind === "int" ? "whole " : ""}number (${range}).`);
    }
  } else {
    value = control.value.trim();
    if (!value) return undefined;
  }
  return value === field.default ? undefined : value;
}

/** The form's defaults: the options' own (shared with `barkgen generate`), then the URL's. */
function applyDefaults(fields) {
  buildFields(fields);
  const byName = Object.fromEntries(fields.map((f) => [f.name, f]));
  const initial = (name) => (byName[name] ? byName[name].default : undefined);
  setSize(initial("size"));
  if (Number.isInteger(initial("k"))) $("param-k").value = String(initial("k"));
  $("param-tile").checked = Boolean(initial("tile"));
  $("param-material").checked = Boolean(initial("material"));
  if (initial("method")) $("param-method").value = initial("method");
  if (initial("strategy")) $("param-strategy").value = initial("strategy");
  setMaterialValues({ relief: initial("relief"), equalize_light: initial("equalize_light"), width_m: initial("width_m") });
  // the set's width within the option's own range (checked on Generate; the field's min stays 0,
  // so its arrows step by whole centimetres)
  if (byName.width_m) WIDTH_M = [byName.width_m.minimum ?? WIDTH_M[0], byName.width_m.maximum ?? WIDTH_M[1]];
  // each control's help is the option's own (the CLI's --help says the same); the built ones
  // start at their defaults
  for (const field of fields) {
    if (controlOf(field.name)) controlOf(field.name).title = field.help;
    setBuilt(field, field.default);
  }
  const q = new URLSearchParams(location.search);
  for (const field of fields) if (q.has(field.name)) setBuilt(field, q.get(field.name));
  if (q.has("size")) setSize(q.get("size"));
  const k = Number(q.get("k"));
  if (q.has("k") && Number.isInteger(k) && k >= K_MIN && k <= K_MAX) $("param-k").value = String(k);
  if (q.has("tile")) $("param-tile").checked = q.get("tile") !== "0" && q.get("tile") !== "false";
  if (q.has("material")) $("param-material").checked = q.get("material") !== "0" && q.get("material") !== "false";
  for (const name of ["method", "strategy", "preset"]) if (q.has(name)) $(`param-${name}`).value = q.get(name);
  // a result's relief, photo light and width ("Generate another seed" carries them)
  const given = (name) => (q.has(name) ? q.get(name) : undefined);
  setMaterialValues({ relief: given("relief"), equalize_light: given("equalize_light"), width_m: given("width_m") });
  if (q.has("kind") && KINDS[q.get("kind")]) $("param-kind").value = q.get("kind");
  const seed = Number(q.get("seed"));
  $("param-seed").value = String(q.has("seed") && Number.isInteger(seed) && seed >= 0 ? seed : randomSeed());
  updateFields();
}

/** The sliders' values shown; the fields of the material set only with material maps (the
 * photo light changes the label map and the texture too: always on). */
function updateFields() {
  $("relief-value").textContent = `${Number($("param-relief").value).toFixed(2)}×`;
  $("equalize-light-value").textContent = `${$("param-equalize-light").value} % out`;
  // an option that applies under another (relief under material) is off while that one is
  for (const field of FIELDS) {
    const control = controlOf(field.name);
    if (field.needs && control && controlOf(field.needs)) control.disabled = !controlOf(field.needs).checked;
  }
}

/** The chosen kind's hint, and the fields it uses. */
function updateKind() {
  const kind = $("param-kind").value;
  const known = kinds && kinds[kind];
  $("param-kind-hint").textContent = known ? known.why : "";
  const labels = kind === "labels";
  // the crack view takes the place of the photo and its label map
  const crackView = kind === "cracks" && cracks !== null;
  $("crack-view").hidden = !crackView;
  $("photo-figure").hidden = crackView;
  $("labels-figure").hidden = crackView;
  if (crackView) cracks.show();
  $("param-k").disabled = kind === "cracks";
  $("param-method").disabled = !labels;
  $("param-strategy").disabled = !labels;
  $("k-hint").textContent =
    kind === "bilayer"
      ? "How many kinds of fine grain (noises), 2–8."
      : kind === "cracks"
        ? "Not used: the cracks and the bark between them are the two regions."
        : `Kinds of region (ridges, furrows, moss), ${K_MIN}–${K_MAX}.`;
}

/** Offer the kinds the photo suits; say why where it does not. */
async function loadKinds() {
  try {
    kinds = await api.getKinds(exemplarId);
  } catch (err) {
    $("param-kind-hint").textContent = `Could not check the photo: ${err.message}`;
    return;
  }
  const whyNot = [];
  for (const option of $("param-kind").options) {
    const known = kinds[option.value];
    option.disabled = Boolean(known && !known.suits);
    option.title = known ? known.why : "";
    if (known && !known.suits) {
      option.textContent = `${option.textContent.split(":")[0]} — not for this photo`;
      whyNot.push(`${option.textContent.split(" — ")[0]}: ${known.why}`);
    }
  }
  $("param-kind").title = whyNot.join("\n");
  $("param-kind-why-not").textContent = whyNot.join(" ");
  $("param-kind-why-not").hidden = whyNot.length === 0;
  if ($("param-kind").selectedOptions[0].disabled) $("param-kind").value = "labels";
  $("param-kind").dataset.kinds = "1"; // what the photo suits is known
  updateKind();
}

/** Read and check the form; returns the job body or throws Error(message). */
function readParams() {
  const kind = $("param-kind").value;
  const k = currentK();
  if (k === null && kind !== "cracks") throw new Error(`Labels (k) must be a whole number from ${K_MIN} to ${K_MAX}.`);
  const width = Number($("param-width").value);
  const height = Number($("param-height").value);
  for (const [name, side] of [["width", width], ["height", height]]) {
    if (!Number.isInteger(side) || side < 16 || side > MAX_SIDE) {
      throw new Error(`The ${name} must be a whole number of pixels from 16 to ${MAX_SIDE} (this server's limit).`);
    }
  }
  const seedText = $("param-seed").value.trim();
  const seed = Number(seedText);
  if (!seedText || !Number.isInteger(seed) || seed < 0) {
    throw new Error("The seed must be a whole number, 0 or more (press 🎲 for a random one).");
  }
  const material = $("param-material").checked;
  // a number field holds "" for text that is no number: badInput tells it from an empty field
  const widthInput = $("param-width-m");
  const widthText = widthInput.value.trim();
  const widthM = Number(widthText);
  if (material && (widthInput.validity.badInput || (widthText && !(widthM >= WIDTH_M[0] && widthM <= WIDTH_M[1])))) {
    throw new Error(`The width must be a number of metres from ${WIDTH_M[0]} to ${WIDTH_M[1]} (or empty: 0.5 m assumed).`);
  }
  const body = {
    exemplar_id: exemplarId,
    size: `${width}x${height}`,
    seed,
    k: k === null ? 3 : k,
    tile: $("param-tile").checked,
    material,
    method: $("param-method").value,
    strategy: $("param-strategy").value,
    preset: $("param-preset").value,
    equalize_light: Number($("param-equalize-light").value) / 100,
    ...KINDS[kind],
  };
  if (material) body.relief = Number($("param-relief").value);
  if (material && widthText) body.width_m = widthM;
  // every other option the server offers, from its built control
  for (const field of FIELDS) {
    const value = readBuilt(field);
    if (value !== undefined) body[field.name] = value;
  }
  // the crack network as edited in the crack view is what the job learns from
  if (kind === "cracks" && cracks && cracks.edited()) body.crack_structure = cracks.structure();
  return body;
}

/** Keep the settings panel (sticky beside the photo on a wide screen) within the window from
 * wherever it starts, so Generate at its foot is in view without scrolling the page, More
 * settings open or not; on a narrow screen the panel is in the flow and Generate at the
 * window's foot (app.css). */
function fitPanel() {
  const panel = document.querySelector(".params");
  if (!panel) return;
  if (getComputedStyle(panel).position !== "sticky") {
    panel.style.maxHeight = "";
    return;
  }
  const top = Math.max(panel.getBoundingClientRect().top, 12);
  panel.style.maxHeight = `${Math.max(window.innerHeight - top - 12, 240)}px`;
}

function setupForm() {
  fitPanel();
  window.addEventListener("scroll", fitPanel, { passive: true });
  window.addEventListener("resize", fitPanel);
  // and whenever the page above it changes (the photo's details, a notice, an error)
  new ResizeObserver(fitPanel).observe(document.querySelector("main"));
  const form = $("params-form");
  const generate = $("generate");
  const errorBox = $("generate-error");

  const panel = jobPanelIn($("job-panel"), (busy) => {
    generate.disabled = busy;
    generate.textContent = busy ? "Working…" : "Generate bark";
  });

  $("param-seed-roll").addEventListener("click", () => {
    $("param-seed").value = String(randomSeed());
  });
  $("param-size").addEventListener("change", () => {
    if ($("param-size").value !== "custom") setSize($("param-size").value);
  });
  for (const side of ["param-width", "param-height"]) {
    $(side).addEventListener("input", () => {
      const text = `${$("param-width").value}x${$("param-height").value}`;
      const preset = $("param-size");
      preset.value = [...preset.options].some((o) => o.value === text) ? text : "custom";
    });
  }
  $("param-kind").addEventListener("change", updateKind);
  $("param-material").addEventListener("change", updateFields);
  $("param-relief").addEventListener("input", updateFields);
  $("param-equalize-light").addEventListener("input", updateFields);

  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    showError(errorBox, "");
    let body;
    try {
      body = readParams();
    } catch (err) {
      showError(errorBox, err.message);
      return;
    }
    try {
      await panel.start(body);
    } catch (err) {
      // The job panel already shows "failed: …"; repeat it near the button.
      showError(errorBox, err.message);
    }
  });

  const jobId = jobIdFromUrl();
  if (jobId) panel.resume(jobId).then((job) => job && showJobParams(job.params));
}

/** After a reload, show the followed job's settings in the form. */
function showJobParams(params) {
  if (!params) return;
  setSize(Array.isArray(params.size) ? `${params.size[0]}x${params.size[1]}` : params.size);
  if (Number.isInteger(params.k)) {
    $("param-k").value = String(params.k);
    $("param-k").dispatchEvent(new Event("change")); // reload the label map
  }
  if (typeof params.tile === "boolean") $("param-tile").checked = params.tile;
  if (typeof params.material === "boolean") $("param-material").checked = params.material;
  if (Number.isInteger(params.seed)) $("param-seed").value = String(params.seed);
  // a job's params hold the options it changed (the others are the defaults the form has)
  setMaterialValues({ relief: params.relief, equalize_light: params.equalize_light, width_m: params.width_m ?? null });
  for (const field of FIELDS) setBuilt(field, field.name in params ? params[field.name] : field.default);
  const kind = params.structure === "cracks" ? "cracks" : params.model === "bilayer" ? "bilayer" : "labels";
  $("param-kind").value = kind;
  updateKind();
  updateFields();
}

// ---------------------------------------------------------------------------

async function main() {
  if (exemplarId === null) {
    showError($("page-error"), "This address does not name a bark photo. Go back to the library.");
    return;
  }
  try {
    const options = await api.getOptions();
    K_MIN = options.k_range[0];
    K_MAX = options.k_range[1];
    MAX_SIDE = options.max_output_side;
    $("param-k").min = String(K_MIN);
    $("param-k").max = String(K_MAX);
    for (const side of ["param-width", "param-height"]) $(side).max = String(MAX_SIDE);
    $("size-hint").textContent = `Up to ${MAX_SIDE} px a side (this server's limit); bigger takes longer.`;
    applyDefaults(options.fields);
  } catch (err) {
    showError($("page-error"), `Could not load the settings: ${err.message}`);
    applyDefaults([]);
  }
  setupForm();
  // what the photo suits (its crack network extracted in the server) once its label map is
  // shown: the label map, which the page waits for, has the server's cores to itself
  const labelsShown = setupLabels();
  Promise.race([labelsShown, new Promise((resolve) => setTimeout(resolve, KINDS_AFTER_MS))]).then(loadKinds);
  try {
    const exemplar = await api.getExemplar(exemplarId);
    renderExemplar(exemplar);
    // an upload of a photo (or set) the library already had lands here: say so, and which
    // files of a set's zip it was made without
    const query = new URLSearchParams(location.search);
    const notes = [];
    const what = exemplar.maps && exemplar.maps.length ? "set" : "photo";
    if (query.get("existing") === "1") {
      notes.push(`This ${what} was already in your library as “${exemplar.name}”, so here it is (with its earlier results).`);
      query.delete("existing");
      const rest = query.toString();
      history.replaceState(null, "", location.pathname + (rest ? `?${rest}` : ""));
    }
    const leftOutKey = `barkgen-left-out-${exemplarId}`;
    const leftOut = JSON.parse(sessionStorage.getItem(leftOutKey) || "[]");
    sessionStorage.removeItem(leftOutKey);
    if (leftOut.length) notes.push(`Made without: ${leftOut.join("; ")}.`);
    if (notes.length) {
      $("exemplar-notice").textContent = notes.join(" ");
      $("exemplar-notice").hidden = false;
    }
  } catch (err) {
    showError($("page-error"), err.status === 404 ? "This bark photo does not exist (any more)." : err.message);
    $("results-status").textContent = "";
  }
}

main();
