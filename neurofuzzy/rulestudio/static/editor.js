// The editing side of the page: variables (plots and numbers), rules as sentences, tissues,
// and the file as it will be saved. Every change is sent as an edit (data, never code).
import { el } from "./dom.js";
import { membershipPlot, COLORS } from "./plot.js";
import { newTerm } from "./membership.js";

const GROUP_COLORS = ["#111", "#d9480f", "#2b8a3e", "#ae3ec9", "#0b7285", "#e67700"];

// problems of the opened file (or of the file a thing comes from) within its lines
export function problemsIn(state, file, first, last) {
  return state.problems.filter((p) => p.file === file && p.line !== null && p.line >= first && p.line <= last);
}

function problemLines(list) {
  return list.map((p) => el("div", { class: "problem", "data-line": p.line, text: `${p.file}:${p.line}: ${p.message}` }));
}

function origin(state, thing) {
  if (thing.own) return el("span", { class: "badge own", text: `${thing.file}:${thing.line}` });
  return el("span", { class: "badge", title: `taken from ${thing.file}; a change copies it into ${state.file}`,
    text: `from ${thing.file}:${thing.line}` });
}

export function renderVariables(state, ctx) {
  return state.variables.map((variable) => {
    const problems = variable.own ? problemsIn(state, variable.file, variable.line, variable.end_line)
      : problemsIn(state, variable.file, variable.line, variable.end_line);
    const output = ctx.tissue && ctx.tissue.outputs.find((o) => o.name === variable.name);
    const fits = [];
    if (variable.role === "output" && ctx.fit) {
      const groups = [...new Set(ctx.fit.entries.map((e) => e.group))];
      for (const entry of ctx.fit.entries) {
        for (const row of entry.rows) {
          if (row.output !== variable.name) continue;
          fits.push({ label: entry.label, start: row.start, learned: row.learned,
            color: GROUP_COLORS[groups.indexOf(entry.group) % GROUP_COLORS.length] });
        }
      }
    }
    const role = variable.role;
    const send = (edit, key) => ctx.edit({ role, variable: variable.name, ...edit }, key);
    const plot = membershipPlot(variable, {
      value: output ? output.value : null,
      aggregate: output && ctx.tissueFresh ? output.set : null,
      fits,
      onDragStart: () => ctx.dragging(true),
      onDrag: (term, kind, params, final) => {
        send({ op: "set_term", term, kind, params }, `term:${role}:${variable.name}:${term}`);
        if (final) ctx.dragging(false);
      },
    });
    const rows = variable.terms.map((term, index) => termRow(state, variable, term, index, send, ctx));
    const addName = el("input", { class: "name", placeholder: "new term", "data-key": `new-term:${role}:${variable.name}`, size: 10 });
    const add = el("button", { class: "small", text: "+ term", onclick: () => {
      if (!variable.universe) return;
      const { kind, params } = newTerm(variable.universe);
      send({ op: "add_term", term: addName.value.trim(), kind, params }, null);
    } });
    const universe = variable.universe;
    return el("div", { class: `variable ${problems.length ? "has-problem" : ""}`, id: `var-${role}-${variable.name}`, "data-var": variable.name }, [
      el("div", { class: "var-head" }, [
        el("b", { text: variable.name }),
        el("span", { class: "note", text: `${role}${variable.quantity && variable.quantity !== variable.name ? " = " + variable.quantity : ""}` +
          (universe ? ` · ${universe.low}…${universe.high} ${variable.unit || ""} (${universe.scale})` : "") }),
        origin(state, variable),
      ]),
      plot,
      el("table", { class: "terms" }, rows),
      el("div", { class: "add-row" }, [addName, add, ctx.errorOf(`new-term:${role}:${variable.name}`)]),
      ...problemLines(problems),
    ]);
  });
}

