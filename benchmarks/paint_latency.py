"""Paint latency in the live view (issue 31): from a mouse stroke in the browser to the first changed picture.

The live view of :meth:`plantvr.view.View.widget` (trame remote view, server rendered, as a JupyterLab workbench
shows it) is opened in headless Chromium with every non-loopback request refused; the documents are made and
their changes applied on a "kernel" thread running its own event loop (as ipykernel's shell does), the trame
server runs on its own thread. Two documents: the Tree Wand :class:`~plantvr.documents.treewand.Model`
(a :class:`~plantvr.view.interaction.BrushInteractor` paints markers) and a ViNE
:class:`~plantvr.documents.labels.Segmentation` (a :class:`~plantvr.view.interaction.LabelBrush` paints
labels). Each stroke is a press, a few moves and a release dispatched in the page; its latency runs from the
``pointerdown`` event's time stamp to the ``load`` of the first picture whose pixels differ from the previous
one (both on the page's ``performance.now()`` clock). Median and max over the strokes are printed beside the
100 ms target and beside the baseline measured in the same run, on the same page, strokes alternating: the
render path before issue 31, where trame sent the JPEG encoder's *previous* picture (the new one followed
0.5 s later or with the next frame; ``plantvr.view._render_lock.FRESH_PICTURES`` off) and the kernel rendered
before each push, whose capture renders again (``View.render_before_push``), a ViNE paint was drawn only once the
kernel thread applied its change (after the picture trame renders right after the mouse event: a second
render), and a stroke was drawn with the window's multisampling (``BrushInteractor.stroke_samples`` None).
The cheaper stroke handling on the server (the brush sphere moved rather than rebuilt, history items counting
their bytes once: a Tree Wand press + 3 drags + release 34 -> 6 ms) is in both paths. Pictures are rendered by Mesa on the CPU here; a shared
2-core machine makes the figures vary by tens of ms from run to run.

Run: ``python benchmarks/paint_latency.py [--quick] [--strokes N]`` (needs Debian's chromium, trame-pyvista).
"""
from __future__ import annotations

import argparse
import asyncio
import threading
import time
from pathlib import Path

import numpy as np

from plantvr._browser import CHROMIUM, launch_chromium

TARGET_MS = 100.0

#: The page's probe: the time stamp of each pointerdown and the latency to the next changed picture.
PROBE = """() => {
  const img = document.querySelector('img');
  const c = document.createElement('canvas');
  const ctx = c.getContext('2d', {willReadFrequently: true});
  const w = window;
  w.__lat = []; w.__t0 = null; w.__last = null; w.__frames = 0; w.__lastFrame = performance.now();
  const sig = () => {
    c.width = img.naturalWidth; c.height = img.naturalHeight; ctx.drawImage(img, 0, 0);
    const d = ctx.getImageData(0, 0, c.width, c.height).data;
    let h = 0;
    for (let i = 0; i < d.length; i += 4) h = (Math.imul(h, 31) + d[i] + 3 * d[i + 1] + 7 * d[i + 2]) | 0;
    return h + ':' + c.width + 'x' + c.height;
  };
  w.__last = sig();
  img.addEventListener('load', () => {
    const t = performance.now();
    w.__frames++; w.__lastFrame = t;
    const s = sig();
    if (s === w.__last) return;
    w.__last = s;
    if (w.__t0 !== null) { w.__lat.push(t - w.__t0); w.__t0 = null; }
  });
  document.addEventListener('pointerdown', (e) => { w.__t0 = e.timeStamp; }, true);
}"""


