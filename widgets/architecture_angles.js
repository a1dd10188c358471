// Angle widget (spec 004 §2.3 items 2 and 4): rays from the top of a vertical parent axis, one per angle
// (degrees from up; side +1 right, -1 left). Drag a handle to set its angle, clamped to [lo, hi].
const NS = "http://www.w3.org/2000/svg";
const W = 200, H = 190, L = 80;

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
export function angleFromVector(dx, dyUp, side, lo, hi) {
  const a = Math.atan2(Math.max(side * dx, 0), dyUp) * 180 / Math.PI;
  return Math.min(hi, Math.max(lo, a));
}

function render({ model, el: host }) {
  // drags send to the kernel at most every 120 ms (each change regrows the schematic there) and once on release
  let lastSent = 0, pending = false;
  function commit(force) {
    const now = performance.now();
    if (force || now - lastSent > 120) { model.save_changes(); lastSent = now; pending = false; } else pending = true;
  }
  const root = document.createElement("div");
  root.className = "plantvr-arch plantvr-angles";
  const svg = el("svg", { width: W, height: H, class: "arch-svg angles-svg" });
  const readout = document.createElement("div");
  readout.className = "arch-readout";
  const err = document.createElement("div");
  err.className = "arch-error";
  root.append(svg, readout, err);
  host.appendChild(root);
  const O = [W / 2, H * 0.58];

  function tipOf(a, side, len) {
    const r = a * Math.PI / 180;
    return [O[0] + side * Math.sin(r) * len, O[1] - Math.cos(r) * len];
  }
  let handles = [];
  function draw() {
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
    err.textContent = model.get("error") || "";
  }

  let grab = -1;
  function local(ev) {
    const r = svg.getBoundingClientRect();
    return [ev.clientX - r.left, ev.clientY - r.top];
  }
  svg.addEventListener("pointerdown", (ev) => {
    const [x, y] = local(ev);
    let bd = 16;
    grab = -1;
    handles.forEach((h, i) => {
      const d = Math.hypot(x - +h.getAttribute("cx"), y - +h.getAttribute("cy"));
      if (d < bd) { bd = d; grab = i; }
    });
    if (grab >= 0) svg.setPointerCapture?.(ev.pointerId);
  });
  svg.addEventListener("pointermove", (ev) => {
    if (grab < 0) return;
    const [x, y] = local(ev), s = model.get("specs")[grab];
    const a = model.get("angles").slice();
    a[grab] = angleFromVector(x - O[0], O[1] - y, s.side, s.lo, s.hi);
    model.set("angles", a);
    commit(false);
  });
  const end = () => { grab = -1; if (pending) commit(true); };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);

  const evs = ["change:angles", "change:specs", "change:error"];
  evs.forEach((e) => model.on(e, draw));
  draw();
  return () => evs.forEach((e) => model.off(e, draw));
}

export default { render };