function termRow(state, variable, term, index, send, ctx) {
  const key = `term:${variable.role}:${variable.name}:${term.name}`;
  const name = el("input", { class: "name", value: term.name, "data-key": `${key}:name`, "aria-label": `name of ${term.name}`,
    onchange: (e) => send({ op: "rename_term", term: term.name, new: e.target.value.trim() }, null) });
  name.style.borderLeft = `4px solid ${COLORS[index % COLORS.length]}`;
  const kinds = el("select", { "data-key": `${key}:kind`, onchange: (e) => {
    const kind = e.target.value;
    const count = state.kinds[kind].count;
    const fresh = newTerm(variable.universe).params;
    const params = kind === "points" ? [[fresh[0], 0], [fresh[1], 1], [fresh[2], 0]]
      : kind === "trapmf" ? [fresh[0], fresh[1], fresh[1], fresh[2]]
      : kind === "gaussmf" ? [fresh[1], variable.universe.scale === "log" ? 0.3 : (fresh[2] - fresh[0]) / 4]
      : kind === "gbellmf" ? [variable.universe.scale === "log" ? 0.3 : (fresh[2] - fresh[0]) / 3, 2, fresh[1]]
      : kind === "sigmf" ? [fresh[1], variable.universe.scale === "log" ? 5 : 2] : fresh.slice(0, count);
    send({ op: "set_term", term: term.name, kind, params }, key);
  } }, Object.keys(state.kinds).map((k) => el("option", { value: k, text: k, selected: k === term.kind })));
  const params = Array.isArray(term.params) ? term.params.flat() : [];
  const inputs = params.map((value, i) => el("input", {
    class: "param", value, "data-key": `${key}:p${i}`, "data-var": variable.name, "data-term": term.name, "data-param": i,
    "aria-label": `${term.name} parameter ${i + 1}`, inputmode: "decimal",
    oninput: (e) => {
      const row = e.target.closest("tr");
      const values = [...row.querySelectorAll("input.param")].map((input) => Number(input.value));
      if (values.some((v) => !isFinite(v)) || e.target.value.trim() === "") { e.target.classList.add("invalid"); return; }
      e.target.classList.remove("invalid");
      const shaped = term.kind === "points" ? values.reduce((out, v, j) => (j % 2 ? out[out.length - 1].push(v) : out.push([v]), out), []) : values;
      send({ op: "set_term", term: term.name, kind: term.kind, params: shaped }, key);
    },
  }));
  const remove = el("button", { class: "small", text: "✕", title: `delete ${term.name}`,
    onclick: () => send({ op: "delete_term", term: term.name }, null) });
  return el("tr", {}, [el("td", {}, name), el("td", {}, kinds), el("td", {}, inputs),
    el("td", {}, [remove, ctx.errorOf(key)]), el("td", { class: "note", text: term.line ? `line ${term.line}` : "" })]);
}

export function renderRules(state, ctx) {
  const strengths = ctx.tissue && ctx.tissueFresh ? ctx.tissue.rules : null;
  const list = state.rules.map((rule, position) => {
    const key = rule.own ? `rule:${rule.index}` : `inherited-rule:${position}`;
    const problems = problemsIn(state, rule.file, rule.line, rule.end_line);
    const strength = strengths && strengths[position] ? strengths[position].strength : null;
    const text = el("input", { class: "rule-text", value: rule.text, "data-key": key, "data-index": rule.own ? rule.index : null,
      readonly: !rule.own, title: rule.own ? "a rule as a sentence: if … then …" : `from ${rule.file}; edit it there`,
      oninput: (e) => ctx.edit({ op: "set_rule", index: rule.index, text: e.target.value, weight: rule.weight }, key) });
    const weight = el("input", { class: "weight", type: "number", min: 0, max: 1, step: 0.05, value: rule.weight ?? "", placeholder: "weight",
      readonly: !rule.own, "data-key": `${key}:weight`, size: 4,
      oninput: (e) => ctx.edit({ op: "set_rule", index: rule.index, text: rule.text, weight: e.target.value === "" ? null : e.target.value }, key) });
    const remove = rule.own ? el("button", { class: "small", text: "✕", title: "delete the rule",
      onclick: () => ctx.edit({ op: "delete_rule", index: rule.index }, null) }) : el("span");
    const bar = el("div", { class: "bar", title: strength === null ? "" : `fires at ${strength.toFixed(2)}` },
      strength === null ? [] : [el("span", { style: `width:${(strength * 100).toFixed(0)}%` })]);
    return el("div", { class: `rule ${rule.own ? "" : "inherited"}`, "data-line": rule.line }, [
      el("span", { class: "line", text: rule.own ? `line ${rule.line}` : `${rule.file}:${rule.line}` }),
      text, weight, remove, bar, ctx.errorOf(key), ...problemLines(problems)]);
  });
  const fresh = el("input", { class: "rule-text", placeholder: "if consistency is soft then youngs_modulus is soft",
    "data-key": "new-rule", size: 60 });
  list.push(el("div", { class: "add-row" }, [fresh, el("button", { text: "+ rule",
    onclick: () => ctx.edit({ op: "add_rule", text: fresh.value }, null, "new-rule") }), ctx.errorOf("new-rule")]));
  return list;
}

