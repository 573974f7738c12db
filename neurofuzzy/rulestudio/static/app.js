// The rule studio's page: state from the server, edits to it, and the tissue it makes.
import { call, query } from "./api.js";
import { el, replaceContent, quantityText, unitText } from "./dom.js";
import { renderVariables, renderRules, renderTissues, renderYaml } from "./editor.js";
import { BlockView } from "./block.js";

const $ = (id) => document.getElementById(id);
const SYMBOLS = { youngs_modulus: "E", poisson_ratio: "ν", viscosity: "η", density: "ρ", stiffness: "k", damping: "c", node_mass: "m" };
let state = null;
let tissue = null;             // the tissue view of the selected tissue
let tissueFresh = false;       // tissue was computed from the current text
let tissueName = null;
let force = null;
let dragging = false;
let message = null;            // {text, kind}
const errors = new Map();      // edit key -> message of an edit the server could not write
const pending = new Map();     // merge key -> edit waiting to be sent
let sending = false;
let serial = 0;
let loading = 0;               // tissue and block requests under way
const block = new BlockView($("block"));

// whether the page still waits for the server (data-busy on <body>, for tests and scripts)
function markBusy() {
  document.body.dataset.busy = sending || pending.size || loading ? "1" : "0";
}

function errorOf(key) {
  const text = key && errors.get(key);
  return el("div", { class: "problem edit-error", "data-for": key || "", text: text || "" });
}

// -- edits: one at a time; a newer edit of the same thing replaces a waiting one ------------
function edit(operation, mergeKey, errorKey) {
  const key = mergeKey || `once:${++serial}`;
  pending.delete(key);
  pending.set(key, { operation, errorKey: errorKey || mergeKey });
  markBusy();
  pump();
}

async function pump() {
  if (sending || pending.size === 0) return;
  const [key, { operation, errorKey }] = pending.entries().next().value;
  pending.delete(key);
  sending = true;
  try {
    const view = await call("api/edit", { edit: operation });
    if (errorKey) errors.delete(errorKey);
    message = null;
    update(view);
  } catch (error) {
    const where = error.detail && error.detail.line ? `line ${error.detail.line}: ` : "";
    if (errorKey) errors.set(errorKey, where + error.message);
    else message = { text: where + error.message, kind: "bad" };
    render();
  } finally {
    sending = false;
    markBusy();
    if (pending.size) pump();
  }
}

function update(view) {
  state = view;
  tissueFresh = false;
  render();
  refreshTissue();
}

// -- the tissue, its values and its block ---------------------------------------------------
let tissueRequest = 0;
async function refreshTissue() {
  loading++;
  markBusy();
  try {
    await loadTissue();
  } finally {
    loading--;
    markBusy();
  }
}

async function loadTissue() {
  if (!state || !state.file) return;
  const names = state.tissues.map((t) => t.name);
  if (!names.includes(tissueName)) tissueName = names[0] || null;
  renderTissuePicker();
  if (!state.valid || !tissueName) { renderSide(); return; }
  const id = ++tissueRequest;
  try {
    const view = await query("api/tissue", { name: tissueName });
    if (id !== tissueRequest) return;
    tissue = view;
    tissueFresh = true;
    $("tissue-note").textContent = "";
  } catch (error) {
    if (id !== tissueRequest) return;
    tissue = null;
    $("tissue-note").textContent = error.message;
  }
  render();
  try {
    const result = await call("api/block", { tissue: tissueName, force });
    if (id !== tissueRequest) return;
    force = result.probe.force;
    if (document.activeElement !== $("force")) $("force").value = force;
    block.show(result);
    const m = result.material;
    $("block-info").className = result.warning ? "note warn" : "note";
    $("block-info").textContent = (result.warning ? result.warning + " — " : "") +
      `${result.positions[0].length} nodes, 108 tetrahedra: E ${quantityText(m.youngs_modulus, "Pa")}, ν ${m.poisson_ratio.toFixed(3)}, ` +
      `η ${quantityText(m.viscosity, "Pa s")}, ρ ${quantityText(m.density, "kg/m^3")}` +
      (m.relaxation_modulus !== undefined ? `, relaxes by g ${m.relaxation_modulus.toPrecision(2)} over τ ${quantityText(m.relaxation_time, "s")}` : "") +
      `; deepest ${(Math.max(...result.depth) * 1000).toFixed(3)} mm; ` +
      `computed in ${(result.seconds * 1000).toFixed(0)} ms`;
  } catch (error) {
    if (id !== tissueRequest) return;
    $("block-info").className = "note warn";
    $("block-info").textContent = error.message;
  }
}

