// Job progress, shared by the exemplar page (generate) and the result page
// (continue synthesis from a painted label map).
//
// A JobPanel owns the panel elements (state text, <progress>, cancel button),
// starts a job (POST /api/jobs), records its id in the URL (?job=ID) so a
// reload reconnects, and follows it through server-sent events, falling back
// to polling GET /api/jobs/{id} if the event stream breaks. When the job is
// done it opens the new result.

import { api } from "./api.js";

const TERMINAL = new Set(["done", "failed", "cancelled"]);
const POLL_MS = 1000;
const MAX_RECONNECTS = 5;

/** One short human sentence for a job object. */
export function describeJob(job) {
  if (!job) return "";
  const pct = Math.round((Number(job.progress) || 0) * 100);
  switch (job.state) {
    case "queued": {
      // queue_position: how many jobs are ahead of this one (the running one included)
      const ahead = Number.isInteger(job.queue_position) ? job.queue_position : 0;
      if (ahead <= 0) return "queued — starting…";
      return `queued — ${ahead} job${ahead === 1 ? "" : "s"} ahead`;
    }
    case "running":
      return job.stage ? `running ${pct} % — ${job.stage}` : `running ${pct} %`;
    case "done":
      return "done";
    case "failed":
      return `failed: ${job.error || "unknown error"}`;
    case "cancelled":
      return "cancelled";
    default:
      return String(job.state || "unknown");
  }
}

/** Read ?job=ID from the page URL (null when absent). */
export function jobIdFromUrl() {
  return new URLSearchParams(location.search).get("job");
}

/** Put ?job=ID into the URL (or remove it with null) without reloading. */
export function setJobInUrl(jobId) {
  const url = new URL(location.href);
  if (jobId) url.searchParams.set("job", jobId);
  else url.searchParams.delete("job");
  history.replaceState(history.state, "", url.pathname + url.search + url.hash);
}

export class JobPanel {
  /**
   * @param {object} opts
   * @param {HTMLElement} opts.root       panel shown while a job is followed
   * @param {HTMLElement} opts.stateEl    [data-testid=job-state]
   * @param {HTMLProgressElement} opts.progressEl  [data-testid=job-progress]
   * @param {HTMLButtonElement} opts.cancelBtn     [data-testid=job-cancel]
   * @param {(busy:boolean)=>void} [opts.onBusy]  called with true when a job
   *        starts and false when it ends without a result (to re-enable forms)
   */
  constructor({ root, stateEl, progressEl, cancelBtn, onBusy }) {
    this.root = root;
    this.stateEl = stateEl;
    this.progressEl = progressEl;
    this.cancelBtn = cancelBtn;
    this.onBusy = onBusy || (() => {});
    this.jobId = null;
    this.source = null;
    this.pollTimer = null;
    this.finished = true;

    this.cancelBtn.addEventListener("click", () => this.cancel());
    // Coming back with the back button may restore this page from the
    // back/forward cache in its "opening result…" state: make it usable.
    window.addEventListener("pageshow", (event) => {
      if (event.persisted && this.finished) this.onBusy(false);
    });
  }

  /** POST a new job and follow it. Throws Error(detail) if the POST fails. */
  async start(body) {
    this.onBusy(true);
    this.show({ state: "queued", progress: 0 }, "submitting…");
    let job;
    try {
      job = await api.createJob(body);
    } catch (err) {
      this.showText(`failed: ${err.message}`);
      this.cancelBtn.disabled = true;
      this.onBusy(false);
      throw err;
    }
    setJobInUrl(job.id);
    this.follow(job.id);
    return job.id;
  }

  /** Reconnect to a job whose id came from the URL (page reload); resolves the job (or null). */
  async resume(jobId) {
    this.onBusy(true);
    this.showText("reconnecting…");
    try {
      const job = await api.getJob(jobId);
      if (TERMINAL.has(job.state)) {
        // Already over: show the outcome without jumping pages on load.
        this.jobId = jobId;
        this.finished = true;
        this.update(job, { navigate: false });
        return job;
      }
      this.follow(jobId);
      return job;
    } catch (err) {
      this.showText(`failed: ${err.status === 404 ? "this job no longer exists." : err.message}`);
      this.cancelBtn.disabled = true;
      setJobInUrl(null);
      this.onBusy(false);
      return null;
    }
  }

  /** Follow a job's server-sent events. */
  follow(jobId) {
    this.stop();
    this.jobId = jobId;
    this.finished = false;
    this.reconnects = 0;
    this.root.hidden = false;
    this.cancelBtn.disabled = false;
    this.listen();
  }

