"""The live workbench works with the network off, and its sliders redraw the browser's picture (issue 31).

``plantvr.ui.workbench(doc, live=True)`` for every document kind is started with name resolution blocked for
every host but this machine (what an offline laptop or CI container sees), its trame page is opened in headless
Chromium with every non-loopback request refused, and each view's picture must arrive and show the document;
nothing may try to download (``trame-vtklocal``'s VTK.wasm fetch), and no traceback may be printed. Then one
slider of each generated panel is moved on the server's event loop (as a comm message is handled in a kernel):
the document changes (and regrows where it grows) and the picture in the browser changes.
Screenshots go to ``$PLANTVR_SCREENSHOTS`` (default: the test's tmp dir).
"""
from __future__ import annotations

import asyncio
import io
import socket
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from plantvr._browser import CHROMIUM, launch_chromium

from ._jupyter import screenshot_dir

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "view"))
from test_every_document import KINDS  # noqa: E402

pytestmark = [pytest.mark.browser,
              pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="Debian chromium not installed")]
playwright_api = pytest.importorskip("playwright.sync_api")
pytest.importorskip("trame_pyvista")

LOOPBACK = ("localhost", "127.0.0.1", "::1", "0.0.0.0", "")


@pytest.fixture
def offline(monkeypatch):
    """Name resolution and TCP connections fail for every host but loopback; the refused hosts are recorded."""
    refused: list[str] = []
    real_getaddrinfo, real_create = socket.getaddrinfo, socket.create_connection

    def getaddrinfo(host, *args, **kwargs):
        h = host.decode() if isinstance(host, bytes) else str(host or "")
        if h not in LOOPBACK and not h.startswith("127."):
            refused.append(h)
            raise socket.gaierror(socket.EAI_NONAME, "Name or service not known (network blocked by the test)")
        return real_getaddrinfo(host, *args, **kwargs)

    def create_connection(address, *args, **kwargs):
        getaddrinfo(address[0], address[1])
        return real_create(address, *args, **kwargs)

    monkeypatch.setattr(socket, "getaddrinfo", getaddrinfo)
    monkeypatch.setattr(socket, "create_connection", create_connection)
    return refused


#: kind -> (slider of the generated panel, value it is moved to)
SLIDE = {"treewand": ("max_len_mult", 5.0), "treesketch": ("main_branch_angle", 40.0), "forest": ("width", 40.0),
         "inflorescence": ("time", 0.3)}


def _on_server_loop(fn) -> None:
    """Run ``fn`` on the trame server's event loop and let the callbacks it schedules run (a kernel's turn)."""
    from trame_pyvista.jupyter import _server_loop

    async def turn():
        fn()
        for _ in range(10):
            await asyncio.sleep(0.05)

    asyncio.run_coroutine_threadsafe(turn(), _server_loop()).result(180)


def _picture(img) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(img.screenshot())).convert("RGB"))


def _content_fraction(img: np.ndarray) -> float:
    """Share of pixels unlike their row's median (the background is a vertical gradient)."""
    rgb = img[..., :3].astype(np.int16)
    bg = np.median(rgb, axis=1, keepdims=True)
    return float((np.abs(rgb - bg).max(axis=-1) > 24).mean())


def test_live_workbench_of_every_kind_renders_with_the_network_off(offline, tmp_path, capfd):
    from PIL import Image

    from plantvr.ui import workbench

    shots = screenshot_dir(tmp_path)
    made: dict[str, object] = {}

    def build():  # off the main thread: the trame server gets its own running event loop (as in a kernel)
        for kind, make in sorted(KINDS.items()):
            doc, _edit = make(tmp_path) if kind == "crown" else make()
            made[kind] = workbench(doc, live=True, window_size=(360, 280))

    t = threading.Thread(target=build)
    t.start()
    t.join(240)
    assert set(made) == set(KINDS), f"workbenches built: {sorted(made)}"
    try:
        from trame_vtklocal.module import wasm
        assert not wasm.WASM_DOWNLOADING, "a VTK.wasm download was started"
    except ImportError:
        pass
    external: list[str] = []
    with playwright_api.sync_playwright() as p:
        browser = launch_chromium(p, timeout=30_000)
        try:
            errors: dict[str, list[str]] = {}
            for kind, wb in sorted(made.items()):
                page = browser.new_page(viewport={"width": 400, "height": 320})
                page.route("**/*", lambda r: (external.append(r.request.url), r.abort())
                           if not r.request.url.startswith(("http://127.0.0.1", "ws://127.0.0.1"))
                           else r.continue_())
                page.on("pageerror", lambda e, k=kind: errors.setdefault(k, []).append(f"{e.name}: {e.message}"))
                page.goto(wb.screen.src.replace("localhost", "127.0.0.1"), wait_until="domcontentloaded")
                img = page.locator("img").first
                img.wait_for(state="visible", timeout=30_000)
                deadline, frac = time.monotonic() + 20, 0.0
                while time.monotonic() < deadline:          # the first picture replaces an empty image
                    pic = _picture(img)
                    frac = _content_fraction(pic)
                    if frac > 0.003:
                        break
                    time.sleep(0.3)
                Image.fromarray(pic).save(shots / f"live_offline_{kind}.png")
                assert frac > 0.003, f"{kind}: the live picture is blank ({frac:.4f} of pixels drawn)"
                if kind in SLIDE:
                    name, value = SLIDE[kind]
                    before, regrows = wb.doc.state_bytes(), wb.regrows
                    time.sleep(0.5)                         # the first picture is settled
                    pic = _picture(img)
                    controls = (wb.panels or wb.editor).controls    # the floret editor is the floret's panel
                    _on_server_loop(lambda: setattr(controls[name], "value", value))
                    assert getattr(wb.doc, name) == pytest.approx(value) and wb.doc.state_bytes() != before
                    assert kind == "inflorescence" or wb.regrows == regrows + 1, f"{kind}: no regrow"
                    deadline, moved = time.monotonic() + 20, 0.0
                    while time.monotonic() < deadline:
                        after = _picture(img)
                        moved = float((np.abs(after.astype(int) - pic).max(axis=-1) > 8).mean())
                        if moved > 0.005:
                            break
                        time.sleep(0.3)
                    Image.fromarray(after).save(shots / f"live_offline_{kind}_{name}.png")
                    assert moved > 0.005, f"{kind}: moving {name} did not change the browser's picture"
                time.sleep(0.5)
                page.close()
            assert not errors, errors
        finally:
            browser.close()
            for wb in made.values():
                wb.close()
    assert not external, f"the page asked the internet for {external}"
    assert not offline, f"the kernel side tried to reach {sorted(set(offline))}"
    err = capfd.readouterr()
    text = err.out + err.err
    for bad in ("Traceback", "ClientConnector", "Downloaded WASM", "gitlab.kitware.com"):
        assert bad not in text, f"{bad!r} printed:\n{text[-3000:]}"
