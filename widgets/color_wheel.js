// Colour wheel (spec 000_vine §2.4.1, §2.6): one slice per colour-table entry, counter-clockwise from +x.
// Click selects (the selected slice is extruded); shift-click toggles visibility (hidden = radial lines);
// the colour picker edits the selected colour. State lives only in the synced traits.
const NS = "http://www.w3.org/2000/svg";
const R = 110, EXTRUDE = 14, PAD = 18, DEAD = 0.15;

function el(tag, attrs) {
  const e = document.createElementNS(NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  return e;
}
export function sliceAt(x, y, n, last) {  // x, y in wheel units, y up
  if (Math.hypot(x, y) < DEAD) return last;
  const a = ((Math.atan2(y, x) % (2 * Math.PI)) + 2 * Math.PI) % (2 * Math.PI);
  return Math.min(Math.floor(a / (2 * Math.PI / n)), n - 1);
}
function contrast(hex) {
  const v = parseInt(hex.slice(1), 16), r = v >> 16, g = (v >> 8) & 255, b = v & 255;
  return 0.299 * r + 0.587 * g + 0.114 * b > 140 ? "#000000" : "#ffffff";
}

function render({ model, el: host }) {
  const C = R + EXTRUDE + PAD;
  const root = document.createElement("div");
  root.className = "plantvr-wheel";
  const svg = el("svg", { width: 2 * C, height: 2 * C, class: "wheel-svg" });
  const bar = document.createElement("div");
  bar.className = "wheel-bar";
  const swatch = document.createElement("span");
  swatch.className = "wheel-label";
  const picker = document.createElement("input");
  picker.type = "color";
  picker.className = "wheel-picker";
  const toggle = document.createElement("button");
  toggle.className = "wheel-toggle";
  const err = document.createElement("div");
  err.className = "wheel-error";
  bar.append(swatch, picker, toggle);
  root.append(svg, bar, err);
  host.appendChild(root);

  const pt = (r, a) => [C + r * Math.cos(a), C - r * Math.sin(a)];
  function draw() {
    const colors = model.get("colors"), hidden = model.get("hidden"), sel = model.get("selected");
    const n = colors.length, da = 2 * Math.PI / n;
    while (svg.firstChild) svg.removeChild(svg.firstChild);
    const order = [...Array(n).keys()].filter((k) => k !== sel).concat([sel]);  // selected on top
    for (const k of order) {
      const r = k === sel ? R + EXTRUDE : R, a0 = k * da, a1 = (k + 1) * da;
      const [x0, y0] = pt(r, a0), [x1, y1] = pt(r, a1);
      const g = el("g", { class: "wheel-slice" + (k === sel ? " selected" : "") + (hidden[k] ? " hidden" : ""),
                          "data-index": k });
      const d = n === 1 ? `M ${C - r} ${C} a ${r} ${r} 0 1 0 ${2 * r} 0 a ${r} ${r} 0 1 0 ${-2 * r} 0`
        : `M ${C} ${C} L ${x0} ${y0} A ${r} ${r} 0 ${da > Math.PI ? 1 : 0} 0 ${x1} ${y1} Z`;
      g.appendChild(el("path", { d, fill: colors[k], stroke: k === sel ? "#222" : "#fff",
                                 "stroke-width": k === sel ? 2.5 : 1 }));
      if (hidden[k]) {  // contrasting radial lines across the slice (Fig. 5.11)
        const lines = 5, ink = contrast(colors[k]);
        for (let i = 1; i <= lines; i++) {
          const a = a0 + (i / (lines + 1)) * da, [xa, ya] = pt(0.25 * r, a), [xb, yb] = pt(0.97 * r, a);
          g.appendChild(el("line", { x1: xa, y1: ya, x2: xb, y2: yb, stroke: ink, "stroke-width": 2.5,
                                     class: "wheel-hidden-line" }));
        }
      }
      const [tx, ty] = pt(0.72 * r, a0 + da / 2);
      const t = el("text", { x: tx, y: ty + 4, "text-anchor": "middle", fill: contrast(colors[k]), class: "wheel-num" });
      t.textContent = k;
      g.appendChild(t);
      svg.appendChild(g);
    }
    svg.appendChild(el("circle", { cx: C, cy: C, r: DEAD * R, fill: "#f4f4f4", stroke: "#999" }));
    swatch.textContent = `label ${sel}`;
    swatch.style.borderColor = colors[sel];
    picker.value = colors[sel];
    toggle.textContent = hidden[sel] ? "show" : "hide";
    err.textContent = model.get("error") || "";
  }

  function select(k) { model.set("selected", k); model.save_changes(); }
  function toggleHidden(k) {
    const h = [...model.get("hidden")]; h[k] = !h[k];
    model.set("hidden", h); model.save_changes();
  }
  svg.addEventListener("click", (ev) => {
    const r = svg.getBoundingClientRect();
    const x = (ev.clientX - r.left - C) / R, y = -(ev.clientY - r.top - C) / R;
    if (Math.hypot(x, y) > (R + EXTRUDE) / R) return;
    const k = sliceAt(x, y, model.get("colors").length, model.get("selected"));
    if (ev.shiftKey) toggleHidden(k); else select(k);
  });
  toggle.addEventListener("click", () => toggleHidden(model.get("selected")));
  picker.addEventListener("change", () => {
    const c = [...model.get("colors")]; c[model.get("selected")] = picker.value;
    model.set("colors", c); model.save_changes();
  });

  const evs = ["change:colors", "change:hidden", "change:selected", "change:error"];
  evs.forEach((e) => model.on(e, draw));
  draw();
  return () => evs.forEach((e) => model.off(e, draw));
}

export default { render };
