// Architecture panel front ends (spec 004 §2.3 items 1-4; plantvr/ui/architecture.py). One ESM for the three
// widgets, chosen by the synced `kind` trait: "schematic" (2D schematic tree, tropism arrow, divergence inset),
// "ellipse" (gravimorphism control ellipse and bud lines), "angles" (draggable angle rays). No state beyond the
// synced traits.
const NS = "http://www.w3.org/2000/svg";
const ORDER_COLORS = ["#5b3a1e", "#7a5230", "#96703f", "#a98b55", "#b9a56d"];

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
function div(className) {
  const d = document.createElement("div");
  d.className = className;
  return d;
}

// theta (degrees from up, toward +x) of the vector (dx, dy_up); the arrow is symmetric, so |dx| is used
export function thetaFromVector(dx, dyUp) {
  return Math.atan2(Math.abs(dx), dyUp) * 180 / Math.PI;
}
export function redGreen(t) {  // t in [0, 1]: red (few resources) -> green (many)
  const a = [214, 48, 39], b = [26, 152, 80];
  return `rgb(${a.map((x, i) => Math.round(x + (b[i] - x) * t)).join(",")})`;
}
export function angleFromVector(dx, dyUp, side, lo, hi) {
  const a = Math.atan2(Math.max(side * dx, 0), dyUp) * 180 / Math.PI;
  return Math.min(hi, Math.max(lo, a));
}

// The common frame of every kind: an optional title, the SVG, a readout and an error line. grab(x, y) on
// pointerdown returns what is held (null: nothing); move(x, y, held) follows the drag (returns false when it
// set nothing). Drags are sent to the kernel at most every 120 ms (each change regrows the schematic there)
// and once on release. start() draws now and on every change of `events`, and returns the function that stops.
function mount({ model, host, kind, title, width, height, events, draw, grab, move }) {
  const root = div(`plantvr-arch plantvr-${kind}`);
  const svg = el("svg", { width, height, class: `arch-svg ${kind}-svg` });
  const readout = div("arch-readout"), err = div("arch-error");
  if (title) {
    const t = div("arch-title");
    t.textContent = title;
    root.append(t);
  }
  root.append(svg, readout, err);
  host.appendChild(root);

  let lastSent = 0, pending = false, held = null;
  function commit(force) {
    const now = performance.now();
    if (force || now - lastSent > 120) { model.save_changes(); lastSent = now; pending = false; } else pending = true;
  }
  function local(ev) {
    const r = svg.getBoundingClientRect();
    return [ev.clientX - r.left, ev.clientY - r.top];
  }
  svg.addEventListener("pointerdown", (ev) => {
    held = grab(...local(ev));
    if (held !== null) svg.setPointerCapture?.(ev.pointerId);
  });
  svg.addEventListener("pointermove", (ev) => {
    if (held !== null && move(...local(ev), held) !== false) commit(false);
  });
  const end = () => { held = null; if (pending) commit(true); };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);

  const view = { svg, readout, err };
  const redraw = () => { draw(view); err.textContent = model.get("error") || ""; };
  const evs = [...events, "change:error"];
  return {
    view, commit,
    start() {
      evs.forEach((e) => model.on(e, redraw));
      redraw();
      return () => evs.forEach((e) => model.off(e, redraw));
    },
  };
}

// index of the handle (an SVG circle) nearest (x, y) within `reach` pixels, -1 if none
function nearest(handles, x, y, reach) {
  let best = -1, bd = reach;
  handles.forEach((h, i) => {
    const d = Math.hypot(x - +h.getAttribute("cx"), y - +h.getAttribute("cy"));
    if (d < bd) { bd = d; best = i; }
  });
  return best;
}

