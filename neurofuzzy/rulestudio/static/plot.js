// A linguistic variable's membership functions as an SVG plot whose points can be dragged.
import { svg, unitText } from "./dom.js";
import { evaluate, handles, dragged, toInternal, toPhysical } from "./membership.js";

export const COLORS = ["#2f6fdf", "#d9480f", "#2b8a3e", "#ae3ec9", "#c92a2a", "#0b7285", "#e67700", "#5f3dc4"];
const W = 560, H = 170, L = 42, R = 12, T = 16, B = 24;
const SAMPLES = 241;

function ticks(universe) {
  const { scale } = universe;
  if (scale === "log") {
    const out = [];
    for (let k = Math.ceil(Math.log10(universe.low) - 1e-9); k <= Math.floor(Math.log10(universe.high) + 1e-9); k++) out.push(Math.pow(10, k));
    return out;
  }
  const span = universe.high - universe.low;
  const raw = span / 6;
  const step = [1, 2, 2.5, 5, 10].map((m) => m * Math.pow(10, Math.floor(Math.log10(raw)))).find((s) => s >= raw);
  const out = [];
  for (let x = Math.ceil(universe.low / step) * step; x <= universe.high + step * 1e-9; x += step) out.push(Number(x.toPrecision(10)));
  return out;
}

function tickText(x, unit) {
  if (unit === "Pa" || unit === "Pa s") {
    const shown = unitText(unit);
    if (x >= 1e6) return `${Number((x / 1e6).toPrecision(3))} M${shown}`;
    if (x >= 1e3) return `${Number((x / 1e3).toPrecision(3))} k${shown}`;
    return `${Number(x.toPrecision(3))} ${shown}`;
  }
  return Math.abs(x) >= 10000 ? `${x / 1000}k` : String(x);
}

