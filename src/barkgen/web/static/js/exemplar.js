// Exemplar page: the photo, its label map for the chosen k, the parameter
// form, the job panel and the earlier results of this photo.

import { api, el, idFromPath, showError, formatDate, describeParams } from "./api.js";
import { jobPanelIn, jobIdFromUrl } from "./jobs.js";

const $ = (testid) => document.querySelector(`[data-testid="${testid}"]`);

const SIZES = ["256x256", "512x512", "1024x1024", "2048x2048"];
const K_MIN = 2;
const K_MAX = 5;
/** How often a label job is checked while the label map is made (ms). */
const LABEL_POLL_MS = 300;

const exemplarId = idFromPath();

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
  }
  const photo = $("exemplar-photo");
  photo.src = ex.photo_url;
  photo.alt = `Bark photo: ${name}`;
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

function setupLabels() {
  const img = $("labels-in");
  const loading = $("labels-loading");
  const errorBox = $("labels-error");
  let shownK = null;

  const fail = (message) => {
    loading.hidden = true;
    showError(errorBox, message);
    shownK = null; // allow a retry with the same k
  };

  // The label map is made by a label job in the server's worker (it takes seconds on a large
  // photo): ask for it, follow the job, then show the picture.
  const load = async () => {
    const k = currentK();
    if (k === null || k === shownK) return;
    shownK = k;
    $("labels-k").textContent = String(k);
    showError(errorBox, "");
    loading.hidden = false;
    img.classList.add("is-loading");
    try {
      const answer = await api.requestLabels(exemplarId, k);
      let job = answer.job;
      while (job && job.state !== "done") {
        if (job.state === "failed" || job.state === "cancelled") {
          throw new Error(job.error || `the label job was ${job.state}`);
        }
        await new Promise((resolve) => setTimeout(resolve, LABEL_POLL_MS));
        if (shownK !== k) return; // k changed meanwhile: that load takes over
        job = await api.getJob(job.id);
      }
      if (shownK === k) img.src = answer.url;
    } catch (err) {
      if (shownK === k) fail(`Could not compute the label map for k = ${k}: ${err.message}`);
    }
  };
  img.addEventListener("load", () => {
    loading.hidden = true;
    img.classList.remove("is-loading");
  });
  img.addEventListener("error", () => {
    if (!img.getAttribute("src")) return;
    fail(`Could not load the label map for k = ${shownK}.`);
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
  load();
}

// ---------------------------------------------------------------------------
// Parameter form and job

/** Defaults from the URL (the result page's "Generate another seed" link). */
function applyQueryDefaults() {
  const q = new URLSearchParams(location.search);
  if (SIZES.includes(q.get("size"))) $("param-size").value = q.get("size");
  const k = Number(q.get("k"));
  if (Number.isInteger(k) && k >= K_MIN && k <= K_MAX) $("param-k").value = String(k);
  if (q.has("tile")) $("param-tile").checked = q.get("tile") !== "0" && q.get("tile") !== "false";
  if (q.has("material")) $("param-material").checked = q.get("material") !== "0" && q.get("material") !== "false";
  const seed = Number(q.get("seed"));
  $("param-seed").value = String(q.has("seed") && Number.isInteger(seed) && seed >= 0 ? seed : randomSeed());
}

/** Read and check the form; returns the job body or throws Error(message). */
function readParams() {
  const k = currentK();
  if (k === null) throw new Error(`Labels (k) must be a whole number from ${K_MIN} to ${K_MAX}.`);
  const seedText = $("param-seed").value.trim();
  const seed = Number(seedText);
  if (!seedText || !Number.isInteger(seed) || seed < 0) {
    throw new Error("The seed must be a whole number, 0 or more (press 🎲 for a random one).");
  }
  return {
    exemplar_id: exemplarId,
    size: $("param-size").value,
    seed,
    k,
    tile: $("param-tile").checked,
    material: $("param-material").checked,
  };
}

function setupForm() {
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
  const size = Array.isArray(params.size) ? `${params.size[0]}x${params.size[1]}` : params.size;
  if (SIZES.includes(size)) $("param-size").value = size;
  if (Number.isInteger(params.k)) {
    $("param-k").value = String(params.k);
    $("param-k").dispatchEvent(new Event("change")); // reload the label map
  }
  if (typeof params.tile === "boolean") $("param-tile").checked = params.tile;
  if (typeof params.material === "boolean") $("param-material").checked = params.material;
  if (Number.isInteger(params.seed)) $("param-seed").value = String(params.seed);
}

// ---------------------------------------------------------------------------

async function main() {
  if (exemplarId === null) {
    showError($("page-error"), "This address does not name a bark photo. Go back to the library.");
    return;
  }
  applyQueryDefaults();
  setupForm();
  setupLabels();
  try {
    const exemplar = await api.getExemplar(exemplarId);
    renderExemplar(exemplar);
    // an upload of a photo the library already had lands here: say so
    const query = new URLSearchParams(location.search);
    if (query.get("existing") === "1") {
      const notice = $("exemplar-notice");
      notice.textContent = `This photo was already in your library as “${exemplar.name}”, so here it is (with its earlier results).`;
      notice.hidden = false;
      query.delete("existing");
      const rest = query.toString();
      history.replaceState(null, "", location.pathname + (rest ? `?${rest}` : ""));
    }
  } catch (err) {
    showError($("page-error"), err.status === 404 ? "This bark photo does not exist (any more)." : err.message);
    $("results-status").textContent = "";
  }
}

main();
