// The poked block: its surface drawn in an oblique view, frame by frame (ten times slower than
// real time), and the depth of the probe against time, beside the curve before the last change.
import { svg } from "./dom.js";

const W = 400, H = 230, CW = 400, CH = 130, CL = 56, CB = 22;
const NICE = [1, 2, 5, 10, 20, 50, 100];
const AZIMUTH = -0.6, ELEVATION = 0.45, SLOW = 10;

function projector(rest) {
  const min = [0, 1, 2].map((k) => Math.min(...rest.map((p) => p[k])));
  const max = [0, 1, 2].map((k) => Math.max(...rest.map((p) => p[k])));
  const centre = min.map((v, k) => (v + max[k]) / 2);
  const ca = Math.cos(AZIMUTH), sa = Math.sin(AZIMUTH), ce = Math.cos(ELEVATION), se = Math.sin(ELEVATION);
  const raw = (p) => {
    const x = p[0] - centre[0], y = p[1] - centre[1], z = p[2] - centre[2];
    const across = x * ca - y * sa;
    const away = x * sa + y * ca;
    return [across, -z * ce + away * se, away * ce + z * se];
  };
  const corners = [];
  for (const i of [0, 1]) for (const j of [0, 1]) for (const k of [0, 1]) corners.push(raw([i ? max[0] : min[0], j ? max[1] : min[1], k ? max[2] : min[2]]));
  const width = Math.max(...corners.map((c) => c[0])) - Math.min(...corners.map((c) => c[0]));
  const height = Math.max(...corners.map((c) => c[1])) - Math.min(...corners.map((c) => c[1]));
  const scale = Math.min((W - 40) / width, (H - 70) / height);
  const top = Math.min(...corners.map((c) => c[1]));
  return (p) => { const [a, b, d] = raw(p); return [W / 2 + a * scale, 50 + (b - top) * scale, d]; };
}

function color(share) {          // blue (still) to red (moved most)
  const s = Math.max(0, Math.min(1, share));
  return `rgb(${Math.round(70 + 170 * s)},${Math.round(120 - 40 * s)},${Math.round(220 - 170 * s)})`;
}

export class BlockView {
  constructor(container) {
    this.container = container;
    this.scene = svg("svg", { viewBox: `0 0 ${W} ${H}`, "aria-label": "the poked block" });
    this.curve = svg("svg", { viewBox: `0 0 ${CW} ${CH}`, "aria-label": "probe depth against time" });
    container.replaceChildren(this.scene, this.curve);
    this.data = null;
    this.previous = null;
    this.frame = 0;
    this.started = 0;
    requestAnimationFrame((t) => this.tick(t));
  }

  show(data) {
    if (this.data && data && this.data.tissue === data.tissue) this.previous = this.data;
    else if (data && this.data) this.previous = this.data;
    this.data = data;
    this.project = data ? projector(data.positions[0]) : null;
    if (data && (!this.magnify || this.force !== data.probe.force)) {
      // displacements are drawn magnified by one factor, kept while the force is, so that a
      // softer tissue visibly sinks deeper; the curve shows the true depth
      const rest = data.positions[0];
      const height = Math.max(...rest.map((p) => p[2])) - Math.min(...rest.map((p) => p[2]));
      const wanted = (0.15 * height) / Math.max(1e-12, Math.max(...data.depth));
      this.magnify = NICE.filter((m) => m <= Math.max(1, wanted)).pop();
      this.force = data.probe.force;
    }
    const depth = data ? Math.max(...data.depth) : 0;
    this.container.dataset.depth = depth;
    this.container.dataset.tissue = data ? data.tissue : "";
    this.replay();
  }

  replay() { this.started = performance.now(); }

  tick(now) {
    if (this.data) {
      const n = this.data.time.length;
      const period = this.data.time[n - 1] * 1000 * SLOW + 700;
      const elapsed = Math.max(0, now - this.started) % period;    // a frame may start before show()
      this.frame = Math.min(n - 1, Math.floor(elapsed / (this.data.time[1] * 1000 * SLOW)));
      this.drawScene();
      this.drawCurve();
    }
    requestAnimationFrame((t) => this.tick(t));
  }