export function renderTissues(state, ctx) {
  const inputs = state.variables.filter((v) => v.role === "input");
  const words = inputs.map((v) => v.terms.map((t) => t.name)).flat();
  const suggestions = el("datalist", { id: "words" }, [...new Set(words)].map((w) => el("option", { value: w })));
  const rows = state.tissues.map((tissue) => {
    const problems = problemsIn(state, tissue.file, tissue.line, tissue.end_line);
    const cells = inputs.map((v) => {
      const key = `tissue:${tissue.name}:${v.name}`;
      return el("td", {}, el("input", { value: tissue.words[v.name] ?? "", list: "words", "data-key": key,
        "data-tissue": tissue.name, "data-input": v.name, "aria-label": `${tissue.name} ${v.name}`,
        oninput: (e) => ctx.edit({ op: "set_tissue", tissue: tissue.name, variable: v.name, words: e.target.value }, key) }));
    });
    const name = tissue.own
      ? el("input", { value: tissue.name, "data-key": `tissue-name:${tissue.name}`, size: 14,
        onchange: (e) => ctx.edit({ op: "rename_tissue", tissue: tissue.name, new: e.target.value.trim() }, null) })
      : el("span", { text: tissue.name, title: `from ${tissue.file}` });
    const remove = tissue.own ? el("button", { class: "small", text: "✕", title: `delete ${tissue.name}`,
      onclick: () => ctx.edit({ op: "delete_tissue", tissue: tissue.name }, null) }) : null;
    return [el("tr", { class: tissue.own ? "" : "inherited", "data-line": tissue.line }, [
      el("td", {}, [name, " ", remove]), ...cells, el("td", { class: "note", text: `${tissue.file}:${tissue.line}` })]),
    problems.length
      ? el("tr", {}, el("td", { colspan: inputs.length + 2 }, problemLines(problems))) : null];
  }).flat();
  const fresh = el("input", { placeholder: "new tissue", "data-key": "new-tissue", size: 14 });
  const add = el("button", { class: "small", text: "+ tissue", onclick: () => {
    const current = state.tissues.find((t) => t.name === ctx.tissueName);
    ctx.edit({ op: "add_tissue", tissue: fresh.value.trim(), words: current ? current.words : {} }, null, "new-tissue");
  } });
  return [suggestions, el("table", { class: "tissues" }, [
    el("tr", {}, [el("th", { text: "tissue" }), ...inputs.map((v) => el("th", { text: v.name })), el("th", { text: "line" })]),
    ...rows]), el("div", { class: "add-row" }, [fresh, add, ctx.errorOf("new-tissue")])];
}

export function renderYaml(state) {
  const bad = new Set(state.problems.filter((p) => p.file === state.file).map((p) => p.line));
  return state.text.split("\n").map((line, i) => el("div", { class: bad.has(i + 1) ? "bad" : "" },
    [el("span", { class: "ln", text: i + 1 }), line]));
}
