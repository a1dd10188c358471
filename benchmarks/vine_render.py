"""ViNE browser review benchmark (issue 14): client-side (vtk.js, trame-vtk ``VtkLocalView``) vs server-side
(``VtkRemoteView``) rendering of the display proxy, driven in headless Chromium (software WebGL).

Three configurations in the same run: ``local`` (vtk.js, per-vertex colour deltas applied in place by the page
hook), ``local-array`` (vtk.js, the whole colour array re-sent after each stroke: the former behaviour, the
baseline for bytes per stroke) and ``remote`` (server renders, images stream).
For each: time to first frame and bytes received until then, paint strokes (click → painted colour on screen:
latency and bytes received per stroke, averaged over ``--strokes`` clicks at different spots), and an orbit
drag (bytes and time). The server-side offscreen frame time of the
same mesh (pyvista, EGL/llvmpipe on a CPU machine) is printed as the remote path's floor.

Mesh: the display proxy of a synthetic head; by default a tiled mesh of ``--faces`` triangles (1.5 M, the
proxy budget at gerbera scale) is served as its own proxy; ``--quick`` uses one 64³ head decimated to 1/4.

Run: ``python benchmarks/vine_render.py [--quick] [--faces F] [--strokes K]``.

Measured (2-core CPU machine, headless Chromium with SwiftShader WebGL, same run for all three):

- ``--quick`` (2,979 proxy vertices): bytes per stroke 600 (deltas) vs 23,532 (whole colour array) vs 89,830
  (remote images).
- ``--faces 200000 --strokes 2`` (109,530 proxy vertices, 438 KB of colours; 1,054 proxy vertices changed per
  stroke): 8,783 B per stroke (deltas, 8.3 B per changed vertex) vs 449,768 B (whole array; 51x more) vs
  102,890 B (remote). Stroke latency there is software-WebGL bound: 4.7 s (deltas) vs 4.5 s (array) vs 1.4 s
  (remote); orbit 231 B local vs 50,141 B remote.
- Default ``--faces 1500000`` (766,710 proxy vertices): the first scene (21.8 MB) arrives in 3.7 s, but
  SwiftShader needs tens of seconds per frame, so the vtk.js click pick did not come back within the stroke
  timeout and no stroke was measured; that size needs a real GPU in the browser.
"""
from __future__ import annotations

import argparse
import io
import os
import time
from pathlib import Path

import numpy as np

from plantvr._browser import CHROMIUM, launch_chromium
from plantvr.vine.isosurface import extract_isosurface
from plantvr.vine.segmentation import Segmentation
from plantvr.vine.synth import synth_flowerhead, tile_mesh


def _view_img(page):
    from PIL import Image
    img = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
    b = page.locator(".vine-view").bounding_box()
    return img[int(b["y"]):int(b["y"] + b["height"]), int(b["x"]):int(b["x"] + b["width"])]


def _red(img) -> int:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return int(((r > 100) & (g < 0.5 * r) & (b < 0.5 * r)).sum())


def _until(page, cond, timeout):
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < timeout:
        if cond():
            return time.perf_counter() - t0
        page.wait_for_timeout(50)
    return float("nan")


