// 2D schematic tree (spec 004 §2.3 items 1-2): segments from Python, the tropism arrow theta that a drag pushes,
// and a top-view inset of the divergence angle. No state beyond the synced traits.
const NS = "http://www.w3.org/2000/svg";
const W = 300, H = 300, PAD = 14;

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
const ORDER_COLORS = ["#5b3a1e", "#7a5230", "#96703f", "#a98b55", "#b9a56d"];

// theta (degrees from up, toward +x) of the vector (dx, dy_up); the arrow is symmetric, so |dx| is used
export function thetaFromVector(dx, dyUp) {
  return Math.atan2(Math.abs(dx), dyUp) * 180 / Math.PI;
}

function render({ model, el: host }) {
  // drags send to the kernel at most every 120 ms (each change regrows the schematic there) and once on release
  let lastSent = 0, pending = false;
  function commit(force) {
    const now = performance.now();
    if (force || now - lastSent > 120) { model.save_changes(); lastSent = now; pending = false; } else pending = true;
  }
  const root = document.createElement("div");
  root.className = "plantvr-arch plantvr-schematic";
  const title = document.createElement("div");
  title.className = "arch-title";
  title.textContent = "Schematic tree";
  const svg = el("svg", { width: W, height: H, class: "arch-svg schematic-svg" });
  const readout = document.createElement("div");
  readout.className = "arch-readout";
  const err = document.createElement("div");
  err.className = "arch-error";
  root.append(title, svg, readout, err);
  host.appendChild(root);

  const gTree = el("g", { class: "schematic-tree" });
  const ground = el("line", { stroke: "#b7a77a", "stroke-width": 2 });
  const arrow = el("g", { class: "arch-arrow schematic-arrow" });
  const shaft = el("line", {});
  const head = el("polygon", {});
  arrow.append(shaft, head);
  const inset = el("g", { class: "schematic-inset" });
  svg.append(ground, gTree, arrow, inset);

  const C = [W / 2, H / 2], LEN = 0.3 * W;
  function draw() {
    const s = model.get("segments") || [];
    const n = Math.floor(s.length / 6);
    let x0 = -1, x1 = 1, y0 = 0, y1 = 1;
    for (let i = 0; i < n; i++) {
      const r = s.slice(6 * i, 6 * i + 6);
      x0 = Math.min(x0, r[0], r[2]); x1 = Math.max(x1, r[0], r[2]);
      y0 = Math.min(y0, r[1], r[3]); y1 = Math.max(y1, r[1], r[3]);
    }
    const sc = Math.min((W - 2 * PAD) / (x1 - x0), (H - 2 * PAD) / (y1 - y0));
    const ox = W / 2 - sc * (x0 + x1) / 2, oy = H - PAD + sc * y0;
    const X = (x) => ox + sc * x, Y = (y) => oy - sc * y;
    gTree.replaceChildren();
    for (let i = 0; i < n; i++) {
      const r = s.slice(6 * i, 6 * i + 6);
      gTree.appendChild(el("line", {
        x1: X(r[0]), y1: Y(r[1]), x2: X(r[2]), y2: Y(r[3]), class: "schematic-seg",
        stroke: ORDER_COLORS[Math.min(r[5], ORDER_COLORS.length - 1)],
        "stroke-width": Math.max(1, Math.min(12, 2 * r[4] * sc)), "stroke-linecap": "round",
      }));
    }
    ground.setAttribute("x1", 0); ground.setAttribute("x2", W);
    ground.setAttribute("y1", Y(0)); ground.setAttribute("y2", Y(0));
    // tropism arrow over the tree
    const th = model.get("tropism_angle") * Math.PI / 180;
    const d = [Math.sin(th), -Math.cos(th)];
    const tip = [C[0] + LEN * d[0], C[1] + LEN * d[1]];
    const back = [C[0] - 0.25 * LEN * d[0], C[1] - 0.25 * LEN * d[1]];
    shaft.setAttribute("x1", back[0]); shaft.setAttribute("y1", back[1]);
    shaft.setAttribute("x2", tip[0] - 10 * d[0]); shaft.setAttribute("y2", tip[1] - 10 * d[1]);
    const nx = -d[1], ny = d[0];
    head.setAttribute("points", [tip, [tip[0] - 16 * d[0] + 8 * nx, tip[1] - 16 * d[1] + 8 * ny],
      [tip[0] - 16 * d[0] - 8 * nx, tip[1] - 16 * d[1] - 8 * ny]].map((p) => p.join(",")).join(" "));
    // divergence inset: buds 0..7 seen from above, k * phi apart
    const phi = model.get("phyllotaxis_angle"), IC = [W - 36, 36], IR = 24;
    inset.replaceChildren(el("circle", { cx: IC[0], cy: IC[1], r: IR + 6, class: "arch-inset" }));
    for (let k = 0; k < 8; k++) {
      const a = (k * phi) * Math.PI / 180, rr = IR * (0.45 + 0.55 * k / 7);
      const p = [IC[0] + rr * Math.cos(a), IC[1] - rr * Math.sin(a)];
      inset.appendChild(el("line", { x1: IC[0], y1: IC[1], x2: p[0], y2: p[1], stroke: "#7a9", "stroke-width": 1 }));
      inset.appendChild(el("circle", { cx: p[0], cy: p[1], r: 2.5, fill: k === 0 ? "#c0392b" : "#2e8b57",
        class: "schematic-bud" }));
    }
    readout.textContent = `θ ${model.get("tropism_angle").toFixed(1)}°  ϕ ${phi.toFixed(1)}°  ` +
      `${n} internodes  ${model.get("build_ms").toFixed(0)} ms`;
    err.textContent = model.get("error") || "";
  }

  let dragging = false;
  function setFromEvent(ev) {
    const r = svg.getBoundingClientRect();
    const dx = ev.clientX - r.left - C[0], dy = C[1] - (ev.clientY - r.top);
    if (Math.hypot(dx, dy) < 4) return;
    model.set("tropism_angle", thetaFromVector(dx, dy));
    commit(false);
  }
  svg.addEventListener("pointerdown", (ev) => { dragging = true; svg.setPointerCapture?.(ev.pointerId); setFromEvent(ev); });
  svg.addEventListener("pointermove", (ev) => { if (dragging) setFromEvent(ev); });
  const end = () => { dragging = false; if (pending) commit(true); };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);

  const evs = ["change:segments", "change:tropism_angle", "change:phyllotaxis_angle", "change:build_ms", "change:error"];
  evs.forEach((e) => model.on(e, draw));
  draw();
  return () => evs.forEach((e) => model.off(e, draw));
}

export default { render };
