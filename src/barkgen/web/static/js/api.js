// Small fetch helpers for barkgen's JSON API.
//
// Every helper resolves with the parsed JSON body on a 2xx answer and throws
// an Error whose message is the server's one-sentence `detail` otherwise, so
// callers can show `err.message` in the page as is.

/** Turn a non-2xx answer's body into a readable sentence. */
function detailMessage(status, statusText, bodyText) {
  if (bodyText) {
    try {
      const body = JSON.parse(bodyText);
      const detail = body && body.detail;
      if (typeof detail === "string" && detail) return detail;
      // FastAPI validation errors (422) carry a list of {loc, msg}.
      if (Array.isArray(detail) && detail.length) {
        return detail
          .map((d) => (d && d.msg ? `${(d.loc || []).slice(1).join(".") || "request"}: ${d.msg}` : String(d)))
          .join("; ");
      }
    } catch {
      // Not JSON: fall through to the generic message.
    }
  }
  if (status === 413) return "The file is too large.";
  return `The server answered ${status}${statusText ? " " + statusText : ""}.`;
}

/** fetch() wrapper: network failures become a clear Error too. */
async function request(url, options = {}) {
  let response;
  try {
    response = await fetch(url, { headers: { Accept: "application/json" }, ...options });
  } catch (err) {
    throw new Error(`Could not reach the barkgen server (${err.message}).`);
  }
  const text = await response.text();
  if (!response.ok) {
    const error = new Error(detailMessage(response.status, response.statusText, text));
    error.status = response.status;
    throw error;
  }
  if (!text) return null;
  try {
    return JSON.parse(text);
  } catch {
    throw new Error(`The server sent an unreadable answer for ${url}.`);
  }
}

/** GET a JSON resource. */
export function getJSON(url) {
  return request(url);
}

/** POST a JSON body, returns the JSON answer. */
export function postJSON(url, body) {
  return request(url, {
    method: "POST",
    headers: { Accept: "application/json", "Content-Type": "application/json" },
    body: JSON.stringify(body),
  });
}

/** DELETE a resource, returns the JSON answer (if any). */
export function deleteJSON(url) {
  return request(url, { method: "DELETE" });
}

/**
 * POST a multipart form with upload progress (fetch cannot report it, so this
 * uses XMLHttpRequest). `onProgress(fraction)` is called while the body is
 * sent. Resolves with the JSON answer; rejects with Error(detail).
 */
export function postForm(url, formData, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open("POST", url);
    xhr.setRequestHeader("Accept", "application/json");
    if (onProgress) {
      xhr.upload.addEventListener("progress", (event) => {
        if (event.lengthComputable) onProgress(event.loaded / event.total);
      });
    }
    xhr.addEventListener("load", () => {
      if (xhr.status >= 200 && xhr.status < 300) {
        try {
          resolve(xhr.responseText ? JSON.parse(xhr.responseText) : null);
        } catch {
          reject(new Error("The server sent an unreadable answer."));
        }
      } else {
        const error = new Error(detailMessage(xhr.status, xhr.statusText, xhr.responseText));
        error.status = xhr.status;
        reject(error);
      }
    });
    xhr.addEventListener("error", () =>
      reject(new Error("The upload failed: the server closed the connection (is the file too large?)."))
    );
    xhr.addEventListener("abort", () => reject(new Error("The upload was cancelled.")));
    xhr.send(formData);
  });
}

// ---------------------------------------------------------------------------
// Named endpoints (thin wrappers, so pages read like the API description).

export const api = {
  listExemplars: () => getJSON("/api/exemplars"),
  getExemplar: (id) => getJSON(`/api/exemplars/${encodeURIComponent(id)}`),
  uploadExemplar: (formData, onProgress) => postForm("/api/exemplars", formData, onProgress),
  // the photo's label map: {url, job} (job: the label job making it, null once it is made)
  requestLabels: (id, k, method = "color") =>
    postJSON(
      `/api/exemplars/${encodeURIComponent(id)}/labels?k=${encodeURIComponent(k)}&method=${encodeURIComponent(method)}`,
      {}
    ),
  // which kinds of bark the photo suits: {labels, cracks, bilayer: {suits, why}}
  getKinds: (id) => getJSON(`/api/exemplars/${encodeURIComponent(id)}/kinds`),
  // the generate form's fields (defaults shared with the CLI), limits and layouts
  getOptions: () => getJSON("/api/options"),
  listJobs: () => getJSON("/api/jobs"),
  getJob: (id) => getJSON(`/api/jobs/${encodeURIComponent(id)}`),
  createJob: (body) => postJSON("/api/jobs", body),
  cancelJob: (id) => deleteJSON(`/api/jobs/${encodeURIComponent(id)}`),
  jobEventsUrl: (id) => `/api/jobs/${encodeURIComponent(id)}/events`,
  getResult: (id) => getJSON(`/api/results/${encodeURIComponent(id)}`),
};

// ---------------------------------------------------------------------------
// The server's settings: on a read-only server (`barkgen serve --read-only`) the page hides
// what would be refused (elements marked `data-changes`, see app.css).

/** Resolves with {read_only}; a server that cannot say is taken as a writable one. */
export const serverSettings = getJSON("/api/server").catch(() => ({ read_only: false }));
serverSettings.then((settings) => {
  if (settings && settings.read_only) document.documentElement.classList.add("read-only");
});

// ---------------------------------------------------------------------------
// Small shared page helpers.

/** The last numeric path segment, e.g. 12 for "/exemplars/12". */
export function idFromPath() {
  const parts = location.pathname.split("/").filter(Boolean);
  const last = parts[parts.length - 1] || "";
  return /^\d+$/.test(last) ? Number(last) : null;
}

/** Create an element with attributes and children in one call. */
export function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (value === null || value === undefined || value === false) continue;
    if (key === "class") node.className = value;
    else if (key === "text") node.textContent = value;
    else if (key === "dataset") Object.assign(node.dataset, value);
    else if (key === "style") Object.assign(node.style, value);
    else node.setAttribute(key, value === true ? "" : String(value));
  }
  for (const child of children.flat()) {
    if (child === null || child === undefined || child === false) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

/** Show (or clear, with an empty message) an error box. */
export function showError(box, message) {
  if (!box) return;
  box.textContent = message || "";
  box.hidden = !message;
}

/** "2024-05-01T12:00:00" → a short local date/time. */
export function formatDate(iso) {
  if (!iso) return "";
  const date = new Date(iso);
  if (Number.isNaN(date.getTime())) return String(iso);
  return date.toLocaleString(undefined, { dateStyle: "medium", timeStyle: "short" });
}

/** Summarise job/result parameters in one short line. */
export function describeParams(params) {
  if (!params) return "";
  const parts = [];
  const size = Array.isArray(params.size) ? params.size.join("×") : String(params.size || "").replace("x", "×");
  if (size) parts.push(size);
  if (params.k !== undefined && params.k !== null) parts.push(`k=${params.k}`);
  if (params.seed !== undefined && params.seed !== null) parts.push(`seed ${params.seed}`);
  if (params.structure === "cracks") parts.push(params.crack_structure ? "edited cracks" : "cracks");
  if (params.model === "bilayer") parts.push("bi-layer");
  if (params.tile) parts.push("tileable");
  if (params.material) parts.push("material");
  if (params.resumed_from || params.resume) parts.push("painted");
  return parts.join(" · ");
}