class Kernel:
    """A thread running an asyncio loop, standing for the kernel's: documents are made and changed on it."""

    def __init__(self):
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="kernel", daemon=True)
        self.thread.start()

    def call(self, fn):
        async def run():
            return fn()
        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(300)

    def stop(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


def _treewand(quick: bool):
    import plantvr
    from plantvr.view import View
    from plantvr.view.interaction import BrushInteractor

    m = plantvr.Model(seed=0)
    m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
    m.step(10 if quick else 25)
    view = View(m, window_size=(480, 400))
    brush = BrushInteractor(view, spacing=0.5)
    m.brush_radius = 0.4
    return m, view, brush


def _vine(quick: bool):
    from plantvr.adapters.vtk_isosurface import extract_isosurface
    from plantvr.documents.labels import Segmentation
    from plantvr.view import View
    from plantvr.view.interaction import LabelBrush
    from plantvr.vine.synth import synth_flowerhead

    head = synth_flowerhead(48 if quick else 64, rng=0)
    s = extract_isosurface(head.volume, head.level)
    seg = Segmentation(s.vertices.astype(np.float32), s.faces)
    view = View(seg, window_size=(480, 400))
    brush = LabelBrush(view, label=1)
    return seg, view, brush


KINDS = {"treewand": _treewand, "vine": _vine}
#: the render paths compared (:func:`_use`)
PATHS = {"baseline": "baseline: before issue 31", "ours": "ours: fresh picture, 1 render"}
#: what a stroke of the "ours" path draws with (the window's own multisampling is restored at the release)
STROKE_SAMPLES = 0


def _settle(page, quiet_ms: float = 350, timeout_s: float = 10) -> None:
    """Wait until no picture has arrived for ``quiet_ms``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if page.evaluate("() => performance.now() - window.__lastFrame") > quiet_ms:
            return
        time.sleep(0.05)


def _use(path: str) -> None:
    """Switch the live view's render path (read at every redraw and capture, so strokes can alternate)."""
    from plantvr.view import View, _render_lock
    from plantvr.view.interaction import BrushInteractor

    baseline = path == "baseline"
    View.render_before_push = baseline
    _render_lock.FRESH_PICTURES = not baseline
    BrushInteractor.stroke_samples = None if baseline else STROKE_SAMPLES


def measure(p, kernel: Kernel, kind: str, strokes: int, quick: bool, *, shot: Path | None) -> dict:
    """Latencies (ms) of ``strokes`` strokes of each path on one live view of ``kind``; the paths alternate
    stroke by stroke, so a load that changes during the run weighs on both alike."""
    doc, view, brush = kernel.call(lambda: KINDS[kind](quick))
    widget = kernel.call(lambda: (brush.attach(), view.widget(width=480, height=400))[1])
    browser = launch_chromium(p, timeout=30_000)
    lat: dict[str, list[float]] = {k: [] for k in PATHS}
    missed = dict.fromkeys(PATHS, 0)
    try:
        page = browser.new_page(viewport={"width": 520, "height": 440})
        page.set_default_timeout(30_000)
        page.route("**/*", lambda r: r.abort() if not r.request.url.startswith(("http://127.0.0.1", "ws://127.0.0.1"))
                   else r.continue_())
        page.goto(widget.src.replace("localhost", "127.0.0.1"), wait_until="domcontentloaded")
        img = page.locator("img").first
        img.wait_for(state="visible")
        page.wait_for_function("() => { const i = document.querySelector('img'); return i && i.naturalWidth > 0; }")
        time.sleep(1.0)
        page.evaluate(PROBE)
        box = img.bounding_box()
        rng = np.random.default_rng(0)
        for k in range(strokes * len(PATHS)):
            path = list(PATHS)[k % len(PATHS)]
            _use(path)
            if kind == "vine":
                brush.label = 1 + k % 3                          # a stroke paints over another colour
                fx, fy = rng.uniform(0.4, 0.6, 2)
            else:
                fx, fy = rng.uniform(0.3, 0.7), rng.uniform(0.15, 0.45)
            x0, y0 = box["x"] + fx * box["width"], box["y"] + fy * box["height"]
            page.mouse.move(x0, y0)
            _settle(page)
            n0 = len(page.evaluate("() => window.__lat"))
            page.mouse.down()
            for j in range(1, 6):
                page.mouse.move(x0 + 4 * j, y0 + 3 * j)
                time.sleep(0.02)
            page.mouse.up()
            try:
                page.wait_for_function("() => window.__t0 === null", timeout=5_000)
            except Exception:                                  # no changed picture within 5 s
                page.evaluate("() => { window.__t0 = null; }")
            got = page.evaluate("() => window.__lat")
            if len(got) > n0:
                lat[path].append(float(got[-1]))
            else:
                missed[path] += 1
            _settle(page)
        if shot is not None:
            page.screenshot(path=str(shot))
        frames = page.evaluate("() => window.__frames")
        page.goto("about:blank")
        time.sleep(0.3)
    finally:
        browser.close()
        _use("ours")
        kernel.call(lambda: (brush.close(), view.close()))
    return {"lat": {k: np.array(v) for k, v in lat.items()}, "missed": missed, "frames": frames,
            "version": int(doc.version)}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="6 strokes, small documents (CI)")
    ap.add_argument("--strokes", type=int, default=None, help="strokes per document and path (default 20)")
    ap.add_argument("--shots", type=Path, default=None, help="folder for a screenshot of each page")
    a = ap.parse_args(argv)
    if not Path(CHROMIUM).exists():
        print("chromium not installed: skipped")
        return {}
    try:
        import trame_pyvista  # noqa: F401
        from playwright.sync_api import sync_playwright
    except ImportError as exc:
        print(f"paint latency needs playwright and trame-pyvista ({exc}): skipped")
        return {}
    strokes = a.strokes or (6 if a.quick else 20)
    kernel = Kernel()
    out: dict = {}
    print(f"paint latency in the live view: pointerdown -> first changed picture in the page, {strokes} strokes; "
          f"target <= {TARGET_MS:.0f} ms")
    print(f"  {'document':>9} {'path':>30} {'median ms':>10} {'target ms':>10} {'max ms':>8} {'missed':>7}")
    try:
        with sync_playwright() as p:
            for kind in KINDS:
                shot = None if a.shots is None else a.shots / f"paint_latency_{kind}.png"
                r = measure(p, kernel, kind, strokes, a.quick, shot=shot)
                for key, name in PATHS.items():
                    lat = r["lat"][key]
                    med, mx = (float(np.median(lat)), float(lat.max())) if len(lat) else (float("nan"),) * 2
                    out[f"{kind}_{key}"] = {"median_ms": med, "max_ms": mx, "strokes": len(lat),
                                            "missed": r["missed"][key]}
                    print(f"  {kind:>9} {name:>30} {med:>10.1f} {'<= ' + format(TARGET_MS, '.0f'):>10} {mx:>8.1f} "
                          f"{r['missed'][key]:>7}")
                print(f"  {kind:>9} {r['frames']} pictures received, document version {r['version']}")
    finally:
        kernel.stop()
    for kind in KINDS:
        o, b = out[f"{kind}_ours"], out[f"{kind}_baseline"]
        ok = "meets" if o["max_ms"] <= TARGET_MS else ("median meets" if o["median_ms"] <= TARGET_MS else "misses")
        print(f"{kind}: median {o['median_ms']:.1f} ms (target <= {TARGET_MS:.0f} ms), max {o['max_ms']:.1f} ms ({ok} "
              f"the target; baseline median {b['median_ms']:.1f}, max {b['max_ms']:.1f})")
    return out


if __name__ == "__main__":
    main()
