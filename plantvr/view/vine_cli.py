"""``plantvr segment``: the command-line entry of the ViNE review page (issue 14).

:func:`main_segment` parses the options, opens the source and either serves
:class:`~plantvr.view.vine_app.VineReviewApp` or, with ``--out``, paints a scripted demo headless and writes
the results; :mod:`plantvr.cli` dispatches ``plantvr segment`` here.
"""
from __future__ import annotations

import sys

from plantvr._validation import check_int, check_range
from plantvr.io import labels as io_labels
from plantvr.vine.proxy import DisplayProxy

from .vine_app import VineReviewApp

__all__ = ["main_segment"]


def main_segment(argv: list[str] | None = None) -> int:
    """``plantvr segment VOLUME_OR_SYNTH [--level L] [--port P] [--faces F] [--lod F] [--out DIR]`` (issue 14).

    Builds the isosurface of a volume (or opens a mesh, or a synthetic head with ``synth`` / ``synth:N``), then
    either serves the browser review page (until interrupted) or, with ``--out``, paints a scripted demo
    headless and writes ``DIR/segment.ply`` (per-vertex colours and labels), ``DIR/segment_session.npz`` and a
    proxy screenshot ``DIR/segment.png``. Returns the process exit code.
    """
    import argparse

    from plantvr.documents.labels_app import paint_demo
    from plantvr.io.source import open_source
    ap = argparse.ArgumentParser(prog="plantvr segment", description=main_segment.__doc__.split("\n")[0])
    ap.add_argument("source", help="volume (.tif/.nrrd/.nii[.gz]/.mha/.mhd/.vti/.h5/.npy/.npz, a .zarr or "
                                   "DICOM folder), mesh file (.ply/.obj/...), or synth[:N]")
    ap.add_argument("--level", type=float, default=None, help="iso-value (default: Otsu / the synthetic one)")
    ap.add_argument("--downsample", action="store_true", help="2x block-mean downsampling before meshing")
    ap.add_argument("--port", type=int, default=None, help="port of the review page (default: a free one)")
    ap.add_argument("--faces", type=int, default=1_500_000, help="display-proxy triangle budget")
    ap.add_argument("--lod", type=int, default=20_000,
                    help="triangles drawn while a stroke or an orbit runs (0: draw the display proxy throughout)")
    ap.add_argument("--mode", choices=("local", "remote"), default="local",
                    help="local: the browser draws the proxy (vtk.js); remote: the server renders")
    ap.add_argument("--out", type=str, default=None, help="headless: paint a demo and write PLY/session/PNG here")
    ap.add_argument("--stamps", type=int, default=24, help="demo brush stamps with --out")
    a = ap.parse_args(argv)
    try:
        return _segment(a, open_source, paint_demo)
    except ValueError as exc:                       # one line on stderr and exit code 2, never a traceback
        print(f"plantvr segment: error: {exc}".replace("\n", " "), file=sys.stderr)
        return 2


def _check_segment_args(a) -> None:
    """Every option of ``plantvr segment`` checked before the source is opened or anything is written."""
    check_int("--faces", a.faces, 4, 2 ** 31 - 1)
    if a.lod != 0:
        check_int("--lod", a.lod, 4, 2 ** 31 - 1)
    check_int("--stamps", a.stamps, 1, 100_000)
    if a.port is not None:
        check_int("--port", a.port, 0, 65535)
    if a.level is not None:
        check_range("--level", a.level, -1e300, 1e300)
    if a.out is not None and not a.out.strip():
        raise ValueError("--out must be a folder path, got ''")


def _segment(a, open_source, paint_demo) -> int:
    _check_segment_args(a)
    src = open_source(a.source, level=a.level, downsample=a.downsample)
    seg = src.seg
    if src.description:
        print(src.description)
    print(f"surface: {seg.n_vertices:,} vertices, {len(seg.faces):,} faces"
          + (f" (iso-value {src.level:g})" if src.level is not None else ""))
    if a.out:
        from pathlib import Path

        from plantvr.types import LabelledSurface
        from plantvr.view import View
        out = Path(a.out)
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ValueError(f"--out {str(out)!r} cannot be created: {exc.strerror or exc}") from None
        n = paint_demo(seg, truth=src.truth, stamps=a.stamps)
        io_labels.export_ply(seg, out / "segment.ply")
        seg.save(out / "segment_session.npz", include_mesh=False)
        proxy = DisplayProxy(seg, target_faces=a.faces)
        view = View({"surface": LabelledSurface(proxy)}, off_screen=True, window_size=(800, 600),
                    background=(0.08, 0.08, 0.1))
        view.plotter.reset_camera()
        view.plotter.camera.elevation = -35
        view.screenshot(out / "segment.png")
        view.close()
        proxy.close()
        print(f"painted {n:,} vertices; wrote {out / 'segment.ply'}, {out / 'segment_session.npz'}, "
              f"{out / 'segment.png'}")
        return 0
    app = VineReviewApp(seg, target_faces=a.faces, mode=a.mode, volume=src.volume, level=src.level,
                        interactive_faces=a.lod or None)
    print(f"display proxy: {app.proxy.n_vertices:,} vertices, {len(app.proxy.faces):,} faces"
          + (f"; level of detail while painting: {len(app.lod.faces):,} faces" if app.lod is not None else ""))
    app.start(a.port, thread=False, open_browser=False)
    return 0