  /** Open the event stream; if it breaks, check the job and reopen (or poll). */
  listen() {
    if (typeof EventSource === "undefined") {
      this.poll();
      return;
    }
    const source = new EventSource(api.jobEventsUrl(this.jobId));
    this.source = source;
    source.addEventListener("message", (event) => {
      let job;
      try {
        job = JSON.parse(event.data);
      } catch {
        return; // ignore keep-alive or malformed lines
      }
      this.reconnects = 0;
      this.update(job);
    });
    source.addEventListener("error", async () => {
      if (this.source !== source) return;
      source.close();
      this.source = null;
      if (this.finished) return;
      // The stream ended before the job did: ask once, then listen again.
      // After a few broken streams in a row, fall back to plain polling.
      this.reconnects += 1;
      if (this.reconnects > MAX_RECONNECTS) {
        this.poll();
        return;
      }
      await this.check();
      if (!this.finished) this.pollTimer = setTimeout(() => this.listen(), POLL_MS);
    });
  }

  /** GET the job once and apply it. */
  async check() {
    const jobId = this.jobId;
    try {
      const job = await api.getJob(jobId);
      if (jobId === this.jobId) this.update(job);
    } catch (err) {
      if (jobId !== this.jobId) return;
      if (err.status === 404) {
        this.finish();
        setJobInUrl(null);
        this.showText("failed: this job no longer exists.");
        this.onBusy(false);
        return;
      }
      this.showText(`connection lost — retrying… (${err.message})`);
    }
  }

  /** Poll GET /api/jobs/{id} until the job is over. */
  async poll() {
    if (this.finished || !this.jobId) return;
    await this.check();
    if (!this.finished) this.pollTimer = setTimeout(() => this.poll(), POLL_MS);
  }

  /** Ask the server to cancel the followed job. */
  async cancel() {
    if (!this.jobId || this.finished) return;
    this.cancelBtn.disabled = true;
    try {
      const job = await api.cancelJob(this.jobId);
      if (job && job.state) this.update(job);
    } catch (err) {
      this.showText(`could not cancel: ${err.message}`);
      if (!this.finished) this.cancelBtn.disabled = false;
    }
  }

  /** Apply a job object to the panel; on a terminal state wrap up. */
  update(job, { navigate = true } = {}) {
    if (!job || (job.id && this.jobId && String(job.id) !== String(this.jobId))) return;
    this.show(job);
    if (!TERMINAL.has(job.state)) return;

    this.finish();
    setJobInUrl(null);
    if (job.state === "done" && job.result_id !== null && job.result_id !== undefined) {
      const url = `/results/${job.result_id}`;
      if (navigate) {
        this.showText("done — opening the result…");
        location.assign(url);
        return; // stay "busy" while the next page loads
      }
      this.stateEl.textContent = "done — ";
      const link = document.createElement("a");
      link.href = url;
      link.textContent = "open the result";
      this.stateEl.append(link);
    }
    this.onBusy(false);
  }

  /** Render state text and progress. */
  show(job, text) {
    this.root.hidden = false;
    this.stateEl.textContent = text || describeJob(job);
    this.stateEl.dataset.state = job.state || "";
    const progress = job.state === "done" ? 1 : Math.min(1, Math.max(0, Number(job.progress) || 0));
    this.progressEl.value = progress;
    this.root.classList.toggle("is-failed", job.state === "failed");
    this.root.classList.toggle("is-done", job.state === "done");
  }

  showText(text) {
    this.root.hidden = false;
    this.stateEl.textContent = text;
    this.root.classList.toggle("is-failed", text.startsWith("failed"));
  }

  /** Stop listening; the job is over. */
  finish() {
    this.finished = true;
    this.cancelBtn.disabled = true;
    this.stop();
  }

  stop() {
    if (this.source) {
      this.source.close();
      this.source = null;
    }
    if (this.pollTimer) {
      clearTimeout(this.pollTimer);
      this.pollTimer = null;
    }
  }
}

/** Wire a standard job panel found by data-testids inside `root`. */
export function jobPanelIn(root, onBusy) {
  return new JobPanel({
    root,
    stateEl: root.querySelector('[data-testid="job-state"]'),
    progressEl: root.querySelector('[data-testid="job-progress"]'),
    cancelBtn: root.querySelector('[data-testid="job-cancel"]'),
    onBusy,
  });
}
