// Library page: upload a photo, browse the exemplars, watch running jobs.

import { api, el, showError, describeParams } from "./api.js";
import { describeJob } from "./jobs.js";

const JOBS_REFRESH_MS = 2000;

const $ = (testid) => document.querySelector(`[data-testid="${testid}"]`);

/** Exemplar names by id, for the jobs strip. */
const exemplarNames = new Map();

// ---------------------------------------------------------------------------
// Exemplar grid

function exemplarCard(ex) {
  const title = ex.name || `Photo #${ex.id}`;
  const size = ex.width && ex.height ? `${ex.width} × ${ex.height} px` : "";
  return el(
    "a",
    { class: "card", href: `/exemplars/${ex.id}`, "data-testid": "exemplar-card", dataset: { id: ex.id } },
    el("div", { class: "card-thumb" }, el("img", { src: ex.thumbnail_url, alt: title, loading: "lazy" })),
    el(
      "div",
      { class: "card-body" },
      el("div", { class: "card-title", text: title }),
      ex.species ? el("div", { class: "card-meta species", text: ex.species }) : null,
      el("div", { class: "card-meta", text: size })
    )
  );
}

async function loadLibrary() {
  const status = $("library-status");
  const grid = $("exemplar-grid");
  try {
    const exemplars = await api.listExemplars();
    grid.replaceChildren(...exemplars.map(exemplarCard));
    exemplars.forEach((ex) => exemplarNames.set(ex.id, ex.name || `Photo #${ex.id}`));
    status.textContent = exemplars.length
      ? `${exemplars.length} photo${exemplars.length === 1 ? "" : "s"} — click one to generate bark from it.`
      : "No photos yet: upload one above.";
    showError($("library-error"), "");
  } catch (err) {
    status.textContent = "";
    showError($("library-error"), `Could not load the library: ${err.message}`);
  }
}

// ---------------------------------------------------------------------------
// Upload

function setupUpload() {
  const form = $("upload-form");
  const fileInput = $("upload-file");
  const submit = $("upload-submit");
  const progress = $("upload-progress");
  const status = $("upload-status");
  const errorBox = $("upload-error");

  // Pre-fill the name from the file name, unless the user typed one.
  fileInput.addEventListener("change", () => {
    showError(errorBox, "");
    const nameInput = $("upload-name");
    const file = fileInput.files[0];
    if (file && !nameInput.value.trim()) {
      nameInput.placeholder = file.name.replace(/\.[^.]+$/, "");
    }
  });

  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    showError(errorBox, "");
    const file = fileInput.files[0];
    if (!file) {
      showError(errorBox, "Choose a photo (or a set's zip) first.");
      fileInput.focus();
      return;
    }
    const data = new FormData();
    data.append("file", file, file.name);
    for (const field of ["name", "species", "licence"]) {
      const value = form.elements[field].value.trim();
      if (value) data.append(field, value);
    }

    submit.disabled = true;
    progress.hidden = false;
    progress.value = 0;
    status.textContent = "Uploading…";
    try {
      const answer = await api.uploadExemplar(data, (fraction) => {
        progress.value = fraction;
        status.textContent = fraction < 1 ? `Uploading… ${Math.round(fraction * 100)} %` : `Checking the ${file.name.toLowerCase().endsWith(".zip") ? "set" : "photo"}…`;
      });
      status.textContent = answer.existing ? "Already in the library — opening it…" : "Uploaded — opening…";
      // the files of a set's zip it was made without: its page says which
      if (answer.left_out) sessionStorage.setItem(`barkgen-left-out-${answer.id}`, JSON.stringify(answer.left_out));
      location.assign(`/exemplars/${answer.id}${answer.existing ? "?existing=1" : ""}`);
    } catch (err) {
      showError(errorBox, err.message);
      status.textContent = "";
      progress.hidden = true;
      submit.disabled = false;
    }
  });
}

// ---------------------------------------------------------------------------
// Jobs strip (queued and running jobs, refreshed every 2 s)

function jobItem(job) {
  const name = exemplarNames.get(job.exemplar_id) || `Photo #${job.exemplar_id}`;
  return el(
    "li",
    { class: "job-item", "data-testid": "job-item", dataset: { state: job.state } },
    el("a", { href: `/exemplars/${job.exemplar_id}?job=${encodeURIComponent(job.id)}` }, name),
    el("span", { class: "job-params",
                 text: job.kind === "labels" ? `label map · k=${job.params.k}` : describeParams(job.params) }),
    el("progress", { max: 1, value: Number(job.progress) || 0 }),
    el("span", { class: "job-text", text: describeJob(job) })
  );
}

async function refreshJobs() {
  const strip = $("jobs-strip");
  try {
    const jobs = await api.listJobs();
    const active = jobs.filter((j) => j.state === "queued" || j.state === "running");
    $("jobs-list").replaceChildren(...active.map(jobItem));
    strip.hidden = active.length === 0;
  } catch {
    // The strip is a convenience: stay quiet and try again later.
  }
}

function startJobsStrip() {
  // one polling loop at a time: a tick of an older loop (hidden then shown again while it
  // was fetching) ends instead of scheduling another
  let timer = null;
  let loop = 0;
  const tick = async (mine) => {
    await refreshJobs();
    if (mine === loop && !document.hidden) timer = setTimeout(() => tick(mine), JOBS_REFRESH_MS);
  };
  document.addEventListener("visibilitychange", () => {
    clearTimeout(timer);
    loop += 1;
    if (!document.hidden) tick(loop);
  });
  tick(loop);
}

// ---------------------------------------------------------------------------

setupUpload();
loadLibrary().then(startJobsStrip);