// -- rendering ------------------------------------------------------------------------------
function context() {
  return { edit, errorOf, tissue, tissueFresh, tissueName, fit: state.fit, dragging: (on) => { dragging = on; if (!on) render(); } };
}

function renderHeader() {
  const chain = state.chain.slice(1);
  replaceContent($("file"), [state.file, chain.length ? el("span", { class: "chain", text: ` extends ${chain.join(" → ")}` }) : null]);
  const status = $("status");
  const problems = state.problems.length;
  if (message) { status.textContent = message.text; status.className = message.kind; }
  else if (problems) { status.textContent = `${problems} problem${problems > 1 ? "s" : ""}: not saved until fixed`; status.className = "bad"; }
  else if (state.dirty) { status.textContent = "changed, not saved"; status.className = ""; }
  else { status.textContent = "saved"; status.className = "good"; }
  status.dataset.problems = problems;
  status.dataset.dirty = state.dirty;
  $("undo").disabled = !state.can_undo;
  $("redo").disabled = !state.can_redo;
  $("save").disabled = !state.dirty || problems > 0;
  $("save-as").disabled = problems > 0;
}

function renderProblems() {
  const box = $("problems");
  box.hidden = state.problems.length === 0 && state.notes.length === 0;
  replaceContent(box, [
    state.problems.length ? el("h3", { text: "Problems (as neurofuzzy rules check reports them)" }) : null,
    el("ul", {}, state.problems.map((p) => el("li", { "data-line": p.line, "data-file": p.file, text: p.text.replace(p.path || "", p.file || ""),
      onclick: () => { const target = document.querySelector(`[data-line="${p.line}"]`); if (target) target.scrollIntoView({ block: "center" }); } }))),
    ...state.notes.map((n) => el("div", { class: "note warn", text: n })),
  ]);
}

function renderTissuePicker() {
  const select = $("tissue-select");
  const names = state.tissues.map((t) => t.name);
  if ([...select.options].map((o) => o.value).join() !== names.join()) {
    select.replaceChildren(...names.map((n) => el("option", { value: n, text: n })));
  }
  if (tissueName) select.value = tissueName;
}

// A name_with_underscores that may wrap after each underscore (a narrow panel), not mid-word.
function breakable(name) {
  return name.split("_").flatMap((part, i) => (i ? ["_", el("wbr"), part] : [part]));
}

function renderSide() {
  const stale = !tissueFresh;
  $("values").classList.toggle("stale", stale);
  if (!state.valid) $("tissue-note").textContent = "Fix the problems to see the tissue again (showing the last valid one).";
  if (!tissue) { $("values").replaceChildren(); $("fired").replaceChildren(); $("defaults").textContent = ""; return; }
  const defaults = Object.entries(tissue.defaults || {}).map(([k, v]) => `${k} is ${v}`);
  $("defaults").textContent = defaults.length ? `Not described, so the rule base's defaults: ${defaults.join(", ")}.` : "";
  $("values").replaceChildren(...tissue.outputs.map((o) => el("tr", { class: "value", "data-quantity": o.quantity, "data-value": o.value, "data-term": o.term }, [
    el("td", {}, [el("b", {}, breakable(o.name))]),
    el("td", { class: "num", text: quantityText(o.value, o.unit) }),
    el("td", {}, [el("div", { text: `${o.term} (${o.degree.toFixed(2)})` }),
      el("div", { class: "degrees" }, Object.entries(o.degrees).filter(([, d]) => d > 0.005).sort((a, b) => b[1] - a[1])
        .map(([t, d]) => el("span", { text: `${t} ${d.toFixed(2)}` })))]),
  ])));
  const fired = tissue.rules.filter((r) => r.strength > 0.001).sort((a, b) => b.strength - a.strength);
  const silent = tissue.rules.length - fired.length;
  $("fired").replaceChildren(...fired.map((r) => el("li", { "data-strength": r.strength }, [el("code", { text: r.text }),
    el("div", { class: "bar", title: r.strength.toFixed(3) }, [el("span", { style: `width:${(r.strength * 100).toFixed(0)}%` })])])),
  silent ? el("li", { class: "note", text: `${silent} rule${silent > 1 ? "s" : ""} did not fire` }) : null);
}