// 2D schematic tree (items 1-2): segments from Python, the tropism arrow theta that a drag pushes, and a
// top-view inset of the divergence angle.
function schematic(model, host) {
  const W = 300, H = 300, PAD = 14, C = [W / 2, H / 2], LEN = 0.3 * W;
  const gTree = el("g", { class: "schematic-tree" });
  const ground = el("line", { stroke: "#b7a77a", "stroke-width": 2 });
  const arrow = el("g", { class: "arch-arrow schematic-arrow" });
  const shaft = el("line", {});
  const head = el("polygon", {});
  arrow.append(shaft, head);
  const inset = el("g", { class: "schematic-inset" });

  function setTheta(x, y) {
    const dx = x - C[0], dy = C[1] - y;
    if (Math.hypot(dx, dy) < 4) return false;
    model.set("tropism_angle", thetaFromVector(dx, dy));
  }
  function draw({ readout }) {
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
  }

  const m = mount({
    model, host, kind: "schematic", title: "Schematic tree", width: W, height: H, draw,
    events: ["change:segments", "change:tropism_angle", "change:phyllotaxis_angle", "change:build_ms"],
    grab: (x, y) => { if (setTheta(x, y) !== false) m.commit(false); return true; },  // a press pushes the arrow
    move: setTheta,
  });
  m.view.svg.append(ground, gTree, arrow, inset);
  return m.start();
}

// Gravimorphism (item 3, Fig. 4.20B): the control ellipse (s_v, s_p, e_v) in the plane across the parent axis,
// bud lines coloured red -> green by the relative resource factor b (from Python). Drag the centre vertically
// (e_v), the top handle (s_v) or the side handle (s_p).
function ellipse(model, host) {
  const SIZE = 220, S = 45;  // pixels per unit
  const O = [SIZE / 2, SIZE / 2];
  const gRays = el("g", { class: "ellipse-rays" });
  const ell = el("ellipse", { class: "arch-ellipse" });
  const axisDot = el("circle", { cx: O[0], cy: O[1], r: 4, fill: "#8a7f70" });
  const lv = el("text", { x: O[0] + 4, y: 12, class: "arch-label" }); lv.textContent = "V (up)";
  const lp = el("text", { x: SIZE - 14, y: O[1] - 4, class: "arch-label" }); lp.textContent = "P";
  const hC = el("circle", { r: 6, class: "arch-handle ellipse-center", "data-handle": "e_v" });
  const hV = el("circle", { r: 6, class: "arch-handle ellipse-top", "data-handle": "s_v" });
  const hP = el("circle", { r: 6, class: "arch-handle ellipse-side", "data-handle": "s_p" });

  function draw({ readout }) {
    const [sv, sp, ev] = model.get("ellipse"), d = model.get("rays") || [];
    const cy = O[1] - ev * S;
    ell.setAttribute("cx", O[0]); ell.setAttribute("cy", cy);
    ell.setAttribute("rx", sp * S); ell.setAttribute("ry", sv * S);
    hC.setAttribute("cx", O[0]); hC.setAttribute("cy", cy);
    hV.setAttribute("cx", O[0]); hV.setAttribute("cy", cy - sv * S);
    hP.setAttribute("cx", O[0] + sp * S); hP.setAttribute("cy", cy);
    const dmax = Math.max(1e-12, ...d);
    gRays.replaceChildren();
    d.forEach((di, i) => {
      const chi = 2 * Math.PI * i / d.length;  // from +V toward +P
      gRays.appendChild(el("line", { x1: O[0], y1: O[1], x2: O[0] + di * S * Math.sin(chi),
        y2: O[1] - di * S * Math.cos(chi), stroke: redGreen(di / dmax), "stroke-width": 3,
        "stroke-linecap": "round", class: "ellipse-ray" }));
    });
    readout.textContent = `s_v ${sv.toFixed(2)}  s_p ${sp.toFixed(2)}  e_v ${ev.toFixed(2)}`;
  }
  function move(x, y, grab) {
    let [sv, sp, e] = model.get("ellipse");
    if (grab === "e_v") e = (O[1] - y) / S;
    if (grab === "s_v") sv = Math.max(0.05, Math.abs((O[1] - e * S) - y) / S);
    if (grab === "s_p") sp = Math.max(0.05, Math.abs(x - O[0]) / S);
    model.set("ellipse", [sv, sp, e]);
  }

  const handles = [hC, hV, hP];
  const m = mount({
    model, host, kind: "ellipse", title: "Gravimorphism", width: SIZE, height: SIZE, draw, move,
    events: ["change:ellipse", "change:rays"],
    grab: (x, y) => {
      const i = nearest(handles, x, y, 14);
      return i < 0 ? null : handles[i].getAttribute("data-handle");
    },
  });
  m.view.svg.append(el("line", { x1: O[0], y1: 0, x2: O[0], y2: SIZE, stroke: "#ddd" }),
    el("line", { x1: 0, y1: O[1], x2: SIZE, y2: O[1], stroke: "#ddd" }), gRays, ell, axisDot, lv, lp, ...handles);
  return m.start();
}

