"""The trame server of live views, started without anything that downloads at run time (issue 31: offline).
"""
from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterator

import pyvista as pv

from ._render_lock import lock_trame_image_delivery

__all__ = ["launch_live_server"]


@contextlib.contextmanager
def _without_vtklocal() -> Iterator[None]:
    """Make ``from trame.widgets import vtklocal`` raise ImportError inside the block (Python's import rule:
    a ``None`` entry in ``sys.modules`` is a module that cannot be imported)."""
    import trame.widgets  # noqa: PLC0415

    name, missing = "trame.widgets.vtklocal", object()
    saved_mod = sys.modules.get(name, missing)
    saved_attr = trame.widgets.__dict__.pop("vtklocal", missing)
    sys.modules[name] = None
    try:
        yield
    finally:
        if saved_mod is missing:
            sys.modules.pop(name, None)
        else:
            sys.modules[name] = saved_mod
        if saved_attr is not missing:
            trame.widgets.vtklocal = saved_attr


def launch_live_server():
    """Start (once) the trame server that serves live views, without anything that downloads at run time.

    ``trame_pyvista``'s launcher enables ``trame-vtklocal`` when it is installed, and that module fetches the
    VTK.wasm bundle from gitlab.kitware.com on first use (neither the ``vtk`` nor the ``trame-vtklocal`` wheel
    ships it): offline, a ``ClientConnectorDNSError`` traceback lands in the cell. Live views are server
    rendered (``mode="server"``: trame-vtk's remote view, whose client ships in the ``trame-vtk`` wheel), so
    the server is launched as if ``trame-vtklocal`` were absent. Returns the running server.
    """
    from trame_pyvista.jupyter import elegantly_launch  # noqa: PLC0415
    from trame_pyvista.widgets import get_server  # noqa: PLC0415

    lock_trame_image_delivery()
    server = get_server(name=pv.global_theme.trame.jupyter_server_name)
    if not server.running:
        with _without_vtklocal():
            elegantly_launch(server, wslink_backend="aiohttp")
    return server