function renderFit() {
  const fit = state.fit;
  $("fit-close").hidden = !fit;
  if (!fit) { $("fit").replaceChildren(el("div", { class: "note", text: "Learned values appear on the output plots: ○ start (the rule base's value of the tissue) → ◆ learned." })); return; }
  const rows = [];
  for (const entry of fit.entries) {
    for (const row of entry.rows) {
      const variable = state.variables.find((v) => v.name === row.output);
      const unit = variable ? variable.unit : "";
      const changed = row.before && row.after && row.before !== row.after;
      rows.push(el("tr", { "data-label": entry.label, "data-output": row.output }, [
        el("td", { text: entry.label + (entry.group ? ` [${entry.group}]` : "") }),
        el("td", { text: SYMBOLS[row.quantity] || row.output, title: row.output }),
        el("td", { text: row.start === null ? "–" : `${quantityText(row.start, unit)} ${row.before}` }),
        el("td", { class: changed ? "changed" : "", text: `${quantityText(row.learned, unit)} ${row.after ?? "(outside the universe)"}` }),
        el("td", { class: "note", text: row.recorded && row.recorded !== row.after ? `recorded: ${row.recorded}` : "" }),
      ]));
    }
  }
  $("fit").replaceChildren(el("div", { class: "note", text: `${fit.source}: ${fit.entries.length} fitted region${fit.entries.length > 1 ? "s" : ""}` }),
    el("table", { class: "fit" }, [el("colgroup", {}, ["label", "symbol", "", "", "note"].map((c) => el("col", { class: c }))), el("tr", {}, ["", "", "start: words before", "learned: words after", ""].map((h) => el("th", { text: h }))), ...rows]));
}

function render() {
  if (!state) return;
  if (!state.file) { renderChooser(); return; }
  $("chooser").hidden = true;
  renderHeader();
  renderProblems();
  const ctx = context();
  if (!dragging) replaceContent($("variables"), renderVariables(state, ctx));
  replaceContent($("rules"), renderRules(state, ctx));
  replaceContent($("tissues"), renderTissues(state, ctx));
  $("yaml").replaceChildren(...renderYaml(state));
  renderSide();
  renderFit();
}

function renderChooser() {
  const box = $("chooser");
  box.hidden = false;
  replaceContent(box, [el("h2", { text: `Open a rule file of ${state.folder}` }),
    ...(state.files.length ? state.files.map((name) => el("button", { text: name, onclick: () => openFile(name) }))
      : [el("p", { text: "No rule files here. Start the studio with one: neurofuzzy studio rules/liver.yaml" })])]);
}

async function openFile(name, discard) {
  try { message = null; update(await call("api/open", { name, discard: !!discard })); } catch (error) { message = { text: error.message, kind: "bad" }; render(); }
}

// -- actions --------------------------------------------------------------------------------
async function action(path, body, done) {
  try {
    const result = await call(path, body || {});
    message = done ? { text: done(result), kind: "good" } : null;
    update(result.state || result);
  } catch (error) {
    message = { text: error.message, kind: "bad" };
    render();
  }
}

$("undo").addEventListener("click", () => action("api/undo"));
$("redo").addEventListener("click", () => action("api/redo"));
$("save").addEventListener("click", () => action("api/save", {}, (r) => `saved ${r.saved}`));
$("save-as").addEventListener("click", () => action("api/save", { name: $("save-name").value }, (r) => `saved ${r.saved}; now editing it`));
document.addEventListener("keydown", (event) => {
  if (!(event.ctrlKey || event.metaKey)) return;
  const inField = ["INPUT", "SELECT", "TEXTAREA"].includes(document.activeElement.tagName);
  if (event.key === "s") { event.preventDefault(); if (!$("save").disabled) $("save").click(); }
  else if (event.key.toLowerCase() === "z" && !inField) { event.preventDefault(); $(event.shiftKey ? "redo" : "undo").click(); }
});
$("tissue-select").addEventListener("change", (e) => { tissueName = e.target.value; tissue = null; refreshTissue(); });
$("force").addEventListener("change", (e) => { const v = Number(e.target.value); if (v > 0) { force = v; refreshTissue(); } });
$("replay").addEventListener("click", () => block.replay());

async function listFits() {
  try {
    const { results } = await query("api/fits", {});
    $("fit-select").replaceChildren(...(results.length ? results : ["(no fit results in this folder)"]).map((r) => el("option", { value: results.length ? r : "", text: r })));
  } catch (_) { /* the folder cannot be listed: the file picker still works */ }
}
$("fit-open").addEventListener("click", () => { if ($("fit-select").value) action("api/fit", { path: $("fit-select").value }); });
$("fit-close").addEventListener("click", () => action("api/fit/close"));
$("fit-file").addEventListener("change", async (e) => {
  const file = e.target.files[0];
  if (!file) return;
  let content;
  try { content = JSON.parse(await file.text()); } catch (_) { message = { text: `${file.name} is not JSON`, kind: "bad" }; render(); return; }
  action("api/fit", { content, name: file.name });
});

(async () => {
  try { update(await call("api/state")); listFits(); } catch (error) { $("status").textContent = error.message; $("status").className = "bad"; }
})();
export { unitText };