// Angles (items 2 and 4): rays from the top of a vertical parent axis, one per angle (degrees from up; side +1
// right, -1 left). Drag a handle to set its angle, clamped to [lo, hi].
function angles(model, host) {
  const W = 200, H = 190, L = 80, O = [W / 2, H * 0.58];
  function tipOf(a, side, len) {
    const r = a * Math.PI / 180;
    return [O[0] + side * Math.sin(r) * len, O[1] - Math.cos(r) * len];
  }
  let handles = [];
  function draw({ svg, readout }) {
    const specs = model.get("specs") || [], ang = model.get("angles") || [];
    svg.replaceChildren(el("line", { x1: O[0], y1: H - 6, x2: O[0], y2: O[1], class: "arch-axis" }),
      el("line", { x1: O[0], y1: O[1], x2: O[0], y2: O[1] - L - 10, stroke: "#bbb", "stroke-dasharray": "4 3" }));
    handles = [];
    specs.forEach((s, i) => {
      const a = ang[i], t = tipOf(a, s.side, L);
      const r0 = Math.min(30, L / 3), large = 0;
      const arcStart = tipOf(0, s.side, r0), arcEnd = tipOf(a, s.side, r0);
      svg.appendChild(el("path", { d: `M ${arcStart[0]} ${arcStart[1]} A ${r0} ${r0} 0 ${a > 180 ? 1 : large} ` +
        `${s.side > 0 ? 1 : 0} ${arcEnd[0]} ${arcEnd[1]}`, fill: "none", stroke: s.color, "stroke-width": 1.5 }));
      svg.appendChild(el("line", { x1: O[0], y1: O[1], x2: t[0], y2: t[1], stroke: s.color, "stroke-width": 4,
        "stroke-linecap": "round", class: "angle-ray", "data-name": s.name }));
      const h = el("circle", { cx: t[0], cy: t[1], r: 7, class: "arch-handle angle-handle", "data-name": s.name });
      svg.appendChild(h);
      handles.push(h);
      const lab = tipOf(a, s.side, L + 18);
      const txt = el("text", { x: lab[0], y: lab[1], fill: s.color, "text-anchor": "middle", class: "arch-label" });
      txt.textContent = s.label.split(" ")[0];
      svg.appendChild(txt);
    });
    readout.innerHTML = specs.map((s, i) =>
      `<span style="color:${s.color}" data-name="${s.name}">${s.label} ${ang[i].toFixed(1)}°</span>`).join("<br>");
  }
  function move(x, y, grab) {
    const s = model.get("specs")[grab], a = model.get("angles").slice();
    a[grab] = angleFromVector(x - O[0], O[1] - y, s.side, s.lo, s.hi);
    model.set("angles", a);
  }

  return mount({
    model, host, kind: "angles", width: W, height: H, draw, move, events: ["change:angles", "change:specs"],
    grab: (x, y) => { const i = nearest(handles, x, y, 16); return i < 0 ? null : i; },
  }).start();
}

const KINDS = { schematic, ellipse, angles };

function render({ model, el: host }) {
  const kind = model.get("kind"), make = KINDS[kind];
  if (!make) throw new Error(`plantvr architecture widget: kind must be one of ${Object.keys(KINDS)}, got ${kind}`);
  return make(model, host);
}

export default { render };
