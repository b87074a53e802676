// The crack view of an exemplar page (sibbing2010 §6, Fig. 8): the photo's crack network drawn
// as SVG over the photo, and the user's edits of it. Every edit is made by the server
// (POST .../cracks/edit, barkgen.branching.edit): the page sends the structure and the clicks
// (in the photo's pixels) and draws the structure it is answered. The page keeps the history
// for Undo and the extracted network for Reset; a cracks job is sent the edited network.
//
// Tools: Extend (click near a branch's end, then the target), Furcation (click on a branch,
// then the target), Delete (click a branch: it goes with its sub-branches), Rectify (click the
// four corners of the bark's plane: a new, rectified photo, which the page then shows).

import { getJSON, postJSON } from "./api.js";

const SVG = "http://www.w3.org/2000/svg";
/** A click may be this many screen pixels from a branch. */
const TOLERANCE_PX = 12;
const HINTS = {
  extend: "Extend: click near the end of a branch, then where it should reach.",
  furcation: "Furcation: click on a branch where the new branch starts, then where it ends.",
  delete: "Delete: click a branch; it goes with every branch that starts on it.",
  rectify: "Rectify: click the four corners of the bark's plane in order around it, starting top left.",
};
const CLICKS = { extend: 2, furcation: 2, delete: 1, rectify: 4 };

/** A branch's colour: hues spread by the golden angle, as the CLI's preview. */
const colour = (i) => `hsl(${Math.round((i * 0.618033988749895 * 360) % 360)}, 90%, 60%)`;

function svgEl(tag, attrs) {
  const node = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attrs)) node.setAttribute(key, String(value));
  return node;
}

/**
 * The crack view in `root` (the figure of exemplar.html) for photo `exemplarId`.
 * Returns {show(), edited(), structure()}: show() loads the network when first shown.
 */
