"""Soak test of the live notebook (issue 31): 200 mixed paints, regrows and undos on a live Tree Wand workbench.

The workbench is made on a "kernel" thread running its own event loop (as ipykernel's shell does), its trame
page opened in headless Chromium with the network refused. Paint strokes are dragged in the page (the trame
server's thread paints), regrows (a *Tree form* slider moved) and undos run on the kernel thread, in a seeded
random order and without waiting for the pictures between them. Afterwards VTK must have reported no error
(no OpenGL error from two threads drawing one window), the kernel and the server must answer, and the live
picture must show the tree. 200 operations take ~50 s on two shared cores; ``pytest --soak`` runs 1000.
"""
from __future__ import annotations

import asyncio
import io
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM, launch_chromium

from ._jupyter import screenshot_dir

pytestmark = [pytest.mark.browser, pytest.mark.soak,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_pyvista")

OPS, LONG_OPS = 200, 1000


class Kernel:
    """A thread running an asyncio loop, standing for the kernel's."""

    def __init__(self):
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="kernel", daemon=True)
        self.thread.start()

    def call(self, fn, timeout: float = 120):
        async def run():
            return fn()
        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(timeout)

    def stop(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


def _content_fraction(img: np.ndarray) -> float:
    """Share of pixels unlike their row's median (the background is a vertical gradient)."""
    rgb = img[..., :3].astype(np.int16)
    return float((np.abs(rgb - np.median(rgb, axis=1, keepdims=True)).max(axis=-1) > 24).mean())


def test_live_workbench_survives_200_mixed_paints_regrows_and_undos(tmp_path, capfd, request):
    import vtk
    from PIL import Image

    import plantvr
    from plantvr.ui import workbench

    out = vtk.vtkStringOutputWindow()
    old = vtk.vtkOutputWindow.GetInstance()
    vtk.vtkOutputWindow.SetInstance(out)
    shots = screenshot_dir(tmp_path)
    kernel = Kernel()

    def build():
        m = plantvr.Model(seed=0)
        m.paint_stroke([[0, y, 0] for y in range(2, 8)], radius=2.0)
        m.step(8)
        m.brush_radius = 0.4
        return m, workbench(m, live=True, window_size=(420, 340))

    m, wb = kernel.call(build, 240)
    slider = wb.panels.controls["max_len_mult"]
    lo, hi = float(slider.min), float(slider.max)
    rng = np.random.default_rng(31)
    counts = {"paint": 0, "regrow": 0, "undo": 0, "step": 0}
    try:
        with playwright_api.sync_playwright() as p:
            browser = launch_chromium(p, timeout=30_000)
            try:
                page = browser.new_page(viewport={"width": 460, "height": 380})
                page.set_default_timeout(30_000)
                errors: list[str] = []
                page.on("pageerror", lambda e: errors.append(f"{e.name}: {e.message}"))
                page.route("**/*", lambda r: r.abort() if not r.request.url.startswith(
                    ("http://127.0.0.1", "ws://127.0.0.1")) else r.continue_())
                page.goto(wb.screen.src.replace("localhost", "127.0.0.1"), wait_until="domcontentloaded")
                img = page.locator("img").first
                img.wait_for(state="visible")
                time.sleep(1.0)
                box = img.bounding_box()
                for _ in range(LONG_OPS if request.config.getoption("--soak") else OPS):
                    op = rng.choice(["paint", "regrow", "undo", "step"], p=[0.6, 0.15, 0.2, 0.05])
                    counts[op] += 1
                    if op == "paint":
                        x0 = box["x"] + rng.uniform(0.3, 0.7) * box["width"]
                        y0 = box["y"] + rng.uniform(0.15, 0.5) * box["height"]
                        page.mouse.move(x0, y0)
                        page.mouse.down()
                        for j in range(1, 4):
                            page.mouse.move(x0 + 5 * j, y0 + 4 * j)
                        page.mouse.up()
                    elif op == "regrow":
                        value = round(float(rng.uniform(lo, min(hi, lo + 0.5 * (hi - lo)))), 2)
                        kernel.call(lambda v=value: setattr(slider, "value", v))
                    elif op == "undo":
                        kernel.call(lambda: m.undo() if m.history.can_undo else None)
                    else:
                        kernel.call(lambda: m.step(1))
                    time.sleep(float(rng.uniform(0.0, 0.02)))
                time.sleep(1.5)                                       # the last pictures arrive
                assert kernel.call(lambda: int(m.version), 60) > 0    # the kernel answers
                n_paint = kernel.call(lambda: sum(e.command == "paint_stroke" for e in m.log.events))
                # the server answers: a last stroke still changes the picture
                before = np.asarray(Image.open(io.BytesIO(img.screenshot())).convert("RGB")).astype(int)
                x0, y0 = box["x"] + 0.5 * box["width"], box["y"] + 0.3 * box["height"]
                page.mouse.move(x0, y0)
                page.mouse.down()
                page.mouse.move(x0 + 20, y0 + 10)
                page.mouse.up()
                deadline, moved = time.monotonic() + 20, 0.0
                while time.monotonic() < deadline and moved <= 0.0005:
                    time.sleep(0.3)
                    after = np.asarray(Image.open(io.BytesIO(img.screenshot())).convert("RGB"))
                    moved = float((np.abs(after.astype(int) - before).max(axis=-1) > 30).mean())
                Image.fromarray(after).save(shots / "soak_live_treewand.png")
                page.goto("about:blank")
                time.sleep(0.3)
            finally:
                browser.close()
        assert moved > 0.0005, "the live picture did not change after the soak's last stroke"
        frac = _content_fraction(after)
        assert frac > 0.01, f"the live picture is blank after the soak ({frac:.4f} of pixels drawn)"
        assert n_paint >= counts["paint"] // 2, (n_paint, counts)
        assert not errors, errors
    finally:
        kernel.call(wb.close)
        kernel.stop()
        vtk.vtkOutputWindow.SetInstance(old)
    err = capfd.readouterr()
    bad = [ln for ln in (err.out + err.err).splitlines() if "ERR|" in ln or "vtkOpenGL" in ln or "GL_" in ln]
    assert not out.GetOutput().strip() and not bad, (out.GetOutput() + "\n".join(bad))[-3000:]