// variable: as in the state; options: {onDrag(term, params, final), value, aggregate, fits}
export function membershipPlot(variable, options = {}) {
  const universe = variable.universe;
  const root = svg("svg", { class: "mf", viewBox: `0 0 ${W} ${H}`, "data-var": variable.name, role: "img",
    "aria-label": `membership functions of ${variable.name}` });
  if (!universe) return root;
  const u0 = toInternal(universe.low, universe.scale);
  const u1 = toInternal(universe.high, universe.scale);
  const xOf = (u) => L + ((u - u0) / (u1 - u0)) * (W - L - R);
  const yOf = (mu) => T + (1 - mu) * (H - T - B);
  const us = Array.from({ length: SAMPLES }, (_, i) => u0 + ((u1 - u0) * i) / (SAMPLES - 1));
  const terms = variable.terms.map((t) => ({ ...t, params: t.params }));
  let active = null;

  function draw() {
    const parts = [];
    parts.push(svg("line", { class: "axis", x1: L, x2: W - R, y1: yOf(0), y2: yOf(0) }));
    parts.push(svg("line", { class: "axis", x1: L, x2: L, y1: yOf(0), y2: yOf(1) }));
    for (const mu of [0, 0.5, 1]) parts.push(svg("text", { x: L - 9, y: yOf(mu) + 3, "text-anchor": "end", text: mu }));
    for (const x of ticks(universe)) {
      const px = xOf(toInternal(x, universe.scale));
      parts.push(svg("line", { class: "axis", x1: px, x2: px, y1: yOf(0), y2: yOf(0) + 4 }));
      parts.push(svg("text", { x: px, y: H - 6, "text-anchor": "middle", text: tickText(x, variable.unit) }));
    }
    if (variable.unit && variable.unit !== "Pa" && variable.unit !== "Pa s") {
      parts.push(svg("text", { x: 2, y: H - 6, text: unitText(variable.unit) }));
    }
    if (options.aggregate) {
      const a = options.aggregate;
      const n = a.values.length;
      const points = a.values.map((m, i) => `${xOf(a.low + ((a.high - a.low) * i) / (n - 1))},${yOf(m)}`);
      parts.push(svg("polygon", { class: "aggregate", points: `${xOf(a.low)},${yOf(0)} ${points.join(" ")} ${xOf(a.high)},${yOf(0)}` }));
    }
    terms.forEach((term, index) => {
      if (!term.kind || !Array.isArray(term.params)) return;
      const color = COLORS[index % COLORS.length];
      const mu = evaluate(term.kind, term.params, us, universe.scale);
      parts.push(svg("polyline", { class: "term", stroke: color, "data-term": term.name,
        points: us.map((u, i) => `${xOf(u).toFixed(1)},${yOf(mu[i]).toFixed(1)}`).join(" ") }));
      const peak = mu.indexOf(Math.max(...mu));
      parts.push(svg("text", { class: "term-label", fill: color, x: Math.min(W - R - 20, Math.max(L + 10, xOf(us[peak]))),
        y: T - 4, "text-anchor": "middle", text: term.name }));
    });
    if (options.value !== undefined && options.value !== null && isFinite(options.value)) {
      const px = xOf(toInternal(options.value, universe.scale));
      parts.push(svg("line", { class: "value-line", x1: px, x2: px, y1: yOf(0), y2: yOf(1.02) }));
    }
    (options.fits || []).forEach((fit, row) => {
      const y = yOf(0) - 6 - 8 * (row % 8);
      const learned = xOf(toInternal(Math.max(fit.learned, universe.low), universe.scale));
      if (fit.start !== null && fit.start !== undefined) {
        const start = xOf(toInternal(fit.start, universe.scale));
        parts.push(svg("line", { class: "fit-learned", x1: start, x2: learned, y1: y, y2: y, stroke: fit.color }));
        parts.push(svg("circle", { class: "fit-start", cx: start, cy: y, r: 3.5 }, [svg("title", { text: `${fit.label}: start` })]));
      }
      parts.push(svg("rect", { class: "fit-learned", x: learned - 3.5, y: y - 3.5, width: 7, height: 7, fill: fit.color,
        transform: `rotate(45 ${learned} ${y})` }, [svg("title", { text: `${fit.label}: learned ${fit.learned.toPrecision(3)}` })]));
    });
    if (options.onDrag) {
      terms.forEach((term, index) => {
        if (!term.kind || !Array.isArray(term.params)) return;
        for (const h of handles(term.kind, term.params, universe.scale)) {
          if (!isFinite(h.u)) continue;
          const isActive = active && active.term === term.name && active.handle.id === h.id && active.handle.mode === h.mode;
          parts.push(svg("circle", {
            class: `handle ${h.mode === "xy" ? "xy" : ""} ${isActive ? "active" : ""}`, cx: xOf(h.u), cy: yOf(h.mu), r: 5.5,
            fill: COLORS[index % COLORS.length], "data-term": term.name, "data-param": h.id, "data-mode": h.mode,
            onpointerdown: (event) => start(event, term, h),
          }, [svg("title", { text: `${term.name}: drag ${h.mode === "width" ? "the width" : "the point"}` })]));
        }
      });
    }
    root.replaceChildren(...parts);
  }

  function pointer(event) {
    const matrix = root.getScreenCTM().inverse();
    const p = new DOMPoint(event.clientX, event.clientY).matrixTransform(matrix);
    return { u: u0 + ((p.x - L) / (W - L - R)) * (u1 - u0), mu: 1 - (p.y - T) / (H - T - B) };
  }

  function start(event, term, handle) {
    event.preventDefault();
    root.setPointerCapture(event.pointerId);
    active = { term: term.name, handle, pointerId: event.pointerId };
    if (options.onDragStart) options.onDragStart();
    draw();
  }

  root.addEventListener("pointermove", (event) => {
    if (!active || event.pointerId !== active.pointerId) return;
    const term = terms.find((t) => t.name === active.term);
    const { u, mu } = pointer(event);
    const params = dragged(term.kind, term.params, active.handle, u, mu, universe);
    if (JSON.stringify(params) === JSON.stringify(term.params)) return;
    term.params = params;
    active.handle = handles(term.kind, params, universe.scale).find((h) => h.id === active.handle.id && h.mode === active.handle.mode) || active.handle;
    draw();
    options.onDrag(term.name, term.kind, params, false);
  });
  const end = (event) => {
    if (!active || event.pointerId !== active.pointerId) return;
    const term = terms.find((t) => t.name === active.term);
    active = null;
    draw();
    options.onDrag(term.name, term.kind, term.params, true);
  };
  root.addEventListener("pointerup", end);
  root.addEventListener("pointercancel", end);
  draw();
  return root;
}

export { toPhysical };
