// Influence triangle (spec 000_treewand §4.9): drag a point; its barycentric coordinates are (H, T, E).
// No state beyond the synced traits: the point is recomputed from `weights` on every change.
const NS = "http://www.w3.org/2000/svg";
const SIZE = 240, PAD = 28;

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
function area2(a, b, c) { return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]); }

export function barycentric(p, c) {
  const t = area2(c[0], c[1], c[2]);
  return [area2(p, c[1], c[2]) / t, area2(c[0], p, c[2]) / t, area2(c[0], c[1], p) / t];
}
function closestOnSegment(p, a, b) {
  const ab = [b[0] - a[0], b[1] - a[1]];
  let t = ((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / (ab[0] * ab[0] + ab[1] * ab[1]);
  t = Math.min(1, Math.max(0, t));
  return [a[0] + t * ab[0], a[1] + t * ab[1]];
}
export function clampToTriangle(p, c) {
  const w = barycentric(p, c);
  if (w.every((x) => x >= 0)) return p;
  let best = null, bd = Infinity;
  for (let i = 0; i < 3; i++) {
    const q = closestOnSegment(p, c[i], c[(i + 1) % 3]);
    const d = Math.hypot(q[0] - p[0], q[1] - p[1]);
    if (d < bd) { bd = d; best = q; }
  }
  return best;
}

function render({ model, el: host }) {
  const root = document.createElement("div");
  root.className = "plantvr-triangle";
  const svg = el("svg", { width: SIZE + 2 * PAD, height: SIZE * 0.866 + 2 * PAD + 8, class: "tri-svg" });
  const readout = document.createElement("div");
  readout.className = "tri-readout";
  const err = document.createElement("div");
  err.className = "tri-error";
  root.append(svg, readout, err);
  host.appendChild(root);

  const corners = () => model.get("corners");
  const h = () => Math.max(...corners().map((c) => c[1]));
  const toScreen = (p) => [PAD + p[0] * SIZE, PAD + (h() - p[1]) * SIZE];
  const fromScreen = (x, y) => [(x - PAD) / SIZE, h() - (y - PAD) / SIZE];

  const subs = [0, 1, 2].map((i) => el("polygon", { class: `tri-sub tri-sub-${i}`, "fill-opacity": 0.8 }));
  const outline = el("polygon", { class: "tri-outline", fill: "none" });
  const handle = el("circle", { r: 8, class: "tri-handle" });
  const cornerLabels = [0, 1, 2].map(() => el("text", { class: "tri-label" }));
  subs.forEach((s) => svg.appendChild(s));
  svg.append(outline, ...cornerLabels, handle);

  function weightsToPoint(w) {
    const c = corners(), s = w[0] + w[1] + w[2];
    return [0, 1].map((k) => (w[0] * c[0][k] + w[1] * c[1][k] + w[2] * c[2][k]) / s);
  }
  function draw() {
    const c = corners(), w = model.get("weights"), col = model.get("colors"), lab = model.get("labels");
    const P = toScreen(weightsToPoint(w)), S = c.map(toScreen);
    // the sub-triangle opposite corner i (P with the other two corners) is drawn in influence i's colour
    subs.forEach((poly, i) => {
      const pts = [P, S[(i + 1) % 3], S[(i + 2) % 3]];
      poly.setAttribute("points", pts.map((q) => q.join(",")).join(" "));
      poly.setAttribute("fill", col[i]);
    });
    outline.setAttribute("points", S.map((q) => q.join(",")).join(" "));
    handle.setAttribute("cx", P[0]); handle.setAttribute("cy", P[1]);
    const offs = [[0, -10], [-6, 18], [6, 18]], anchor = ["middle", "start", "end"];
    cornerLabels.forEach((t, i) => {
      t.setAttribute("x", S[i][0] + offs[i][0]); t.setAttribute("y", S[i][1] + offs[i][1]);
      t.setAttribute("text-anchor", anchor[i]); t.setAttribute("fill", col[i]); t.textContent = lab[i];
    });
    readout.innerHTML = ["H", "T", "E"].map((n, i) =>
      `<span class="tri-w" style="border-color:${col[i]}" data-name="${n}">${n} ${w[i].toFixed(3)}</span>`).join(" ");
    err.textContent = model.get("error") || "";
  }

  let dragging = false;
  function setFromEvent(ev) {
    const r = svg.getBoundingClientRect();
    const p = clampToTriangle(fromScreen(ev.clientX - r.left, ev.clientY - r.top), corners());
    const w = barycentric(p, corners()).map((x) => Math.max(0, x));
    const s = w[0] + w[1] + w[2];
    model.set("weights", w.map((x) => x / s));
    model.save_changes();
  }
  svg.addEventListener("pointerdown", (ev) => { dragging = true; svg.setPointerCapture?.(ev.pointerId); setFromEvent(ev); });
  svg.addEventListener("pointermove", (ev) => { if (dragging) setFromEvent(ev); });
  const end = () => { dragging = false; };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);

  ["change:weights", "change:colors", "change:labels", "change:corners", "change:error"].forEach((e) => model.on(e, draw));
  draw();
  return () => ["change:weights", "change:colors", "change:labels", "change:corners", "change:error"].forEach((e) => model.off(e, draw));
}

export default { render };