export function crackViewIn(root, exemplarId) {
  const $ = (testid) => root.querySelector(`[data-testid="${testid}"]`);
  const svg = $("crack-svg");
  const status = $("crack-status");
  const errorBox = $("crack-error");
  let original = null; // the extracted network (structure JSON)
  let structure = null; // the one shown
  const history = []; // the structures before each edit
  let tool = null;
  let pending = []; // the clicks of the tool so far, photo pixels
  let busy = false;
  let loading = null;

  const size = () => (structure ? structure.size : [1, 1]);
  /** Photo pixels per screen pixel. */
  const scale = () => size()[0] / Math.max(svg.getBoundingClientRect().width, 1);

  function say(message, error = "") {
    status.textContent = message;
    errorBox.textContent = error;
    errorBox.hidden = !error;
  }

  function render() {
    const [w, h] = size();
    svg.setAttribute("viewBox", `0 0 ${w} ${h}`);
    $("crack-stage").style.maxWidth = `calc(70vh * ${w / h})`;
    const dot = 3 * scale();
    const nodes = [];
    (structure ? structure.branches : []).forEach((b, i) => {
      nodes.push(
        svgEl("polyline", {
          points: b.points.map((p) => `${p[0]},${p[1]}`).join(" "),
          stroke: colour(i),
          "data-testid": "crack-branch",
          "data-index": i,
          class: "crack-branch",
        })
      );
    });
    for (const b of structure ? structure.branches : []) {
      if (b.parent !== null && b.parent !== undefined) {
        const [x, y] = structure.branches[b.parent].points[b.parent_vertex];
        nodes.push(svgEl("circle", { cx: x, cy: y, r: dot, class: "crack-furcation" }));
      }
    }
    if (tool === "rectify" && pending.length > 1) {
      nodes.push(svgEl("polyline", { points: pending.map((p) => p.join(",")).join(" "), class: "crack-quad" }));
    }
    for (const [x, y] of pending) nodes.push(svgEl("circle", { cx: x, cy: y, r: 1.6 * dot, class: "crack-mark", "data-testid": "crack-mark" }));
    svg.replaceChildren(...nodes);
    const n = structure ? structure.branches.length : 0;
    $("crack-count").textContent = String(n);
    root.dataset.branches = String(n);
    root.dataset.edits = String(history.length);
    root.dataset.tool = tool || "";
    $("crack-undo").disabled = busy || history.length === 0;
    $("crack-reset").disabled = busy || history.length === 0;
    for (const button of root.querySelectorAll("[data-tool]")) {
      button.setAttribute("aria-pressed", String(button.dataset.tool === tool));
      button.disabled = busy || !structure;
    }
  }

  function choose(name) {
    tool = tool === name ? null : name;
    pending = [];
    say(tool ? HINTS[tool] : "Choose a tool to edit the network a crack job learns from.");
    render();
  }

  /** The click in photo pixels, inside the photo. */
  function photoPoint(event) {
    const rect = svg.getBoundingClientRect();
    const [w, h] = size();
    const x = ((event.clientX - rect.left) / rect.width) * w;
    const y = ((event.clientY - rect.top) / rect.height) * h;
    return [Math.min(Math.max(x, 0), w), Math.min(Math.max(y, 0), h)].map((v) => Math.round(v * 100) / 100);
  }

  async function run(action) {
    busy = true;
    render();
    try {
      await action();
    } catch (err) {
      say(tool ? HINTS[tool] : "", err.message);
    } finally {
      busy = false;
      pending = [];
      render();
    }
  }

  async function edit(points) {
    const answer = await postJSON(`/api/exemplars/${exemplarId}/cracks/edit`, {
      structure,
      tool,
      points,
      tolerance: TOLERANCE_PX * scale(),
    });
    history.push(structure);
    structure = answer.structure;
    const n = structure.branches.length;
    const done = {
      extend: `Branch ${answer.branch} extended`,
      furcation: `Branch ${answer.branch} added on branch ${answer.picked}`,
      delete: `Branch ${answer.picked} deleted with its sub-branches`,
    }[tool];
    say(`${done}: ${n} branches. ${HINTS[tool]}`);
  }

  async function rectify(corners) {
    say("Rectifying the photo…");
    const answer = await postJSON(`/api/exemplars/${exemplarId}/rectify`, { corners });
    say(answer.existing ? "This rectified photo is in the library already: opening it…" : "Opening the rectified photo…");
    root.dataset.rectified = String(answer.id);
    location.assign(`/exemplars/${answer.id}?kind=cracks`);
  }

  svg.addEventListener("click", (event) => {
    if (!tool || busy || !structure) return;
    pending.push(photoPoint(event));
    if (pending.length < CLICKS[tool]) {
      const left = CLICKS[tool] - pending.length;
      say(`${HINTS[tool]} ${left} more click${left > 1 ? "s" : ""}.`);
      render();
      return;
    }
    const points = pending.slice();
    run(() => (tool === "rectify" ? rectify(points) : edit(points)));
  });
  for (const button of root.querySelectorAll("[data-tool]")) {
    button.addEventListener("click", () => choose(button.dataset.tool));
  }
  $("crack-undo").addEventListener("click", () => {
    if (!history.length) return;
    structure = history.pop();
    pending = [];
    say(`Undone: ${structure.branches.length} branches.`);
    render();
  });
  $("crack-reset").addEventListener("click", () => {
    structure = original;
    history.length = 0;
    pending = [];
    say(`Back to the photo's own network: ${structure.branches.length} branches.`);
    render();
  });

  async function load() {
    $("crack-loading").hidden = false;
    try {
      original = await getJSON(`/api/exemplars/${exemplarId}/cracks`);
      structure = original;
      say("Choose a tool to edit the network a crack job learns from.");
      root.dataset.loaded = "1";
    } catch (err) {
      say("", `Could not find the photo's cracks: ${err.message}`);
    } finally {
      $("crack-loading").hidden = true;
      render();
    }
  }

  $("crack-photo").addEventListener("load", render); // the dots' size follows the shown size
  render();
  return {
    show() {
      if (!loading) loading = load();
      return loading;
    },
    /** The network was edited (a job is sent it). */
    edited: () => history.length > 0,
    structure: () => structure,
  };
}
