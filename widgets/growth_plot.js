// Live plot of growth: ms/step (orange, left axis) and internodes (green, right axis) against step.
function render({ model, el }) {
  const canvas = document.createElement("canvas");
  canvas.style.border = "1px solid #ccc";
  el.appendChild(canvas);
  function draw() {
    const W = model.get("width"), H = model.get("height");
    canvas.width = W; canvas.height = H;
    const g = canvas.getContext("2d");
    g.fillStyle = "#fff"; g.fillRect(0, 0, W, H);
    const s = model.get("steps"), ms = model.get("ms"), n = model.get("internodes");
    const L = 44, Rm = 74, T = 14, B = 22;
    g.font = "11px sans-serif"; g.fillStyle = "#444";
    g.fillText("step", W / 2 - 10, H - 4);
    if (s.length < 1) { g.fillText("no steps yet", W / 2 - 30, H / 2); return; }
    const x0 = s[0], x1 = Math.max(s[s.length - 1], x0 + 1);
    const X = (v) => L + (v - x0) / (x1 - x0) * (W - L - Rm);
    g.strokeStyle = "#bbb"; g.lineWidth = 1; g.beginPath();            // the axes
    g.moveTo(L, T); g.lineTo(L, H - B); g.lineTo(W - Rm, H - B); g.lineTo(W - Rm, T); g.stroke();
    g.fillText(String(x0), L, H - 4); g.textAlign = "right"; g.fillText(String(x1), W - Rm, H - 4);
    g.textAlign = "left";
    const series = [[ms, "#e67e22", "ms/step", L - 4, "right"], [n, "#27ae60", "internodes", W - Rm + 4, "left"]];
    for (const [ys, col, name, tx, align] of series) {
      const top = Math.max(...ys, 1e-9), Y = (v) => H - B - v / top * (H - B - T);
      g.strokeStyle = col; g.lineWidth = 1.5; g.beginPath();
      ys.forEach((v, i) => (i ? g.lineTo(X(s[i]), Y(v)) : g.moveTo(X(s[i]), Y(v))));
      g.stroke();
      g.fillStyle = col;
      if (ys.length < 40) ys.forEach((v, i) => g.fillRect(X(s[i]) - 2, Y(v) - 2, 4, 4));  // few points: dots
      g.textAlign = align;
      g.fillText(top.toPrecision(3), tx, T + 4); g.fillText("0", tx, H - B);
      g.fillText(name, tx, H / 2);
    }
    g.textAlign = "left";
  }
  const evs = ["change:steps", "change:ms", "change:internodes", "change:width", "change:height"];
  evs.forEach((e) => model.on(e, draw));
  draw();
  return () => evs.forEach((e) => model.off(e, draw));
}
export default { render };