  drawScene() {
    const { positions, triangles, depth, probe } = this.data;
    const rest = positions[0];
    const m = this.magnify;
    const frame = positions[this.frame].map((p, i) => p.map((v, k) => rest[i][k] + m * (v - rest[i][k])));
    const moved = frame.map((p, i) => Math.hypot(p[0] - rest[i][0], p[1] - rest[i][1], p[2] - rest[i][2]));
    const most = Math.max(1e-12, ...positions.map((f) => Math.max(...f.map((p, i) => Math.abs(p[2] - rest[i][2])))));
    const projected = frame.map((p) => this.project(p));
    const faces = [];
    for (const [a, b, c] of triangles) {
      const [pa, pb, pc] = [projected[a], projected[b], projected[c]];
      const area = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pc[0] - pa[0]) * (pb[1] - pa[1]);
      if (area >= 0) continue;              // facing away
      faces.push({ depth: pa[2] + pb[2] + pc[2], points: [pa, pb, pc], share: (moved[a] + moved[b] + moved[c]) / (3 * most) });
    }
    faces.sort((f, g) => g.depth - f.depth);
    const parts = faces.map((f) => svg("polygon", { class: "face", fill: color(f.share),
      points: f.points.map((p) => `${p[0].toFixed(1)},${p[1].toFixed(1)}`).join(" ") }));
    const pushing = this.data.time[this.frame] < probe.push_until;
    const tip = this.project([probe.point[0], probe.point[1], probe.point[2] - (pushing ? m * depth[this.frame] : -0.004)]);
    const side = this.project([probe.point[0] + probe.radius, probe.point[1], probe.point[2]])[0] - this.project(probe.point)[0];
    parts.push(svg("rect", { class: "probe", x: tip[0] - Math.abs(side) / 2, y: tip[1] - 44, width: Math.abs(side), height: 44, rx: 3 }));
    parts.push(svg("text", { x: 8, y: H - 8, "font-size": 11, fill: "#6b7385",
      text: `t = ${(this.data.time[this.frame] * 1000).toFixed(0)} ms, shown ${SLOW}× slower; displacements drawn ×${m}` }));
    this.scene.replaceChildren(...parts);
  }

  drawCurve() {
    const { time } = this.data;
    const curves = [this.previous, this.data].filter(Boolean);
    const most = Math.max(1e-9, ...curves.map((c) => Math.max(...c.depth)));
    const least = Math.min(0, ...curves.map((c) => Math.min(...c.depth)));
    const xOf = (t) => CL + (t / time[time.length - 1]) * (CW - CL - 8);
    const yOf = (d) => 8 + ((d - least) / (most - least)) * (CH - CB - 8);
    const label = (d) => svg("text", { x: CL - 4, y: yOf(d) + 3, "text-anchor": "end", "font-size": 10, fill: "#6b7385",
      text: d === 0 ? "0" : `${(d * 1000).toPrecision(2)} mm` });
    const parts = [
      svg("line", { x1: CL, x2: CW - 8, y1: yOf(0), y2: yOf(0), stroke: "#99a" }),
      svg("line", { x1: CL, x2: CL, y1: 8, y2: CH - CB, stroke: "#99a" }),
      label(most), label(0), least < -0.05 * most ? label(least) : null,
      svg("text", { x: CW - 8, y: CH - 6, "text-anchor": "end", "font-size": 10, fill: "#6b7385", text: `${(time[time.length - 1] * 1000).toFixed(0)} ms` }),
      svg("text", { x: CL, y: CH - 6, "font-size": 10, fill: "#6b7385", text: "0 ms" }),
    ].filter(Boolean);
    curves.forEach((c) => parts.push(svg("polyline", { class: c === this.data ? "curve" : "curve previous",
      points: c.depth.map((d, i) => `${xOf(c.time[i]).toFixed(1)},${yOf(d).toFixed(1)}`).join(" ") })));
    const x = xOf(time[this.frame]);
    parts.push(svg("line", { class: "cursor", x1: x, x2: x, y1: 8, y2: CH - CB }));
    this.curve.replaceChildren(...parts);
  }
}
