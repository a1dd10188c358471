// Gravimorphism widget (spec 004 §2.3 item 3, Fig. 4.20B): the control ellipse (s_v, s_p, e_v) in the plane
// across the parent axis, bud lines coloured red -> green by the relative resource factor b (from Python).
// Drag the centre vertically (e_v), the top handle (s_v) or the side handle (s_p).
const NS = "http://www.w3.org/2000/svg";
const SIZE = 220, S = 45;  // pixels per unit

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
export function redGreen(t) {  // t in [0, 1]: red (few resources) -> green (many)
  const a = [214, 48, 39], b = [26, 152, 80];
  return `rgb(${a.map((x, i) => Math.round(x + (b[i] - x) * t)).join(",")})`;
}

function render({ model, el: host }) {
  // drags send to the kernel at most every 120 ms (each change regrows the schematic there) and once on release
  let lastSent = 0, pending = false;
  function commit(force) {
    const now = performance.now();
    if (force || now - lastSent > 120) { model.save_changes(); lastSent = now; pending = false; } else pending = true;
  }
  const root = document.createElement("div");
  root.className = "plantvr-arch plantvr-ellipse";
  const title = document.createElement("div");
  title.className = "arch-title";
  title.textContent = "Gravimorphism";
  const svg = el("svg", { width: SIZE, height: SIZE, class: "arch-svg ellipse-svg" });
  const readout = document.createElement("div");
  readout.className = "arch-readout";
  const err = document.createElement("div");
  err.className = "arch-error";
  root.append(title, svg, readout, err);
  host.appendChild(root);

  const O = [SIZE / 2, SIZE / 2];
  const gRays = el("g", { class: "ellipse-rays" });
  const ell = el("ellipse", { class: "arch-ellipse" });
  const axisDot = el("circle", { cx: O[0], cy: O[1], r: 4, fill: "#8a7f70" });
  const lv = el("text", { x: O[0] + 4, y: 12, class: "arch-label" }); lv.textContent = "V (up)";
  const lp = el("text", { x: SIZE - 14, y: O[1] - 4, class: "arch-label" }); lp.textContent = "P";
  const hC = el("circle", { r: 6, class: "arch-handle ellipse-center", "data-handle": "e_v" });
  const hV = el("circle", { r: 6, class: "arch-handle ellipse-top", "data-handle": "s_v" });
  const hP = el("circle", { r: 6, class: "arch-handle ellipse-side", "data-handle": "s_p" });
  svg.append(el("line", { x1: O[0], y1: 0, x2: O[0], y2: SIZE, stroke: "#ddd" }),
    el("line", { x1: 0, y1: O[1], x2: SIZE, y2: O[1], stroke: "#ddd" }), gRays, ell, axisDot, lv, lp, hC, hV, hP);

  function draw() {
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
    err.textContent = model.get("error") || "";
  }

  let grab = null;
  function local(ev) {
    const r = svg.getBoundingClientRect();
    return [ev.clientX - r.left, ev.clientY - r.top];
  }
  function move(ev) {
    if (!grab) return;
    const [x, y] = local(ev);
    let [sv, sp, e] = model.get("ellipse");
    if (grab === "e_v") e = (O[1] - y) / S;
    if (grab === "s_v") sv = Math.max(0.05, Math.abs((O[1] - e * S) - y) / S);
    if (grab === "s_p") sp = Math.max(0.05, Math.abs(x - O[0]) / S);
    model.set("ellipse", [sv, sp, e]);
    commit(false);
  }
  svg.addEventListener("pointerdown", (ev) => {
    const [x, y] = local(ev);
    let best = null, bd = 14;
    for (const h of [hC, hV, hP]) {
      const dd = Math.hypot(x - +h.getAttribute("cx"), y - +h.getAttribute("cy"));
      if (dd < bd) { bd = dd; best = h.getAttribute("data-handle"); }
    }
    grab = best;
    if (grab) svg.setPointerCapture?.(ev.pointerId);
  });
  svg.addEventListener("pointermove", move);
  const end = () => { grab = null; if (pending) commit(true); };
  svg.addEventListener("pointerup", end);
  svg.addEventListener("pointercancel", end);

  const evs = ["change:ellipse", "change:rays", "change:error"];
  evs.forEach((e) => model.on(e, draw));
  draw();
  return () => evs.forEach((e) => model.off(e, draw));
}

export default { render };
