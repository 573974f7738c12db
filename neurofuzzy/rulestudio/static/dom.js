// Building elements without HTML strings: every text from the file or the server is set as
// text, never parsed as markup.
const SVG = "http://www.w3.org/2000/svg";

function build(node, attrs, children) {
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value === undefined || value === null || value === false) continue;
    if (key === "text") node.textContent = value;
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else if (key === "value") node.value = value;
    else if (key === "style") node.style.cssText = value;       // CSSOM: allowed by the page's CSP
    else node.setAttribute(key, value === true ? "" : String(value));
  }
  for (const child of [].concat(children || [])) {
    if (child === null || child === undefined || child === false) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

export function el(tag, attrs, children) { return build(document.createElement(tag), attrs, children); }
export function svg(tag, attrs, children) { return build(document.createElementNS(SVG, tag), attrs, children); }

// Replace a container's content, keeping the focus, text and caret of the field being typed in
// (matched by its data-key).
export function replaceContent(container, children) {
  const active = document.activeElement;
  const key = active && container.contains(active) && active.dataset ? active.dataset.key : null;
  const kept = key ? { value: active.value, start: active.selectionStart, end: active.selectionEnd } : null;
  container.replaceChildren(...[].concat(children).filter(Boolean));
  if (!key) return;
  const again = container.querySelector(`[data-key="${CSS.escape(key)}"]`);
  if (!again) return;
  if ("value" in again && kept.value !== undefined && again.tagName !== "SELECT") again.value = kept.value;
  again.focus();
  try { if (kept.start !== null) again.setSelectionRange(kept.start, kept.end); } catch (_) { /* not a text field */ }
}

const PREFIX = [[1e9, "G"], [1e6, "M"], [1e3, "k"]];

export function unitText(unit) {
  return (unit || "").replace("^3", "³").replace("^2", "²").replace(/\bPa s\b/, "Pa·s").replace(/\bN s\b/, "N·s");
}

// 6120 Pa → "6.12 kPa"; 0.456 → "0.456"; 1045 kg/m^3 → "1045 kg/m³"
export function quantityText(value, unit) {
  if (value === null || value === undefined || !isFinite(value)) return "–";
  if (unit === "Pa" || unit === "Pa s") {
    for (const [size, prefix] of PREFIX) {
      if (Math.abs(value) >= size) return `${(value / size).toPrecision(3)} ${prefix}${unitText(unit)}`;
    }
  }
  const text = Math.abs(value) >= 1000 ? value.toFixed(0) : value.toPrecision(3);
  return unit ? `${text} ${unitText(unit)}` : text;
}
