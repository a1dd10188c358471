"""ViNE browser painting benchmark (issue 14): frames per second while painting a stroke on the display proxy in
headless Chromium (software WebGL: SwiftShader on this 2-core CPU machine), and the bytes a stroke sends.

Each configuration serves a ``VineReviewApp`` (trame-vtk ``VtkLocalView``, vtk.js) and paints one stroke in the
page: ctrl-pointer events dispatched on the canvas every 16 ms (a 60 Hz mouse) along a left-to-right arc through
the view's centre for ``--seconds``. The page hook sends the positions to the server (at most one request in
flight, positions coalesced meanwhile), the server picks them (``vtkStaticCellLocator`` on the drawn proxy) and
stamps the full-resolution labels, and each reply's colour delta is applied in place and drawn at the next
animation frame. With ``finish`` on, every render waits for the (software) GPU (it reads one pixel back:
``gl.finish`` returns before SwiftShader has drawn), so a frame is only counted once it has been drawn.
Measured per configuration:

- ``first frame``: page load until the scene's actors and colour arrays are there and drawn;
- ``redraw`` / ``with buffer rebuild``: one frame of the display proxy at rest, drawn as is and after marking its
  data modified (vtk.js then rebuilds every vertex buffer: what a colour delta costs without a finer path);
- ``fps``: requestAnimationFrame callbacks per second while the stroke runs (the page's frame rate);
- ``updates/s``: renders showing new paint per second (one per delta batch, at most one per frame);
- ``rtt``: median round trip of a stroke request (server pick + stamp + delta and the websocket);
- ``end``: from the release to the stroke's last batch drawn (the display proxy is drawn again then);
- ``B/stroke``: websocket bytes the page received (server → page) and sent (page → server) during the stroke;
- server-side seconds per stamp for picking, stamping (full-resolution labels, both proxies' labels) and
  building deltas.

Configurations: ``proxy`` paints while drawing the display proxy itself; ``lod`` draws the ``--lod``-face level of
detail while the stroke (or an orbit) runs and the display proxy again after it (the default of the app);
``array`` is the baseline for bytes: each request re-synchronises the scene (the whole colour array) instead of
sending deltas. Meshes: a synthetic head (64³ or 128³) copied in a row to the proxy budget and served as its own
proxy, the view zoomed onto the last copy (the others stay in the scene and are drawn)
(decimating an 18 M-vertex head to such a proxy is the core's part, ``benchmarks/vine_proxy.py``); budgets
~50k, ~200k and ~1.5 M faces; ``--quick`` uses one 64³ head (23,862 faces) with a 6k-face level of detail.

Run: ``python benchmarks/vine_render.py [--quick] [--budgets 50000,200000,1500000] [--seconds S] [--gerbera]``.

``--gerbera`` paints on the display proxy of ONE synthetic gerbera-class head instead (1624x1624x710 volume, 48
veins, 6,000 noise blobs: 18,074,781 vertices / 36,125,180 faces, proxy budget 1.5 M faces, level of detail
decimated from the proxy). Measured once (quiet machine): with the 20k-face level of detail drawn during the
stroke 37.1 fps, **12.3 paint updates/s** (render 48 ms, round trip 8 ms, stamp 7.6 ms server-side for ~9k
full-resolution vertices per stamp), 260 KB received for 31,832 changed proxy vertices (8.2 B each; the whole
colour array is 3.0 MB), first frame 7.7 s (45.7 MB scene); drawing the 1.5 M-face proxy itself while painting:
1.5 fps, 0.5 updates/s (1.9 s per software frame) — that needs a real GPU.

Measured (2-core CPU machine, headless Chromium, SwiftShader WebGL, 596x556 canvas, a 3 s stroke), two full
runs: A with other work running on the machine (load average ~7), B quieter (load ~2). fps = page frames per
second (rAF), upd/s = renders showing new paint per second, render = one such render, bytes = websocket bytes
the page received during the stroke (``array``: whole colour arrays instead of deltas, same stroke):

==========  =======  ===============  ===============  ===============  ================  ==================
proxy       drawn    A: fps / upd/s   B: fps / upd/s   render (A / B)   bytes (A / B)     bytes, ``array``
==========  =======  ===============  ===============  ===============  ================  ==================
47,724      proxy    11.5 / 4.5       16.5 / 6.9       200 / 120 ms     7,286 / 8,967     7.6 / 4.4 MB
47,724      20k LOD  18.9 / 7.0       29.5 / 12.3      117 / 48 ms      12,193 / 15,152
218,916     proxy     8.1 / 3.2        6.4 / 2.4       292 / 373 ms     21,015 / 16,053   11.7 / 5.4 MB
218,916     20k LOD  29.5 / 10.6      23.4 / 8.2       63 / 89 ms       33,694 / 31,444
1,532,412   proxy     1.6 / 0.6        2.7 / 0.9       1.4 / 1.0 s      6,463 / 8,087
1,532,412   20k LOD  42.5 / 7.8       44.8 / 7.8       49 / 48 ms       36,309 / 36,758
==========  =======  ===============  ===============  ===============  ================  ==================

- Which budget reaches >= 5 fps in software WebGL: painting while drawing a proxy of ~50k faces is at the edge
  (4.3-6.9 paint updates/s over five runs, depending on the machine's load; 11-17 fps page frame rate); with
  the 20k-face level of detail the app draws while a stroke runs (its default), painting runs at 7-12
  updates/s and 19-45 fps at every budget, 1.5 M faces included. Drawing the 200k- or 1.5 M-face proxy itself
  while painting does not reach 5 fps in software (0.3-0.7 s and 1-2 s per frame): a 1.5 M-face proxy needs a
  real GPU to be drawn at interactive rates; in software it is drawn once per stroke, when the stroke ends
  (0.5-2 s, "end of stroke").
- Where a stroke's time goes (per update): the render dominates (SwiftShader, one frame at this canvas: ~60 ms
  at 24k triangles, 110-200 ms at 48k, 0.26-0.7 s at 219k, 0.5-2 s at 1.5 M); the request's round trip is
  7-20 ms when the page is not busy drawing; the server spends ~0.4-0.7 ms picking (``vtkStaticCellLocator``,
  ~0.1 ms of it the ray query) and ~1-2 ms stamping (full-resolution labels and both proxies) per stamp and
  ~0.2 ms building a delta. Colour deltas go straight into vtk.js's GPU colour buffer ("recoloured in the GPU
  buffer": all batches), so marking the data modified (which rebuilds all vertex buffers: a 1.5 M-face frame
  then takes 1.4-2.6 s instead of 0.5-1.2 s) is avoided.
- Bytes per stroke: ~8 B per changed proxy vertex (uint32 id + RGBA, both levels of detail) plus ~200 B of
  message framing per request: 7-36 KB per 3 s stroke, against 7.6-11.7 MB when every request re-sends the
  whole colour array (``array``; 4 B per proxy vertex) and 46 MB for the 1.5 M-face scene itself. The page
  sends 5-32 KB per stroke (positions and camera).
- ``--quick`` (one 64³ head, 23,862 faces, 6k-face level of detail, 0.8 s stroke, ~20-30 s in all): 20-34
  fps / 7-14 updates/s drawing the proxy, 30-50 fps / 13-19 updates/s on the level of detail; 5-10 KB per
  stroke vs 0.65-1.4 MB re-sending whole arrays.
- Not measured here: the proxy of a real 18 M-vertex head (the tiled heads stand in for a 1.5 M-face proxy;
  decimation is the core's benchmark).

Before this (issue 14, first version): a click was picked in the browser by the vtk.js hardware selector (an
extra selection render pass) and every delta rebuilt all vertex buffers: ~4.7 s per stamp at a 200k-face
proxy in software, and no pick came back at all at 1.5 M faces.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from plantvr._browser import CHROMIUM, launch_chromium
from plantvr.documents.labels import Segmentation
from plantvr.adapters.vtk_isosurface import extract_isosurface
from plantvr.vine.synth import synth_flowerhead

#: One stroke, driven in the page: ctrl-pointer events on the canvas at 60 Hz, frames counted meanwhile.
_STROKE_JS = """async ({dur, r}) => {
  const v = window.vineDelta; v.finish = true;
  const c = document.querySelector('.vine-view canvas'); const b = c.getBoundingClientRect();
  const cx = b.left + b.width / 2, cy = b.top + b.height / 2;
  const frames = []; let run = true;
  const f = (t) => { frames.push(performance.now()); if (run) requestAnimationFrame(f); };
  requestAnimationFrame(f);
  const ev = (type, x, y) => c.dispatchEvent(new PointerEvent(type, {clientX: x, clientY: y, button: 0,
      buttons: type === 'pointerup' ? 0 : 1, ctrlKey: true, bubbles: true, cancelable: true, pointerId: 1,
      isPrimary: true}));
  const n0 = v.strokes, r0 = v.renders.length, l0 = v.log.length, fast0 = v.fast, ap0 = v.applied;
  const t0 = performance.now();
  ev('pointerdown', cx - r, cy);
  let moves = 0;
  while (performance.now() - t0 < dur) {
    await new Promise(res => setTimeout(res, 16));
    const a = Math.min((performance.now() - t0) / dur, 1);
    ev('pointermove', cx - r + 2 * r * a, cy + 0.25 * r * Math.sin(6.283 * a)); moves++;
  }
  const tUp = performance.now();
  ev('pointerup', cx + r, cy);
  while (v.strokes === n0) await new Promise(res => setTimeout(res, 5));
  await new Promise(res => requestAnimationFrame(() => requestAnimationFrame(res)));
  const tEnd = performance.now();
  run = false;
  v.finish = false;
  return {t0, tUp, tEnd, moves, fast: v.fast - fast0, applied: v.applied - ap0, frames: frames.filter(t => t >= t0 && t <= tUp).length,
          renders: v.renders.slice(r0).filter(x => x[0] >= t0 && x[0] <= tUp).map(x => x[1]),
          rtt: v.log.slice(l0).map(e => e.back - e.sent), points: v.log.slice(l0).map(e => e.points),
          last_render_ms: v.renders.length ? v.renders[v.renders.length - 1][1] : 0};
}"""


_FRAME_JS = """() => {
  const v = window.trame.refs.vine_view.$.provides.view, gl = v.openglRenderWindow.getContext();
  const px = new Uint8Array(4);
  const t = (f) => { const a = performance.now(); f(); v.renderWindow.render();
                     gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px); return performance.now() - a; };
  const med = (x) => x.sort((a, b) => a - b)[x.length >> 1];
  const draw = med([t(() => 0), t(() => 0), t(() => 0)]);
  const actors = v.renderer.getActors().filter(a => a.getVisibility());
  const rebuild = med([0, 1, 2].map(() => t(() => actors.forEach(a => a.getMapper().getInputData().modified()))));
  return {draw_ms: draw, rebuild_ms: rebuild};
}"""


def _measure(browser, seg: Segmentation, budget: int, config: str, lod: int, radius: float, seconds: float,
             shots: Path | None, tag: str, focus) -> dict:
    from plantvr.view.vine_app import VineReviewApp
    t0 = time.perf_counter()
    app = VineReviewApp(seg, target_faces=budget, radius=radius, window_size=(800, 560),
                        interactive_faces=lod if config == "lod" else None,
                        colour_updates="array" if config == "array" else "delta")
    app.state.label = 2                                       # red
    app.view.plotter.reset_camera(bounds=focus)               # the first copy fills the view (zoomed in to paint)
    app.view.plotter.camera.elevation = -35
    out: dict = {"config": config, "proxy_vertices": app.proxy.n_vertices, "proxy_faces": len(app.proxy.faces),
                 "lod_faces": 0 if app.lod is None else len(app.lod.faces), "app_s": time.perf_counter() - t0}
    url = app.start()
    page = browser.new_page(viewport={"width": 800, "height": 640})
    rx, tx = [], []
    page.on("websocket", lambda ws: (ws.on("framereceived", lambda m: rx.append(len(m))),
                                     ws.on("framesent", lambda m: tx.append(len(m)))))
    try:
        t0 = time.perf_counter()
        page.goto(url)
        page.wait_for_selector(".vine-view canvas", timeout=300_000)
        page.wait_for_function("() => window.vineDelta && window.vineDelta.ready()", timeout=300_000, polling=100)
        # first frame drawn: a render that waits for the GPU
        page.evaluate("() => { const v = window.trame.refs.vine_view.$.provides.view; v.renderWindow.render();"
                      " const gl = v.openglRenderWindow.getContext();"
                      " gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4)); }")
        out["first_frame_s"] = time.perf_counter() - t0
        # where a frame's time goes: a plain redraw vs one that rebuilds the actors' buffers (data modified)
        out.update(page.evaluate(_FRAME_JS))
        n = -1
        while n != len(rx):                                   # the scene's last arrays have arrived
            n = len(rx)
            page.wait_for_timeout(300)
        out["scene_bytes"] = sum(rx)
        rx.clear()
        tx.clear()
        st0 = dict(app.stroke_stats)
        r = page.evaluate(_STROKE_JS, {"dur": 1000 * seconds, "r": 70})
        page.wait_for_timeout(300)
        dur = (r["tUp"] - r["t0"]) / 1e3
        st = {k: app.stroke_stats[k] - st0[k] for k in st0}
        stamps = max(st["stamps"], 1)
        out.update({
            "fps": r["frames"] / dur, "updates_per_s": len(r["renders"]) / dur,
            "render_ms": float(np.median(r["renders"])) if r["renders"] else float("nan"),
            "rtt_ms": float(np.median(r["rtt"])), "end_s": (r["tEnd"] - r["tUp"]) / 1e3,
            "final_render_ms": r["last_render_ms"], "moves": r["moves"], "fast": r["fast"],
            "applied": r["applied"], "requests": st["requests"],
            "stamps": st["stamps"], "misses": st["misses"], "bytes_rx": sum(rx), "bytes_tx": sum(tx),
            "changed_full": int(np.count_nonzero(seg.labels)), "delta_vertices": app.delta_vertices,
            "pick_ms": 1e3 * st["pick_s"] / stamps, "paint_ms": 1e3 * st["paint_s"] / stamps,
            "delta_ms": 1e3 * st["delta_s"] / max(st["requests"], 1),
            "colour_array_bytes": 4 * app.proxy.n_vertices,
        })
        if len(seg.history.undo_stack) != 1:
            raise RuntimeError(f"{tag}: the stroke was not one undo item ({len(seg.history.undo_stack)})")
        if shots is not None:
            page.screenshot(path=str(shots / f"vine_render_{tag}.png"))
    finally:
        page.close()
        app.stop()
        seg.labels[:] = 0
        seg.history.undo_stack.clear()
        seg.history.redo_stack.clear()
    return out


def _mesh(budget: int, quick: bool):
    """A synthetic head copied in a row along x to about ``budget`` faces, and the bounds of the last copy (the
    painted one: nothing stands between it and the default camera)."""
    head = synth_flowerhead(64 if quick or budget < 100_000 else 128, rng=1)
    s = extract_isosurface(head.volume, head.level)
    copies = 1 if quick else max(1, round(budget / len(s.faces)))
    v0, f0 = np.asarray(s.vertices, np.float32), np.asarray(s.faces, np.int64)
    step = np.float32(1.05 * np.ptp(v0[:, 0]))
    v = np.concatenate([v0 + np.float32([c * step, 0, 0]) for c in range(copies)])
    f = np.concatenate([f0 + c * len(v0) for c in range(copies)]).astype(np.uint32)
    last = v[(copies - 1) * len(v0):]
    return v, f, np.c_[last.min(axis=0), last.max(axis=0)].ravel()


def _gerbera_mesh():
    """One synthetic head in a 1624×1624×710 volume (the gerbera class) with 48 veins and 6,000 noise blobs:
    18.1 M vertices / 36.1 M faces, and its bounds."""
    head = synth_flowerhead((1624, 1624, 710), n_veins=48, noise_blobs=6000, rng=1)
    s = extract_isosurface(head.volume, head.level)
    del head
    v = np.asarray(s.vertices, np.float32)
    return v, np.asarray(s.faces, np.uint32), np.c_[v.min(axis=0), v.max(axis=0)].ravel()


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="one 64³ head (23,862 faces), 6k-face LOD (CI)")
    ap.add_argument("--budgets", type=str, default="50000,200000,1500000", help="proxy face budgets")
    ap.add_argument("--lod", type=int, default=20_000, help="faces of the level of detail drawn while painting")
    ap.add_argument("--seconds", type=float, default=3.0, help="length of the stroke")
    ap.add_argument("--shots", type=str, default=os.environ.get("PLANTVR_SCREENSHOTS"))
    ap.add_argument("--gerbera", action="store_true",
                    help="paint on the 1.5 M-face display proxy of one 18 M-vertex / 36 M-face synthetic head")
    a = ap.parse_args(argv)
    if not Path(CHROMIUM).exists():
        print("chromium not installed: skipped")
        return {"skipped": True}
    from playwright.sync_api import sync_playwright
    shots = Path(a.shots) if a.shots else None
    if shots:
        shots.mkdir(parents=True, exist_ok=True)
    budgets = [0] if a.quick else [36_000_000] if a.gerbera else [int(b) for b in a.budgets.split(",")]
    lod, seconds = (6000, 0.8) if a.quick else (a.lod, a.seconds)
    results = []
    with sync_playwright() as p:
        browser = launch_chromium(p)
        for budget in budgets:
            v, f, focus = _gerbera_mesh() if a.gerbera else _mesh(budget, a.quick)
            seg = Segmentation(v, f)
            del v
            radius = 0.03 * float(np.linalg.norm(focus[1::2] - focus[::2]))
            proxy_budget = 1_500_000 if a.gerbera else len(f)     # else the mesh is served as its own proxy
            configs = (["lod", "proxy"] if a.gerbera else
                       ["proxy"] + (["lod"] if len(f) > lod else []) + (["array"] if len(f) <= 250_000 else []))
            if a.gerbera:
                print(f"mesh {seg.n_vertices:,} vertices / {len(f):,} faces; display proxy budget {proxy_budget:,}",
                      flush=True)
            for config in configs:
                r = _measure(browser, seg, proxy_budget, config, lod, radius, seconds, shots,
                             f"{len(f)}_{config}", focus)
                results.append(r)
                lodtxt = f" (LOD {r['lod_faces']:,} faces)" if r["lod_faces"] else ""
                print(f"{r['proxy_faces']:>9,} faces {config:5s}{lodtxt}: first frame {r['first_frame_s']:.1f} s "
                      f"({r['scene_bytes']:,} B), redraw {r['draw_ms']:.0f} ms, with buffer rebuild "
                      f"{r['rebuild_ms']:.0f} ms; painting {r['fps']:.1f} fps, {r['updates_per_s']:.1f} updates/s "
                      f"(render {r['render_ms']:.0f} ms, rtt {r['rtt_ms']:.0f} ms, {r['stamps']} stamps from "
                      f"{r['requests']} requests, {r['moves']} moves, {r['misses']} misses; {r['fast']} of "
                      f"{r['applied']} batches' "
                      f"actors recoloured in the GPU buffer); end of stroke {r['end_s']:.2f} s; "
                      f"{r['bytes_rx']:,} B received / {r['bytes_tx']:,} B sent per stroke for "
                      f"{r['delta_vertices']:,} changed proxy vertices ({r['changed_full']:,} full-res; whole "
                      f"colour array {r['colour_array_bytes']:,} B); server per stamp: pick {r['pick_ms']:.2f} ms, "
                      f"stamp {r['paint_ms']:.2f} ms, delta {r['delta_ms']:.2f} ms/request", flush=True)
        browser.close()
    print("\nsummary (software WebGL, this machine): painting fps / bytes received per stroke")
    for r in results:
        ok = ("baseline for bytes (whole colour arrays)" if r["config"] == "array"
              else "≥ 5 fps" if r["fps"] >= 5 and r["updates_per_s"] >= 5 else "< 5 fps")
        print(f"  {r['proxy_faces']:>9,} faces  {r['config']:5s}  {r['fps']:5.1f} fps  {r['updates_per_s']:5.1f} "
              f"updates/s  {r['bytes_rx']:>10,} B  {ok}")
    return {"results": results}


if __name__ == "__main__":
    main()
