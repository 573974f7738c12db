// Membership functions as neurofuzzy.rules.membership evaluates them, on a variable's internal
// axis u (the value itself, or log10 of it on a log universe); and the points of each one
// that can be dragged.

export const toInternal = (x, scale) => (scale === "log" ? Math.log10(x) : x);
export const toPhysical = (u, scale) => (scale === "log" ? Math.pow(10, u) : u);

// indices of the parameters that are positions (in physical units) per function
const POSITIONS = { trimf: [0, 1, 2], trapmf: [0, 1, 2, 3], gaussmf: [0], gbellmf: [2], sigmf: [0] };

function internalParams(kind, params, scale) {
  if (kind === "points") return params.map(([x, m]) => [toInternal(x, scale), m]);
  const out = params.slice();
  for (const i of POSITIONS[kind] || []) out[i] = toInternal(params[i], scale);
  return out;
}

function trapezoid(u, [a, b, c, d]) {
  if (u < a || u > d) return 0;
  const rising = u < b ? (b > a ? (u - a) / (b - a) : 1) : 1;
  const falling = u > c ? (d > c ? (d - u) / (d - c) : 1) : 1;
  return Math.max(0, Math.min(1, rising, falling));
}

// μ of every u in us for a term (NaN-free; 0 for parameters that cannot be drawn)
export function evaluate(kind, params, us, scale) {
  let p;
  try { p = internalParams(kind, params, scale); } catch (_) { return us.map(() => 0); }
  if (!p || p.some((v) => (Array.isArray(v) ? v.some((w) => !isFinite(w)) : !isFinite(v)))) return us.map(() => 0);
  switch (kind) {
    case "trimf": return us.map((u) => trapezoid(u, [p[0], p[1], p[1], p[2]]));
    case "trapmf": return us.map((u) => trapezoid(u, p));
    case "gaussmf": return us.map((u) => Math.exp(-((u - p[0]) ** 2) / (2 * p[1] ** 2)));
    case "gbellmf": return us.map((u) => 1 / (1 + Math.abs((u - p[2]) / p[0]) ** (2 * p[1])));
    case "sigmf": return us.map((u) => 1 / (1 + Math.exp(-p[1] * (u - p[0]))));
    case "points": return us.map((u) => {
      if (u <= p[0][0]) return p[0][1];
      for (let i = 1; i < p.length; i++) {
        if (u <= p[i][0]) return p[i - 1][1] + ((p[i][1] - p[i - 1][1]) * (u - p[i - 1][0])) / (p[i][0] - p[i - 1][0]);
      }
      return p[p.length - 1][1];
    });
    default: return us.map(() => 0);
  }
}

// The draggable points of a term: {id, u, mu, mode: "x" | "xy" | "width"}
export function handles(kind, params, scale) {
  let p;
  try { p = internalParams(kind, params, scale); } catch (_) { return []; }
  switch (kind) {
    case "trimf": return [[0, 0], [1, 1], [2, 0]].map(([i, mu]) => ({ id: i, u: p[i], mu, mode: "x" }));
    case "trapmf": return [[0, 0], [1, 1], [2, 1], [3, 0]].map(([i, mu]) => ({ id: i, u: p[i], mu, mode: "x" }));
    case "gaussmf": return [{ id: 0, u: p[0], mu: 1, mode: "x" }, { id: 1, u: p[0] + p[1], mu: Math.exp(-0.5), mode: "width", centre: p[0] }];
    case "gbellmf": return [{ id: 2, u: p[2], mu: 1, mode: "x" }, { id: 0, u: p[2] + p[0], mu: 0.5, mode: "width", centre: p[2] }];
    case "sigmf": return [{ id: 0, u: p[0], mu: 0.5, mode: "x" }];
    case "points": return p.map(([u, mu], i) => ({ id: i, u, mu, mode: "xy" }));
    default: return [];
  }
}

// a number rounded for the file: 3 significant digits on a log axis, a step of about a
// 200th of the span on a linear one
export function tidy(value, universe, isWidth) {
  if (universe.scale === "log" && !isWidth) return Number(value.toPrecision(3));
  const span = isWidth && universe.scale === "log"
    ? Math.log10(universe.high) - Math.log10(universe.low) : universe.high - universe.low;
  const step = Math.pow(10, Math.floor(Math.log10(span / 200)));
  return Number((Math.round(value / step) * step).toFixed(Math.max(0, -Math.floor(Math.log10(step)))));
}

// new parameters after moving handle h to internal position u (and μ for "xy")
export function dragged(kind, params, h, u, mu, universe) {
  const { scale } = universe;
  const low = toInternal(universe.low, scale);
  const high = toInternal(universe.high, scale);
  u = Math.min(high, Math.max(low, u));
  const out = JSON.parse(JSON.stringify(params));
  if (kind === "points") {
    const p = internalParams(kind, params, scale);
    const before = h.id > 0 ? p[h.id - 1][0] : low;
    const after = h.id < p.length - 1 ? p[h.id + 1][0] : high;
    const span = (high - low) / 1000;
    u = Math.min(after - span, Math.max(before + span, u));
    out[h.id] = [tidy(toPhysical(u, scale), universe), Number(Math.min(1, Math.max(0, mu)).toFixed(2))];
    return out;
  }
  if (h.mode === "width") {
    const width = Math.max(Math.abs(u - h.centre), (high - low) / 500);
    out[h.id] = tidy(width, universe, true);
    return out;
  }
  if (kind === "trimf" || kind === "trapmf") {
    const p = internalParams(kind, params, scale);
    if (h.id > 0) u = Math.max(u, p[h.id - 1]);
    if (h.id < p.length - 1) u = Math.min(u, p[h.id + 1]);
  }
  let value = tidy(toPhysical(u, scale), universe);
  if (scale === "log") value = Math.max(value, universe.low);
  if (kind === "trimf" || kind === "trapmf") {      // keep the order after rounding
    if (h.id > 0) value = Math.max(value, params[h.id - 1]);
    if (h.id < params.length - 1) value = Math.min(value, params[h.id + 1]);
  }
  out[h.id] = value;
  return out;
}

// a new term's function: a triangle around the middle of the free part of the universe
export function newTerm(universe) {
  const { scale } = universe;
  const low = toInternal(universe.low, scale);
  const high = toInternal(universe.high, scale);
  const span = high - low;
  const mid = low + span / 2;
  return { kind: "trimf", params: [mid - span / 6, mid, mid + span / 6].map((u) => tidy(toPhysical(u, scale), universe)) };
}