def _measure(seg: Segmentation, config: str, budget: int, radius: float, shots: Path | None,
             strokes: int = 3) -> dict:
    from playwright.sync_api import sync_playwright

    from plantvr.view.vine_app import VineReviewApp
    mode = "remote" if config == "remote" else "local"
    updates = "array" if config == "local-array" else "delta"
    app = VineReviewApp(seg, target_faces=budget, mode=mode, radius=radius, window_size=(800, 560),
                        colour_updates=updates)
    app.state.label = 2                                       # red
    url = app.start()
    out: dict = {"proxy_vertices": app.proxy.n_vertices, "proxy_faces": len(app.proxy.faces)}
    try:
        with sync_playwright() as p:
            browser = launch_chromium(p)
            page = browser.new_page(viewport={"width": 800, "height": 640})
            rx = []
            page.on("websocket", lambda ws: ws.on("framereceived", lambda m: rx.append(len(m))))
            t0 = time.perf_counter()
            page.goto(url)
            page.wait_for_selector(".vine-view canvas", timeout=120_000)

            def drawn():
                img = _view_img(page)
                h, w = img.shape[0] // 2, img.shape[1] // 2
                return img[h - 2:h + 3, w - 2:w + 3].sum(axis=2).max() > 150
            _until(page, drawn, 300)
            out["first_frame_s"] = time.perf_counter() - t0
            page.wait_for_timeout(300)
            out["scene_bytes"] = sum(rx)
            box = page.locator(".vine-view").bounding_box()
            cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            ts, nbytes, spots = [], [], [(0, 0), (-18, 10), (14, -12), (-6, -20), (20, 16)][:max(1, strokes)]
            for k, (dx, dy) in enumerate(spots):
                page.wait_for_timeout(300)
                rx.clear()
                red0 = _red(_view_img(page))
                t0 = time.perf_counter()
                page.mouse.click(cx + dx, cy + dy)
                _until(page, lambda r0=red0: _red(_view_img(page)) > r0 + 5, 30)
                ts.append(time.perf_counter() - t0)
                page.wait_for_timeout(300)
                nbytes.append(sum(rx))
                if k == 0:
                    out["stroke_full_res_changed"] = int(np.count_nonzero(seg.labels))
            out["stroke_s"] = float(np.median(ts))
            out["stroke_bytes"] = int(np.mean(nbytes))
            out["stroke_bytes_each"] = nbytes
            out["strokes"] = len(spots)
            out["delta_vertices_per_stroke"] = app.delta_vertices / max(app.deltas, 1)
            out["in_place"] = page.evaluate("window.vineDelta ? window.vineDelta.applied : 0")
            if shots is not None:
                page.screenshot(path=str(shots / f"vine_render_{config}.png"))
            rx.clear()
            t0 = time.perf_counter()
            page.mouse.move(cx - 100, cy)
            page.mouse.down()
            page.mouse.move(cx + 100, cy + 30, steps=20)
            page.mouse.up()
            page.wait_for_timeout(500)
            out["orbit_s"] = time.perf_counter() - t0 - 0.5
            out["orbit_bytes"] = sum(rx)
            browser.close()
    finally:
        app.stop()
    seg.labels[:] = 0
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="one 64³ head, proxy 1/4 (CI)")
    ap.add_argument("--faces", type=int, default=1_500_000, help="triangles of the served proxy")
    ap.add_argument("--strokes", type=int, default=3, help="clicks per configuration (1-5)")
    ap.add_argument("--shots", type=str, default=os.environ.get("PLANTVR_SCREENSHOTS"))
    a = ap.parse_args(argv)
    if not Path(CHROMIUM).exists():
        print("chromium not installed: skipped")
        return {"skipped": True}
    shots = Path(a.shots) if a.shots else None
    if shots:
        shots.mkdir(parents=True, exist_ok=True)
    head = synth_flowerhead(64 if a.quick else 128, rng=1)
    s = extract_isosurface(head.volume, head.level)
    if a.quick:
        v, f, budget = s.vertices, s.faces, len(s.faces) // 4
    else:
        v, f = tile_mesh(s.vertices, s.faces, a.faces // 2)
        budget = len(f)                                      # served as its own proxy (no decimation here)
    seg = Segmentation(v, f)
    diag = float(np.linalg.norm(np.ptp(v, axis=0)))
    out: dict = {"vertices": seg.n_vertices, "faces": len(f)}
    print(f"mesh {seg.n_vertices:,} vertices / {len(f):,} faces, proxy budget {budget:,}")

    # the remote path's floor: one offscreen server-side frame of the same proxy
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    from plantvr.view.segmentation import SegmentationView
    from plantvr.vine.proxy import DisplayProxy
    px = DisplayProxy(seg, target_faces=budget)
    view = SegmentationView(seg, proxy=px, window_size=(800, 560))
    view.screenshot()
    ts = []
    for _ in range(3):
        t = time.perf_counter()
        view.plotter.render()
        ts.append(time.perf_counter() - t)
    out["server_frame_ms"] = 1e3 * min(ts)
    view.close()
    px.close()
    print(f"server-side offscreen frame of the proxy (CPU, 800x560): {out['server_frame_ms']:.0f} ms")

    for config in ("local", "local-array", "remote"):
        r = _measure(seg, config, budget, 0.05 * diag, shots, a.strokes)
        out[config] = r
        print(f"{config:11s}: first frame {r['first_frame_s']:.2f} s after {r['scene_bytes']:,} B; stroke "
              f"{r['stroke_s'] * 1e3:.0f} ms (median of {r['strokes']}), {r['stroke_bytes']:,} B received per "
              f"stroke ({r['stroke_full_res_changed']:,} full-res vertices painted by the first"
              + (f"; {r['delta_vertices_per_stroke']:.0f} proxy vertices per delta, {r['in_place']} applied in "
                 "place" if config == "local" else "")
              + f"); orbit drag {r['orbit_s']:.2f} s, {r['orbit_bytes']:,} B")
    lo, la, re = out["local"], out["local-array"], out["remote"]
    print(f"bytes per stroke, same run: deltas {lo['stroke_bytes']:,} B vs whole colour array "
          f"{la['stroke_bytes']:,} B ({la['stroke_bytes'] / max(lo['stroke_bytes'], 1):.0f}x less; proxy "
          f"{lo['proxy_vertices']:,} vertices = {4 * lo['proxy_vertices']:,} B of colours) vs remote images "
          f"{re['stroke_bytes']:,} B")
    print(f"choice: local (vtk.js + deltas) sends {lo['stroke_bytes']:,} B per stroke and {lo['orbit_bytes']:,} B "
          f"per orbit vs remote {re['stroke_bytes']:,} / {re['orbit_bytes']:,} B; first frame "
          f"{lo['first_frame_s']:.2f} s vs {re['first_frame_s']:.2f} s")
    return out


if __name__ == "__main__":
    main()
