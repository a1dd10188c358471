"""Stereo frame time of the headset renderer (spec 000_treewand §4.10, §8.2; 000_vine §4.5).

For trees of ~5,000 and ~22,000 internodes, renders both eyes offscreen at headset resolution
(2016 x 2240 per eye; ``--quick``: 504 x 560) with the two layouts of
:class:`plantvr.vr.render.StereoRenderer` ("side": one window, two renderers sharing GPU buffers; "pair":
one window per eye), beside a single-eye baseline (one window, one renderer) measured in the same run.
Then runs the whole headset bridge (:class:`plantvr.vr.Headset`) against the fake OpenVR runtime and prints its
frame-time histogram.

ViNE mode (spec 000_vine §4.5, §5.7): a synthetic flower head (``synth_flowerhead``) is tiled up toward the
gerbera class (36 M triangles; ``--vine-faces``), decimated to a :class:`plantvr.vine.proxy.DisplayProxy` of
~1.5 M triangles (``--proxy-faces``); the coloured, depth-cued proxy surface is timed beside a single-eye
baseline, and the segmentation document is drawn through :class:`plantvr.vr.Headset` (fake runtime; mesher
thread, depth cue, colour wheel) at headset resolution, as its ``scene()`` presents it.
Target in a headset: <= 11.1 ms per stereo frame (90 fps). On a CPU-only machine VTK renders with Mesa
llvmpipe, so absolute numbers are far from that; the ratios still show what stereo costs.

The 5k tree is grown by the model (seeded); growing 22k internodes takes minutes on 2 cores, so the
larger tree is a seeded synthetic branching tree (``--grow-all`` grows it).
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import numpy as np


def grown_tree(target: int, seed: int = 0, max_s: float = 120.0):
    """Grow a seeded tree with random strokes until it has ``target`` internodes (or ``max_s`` passes); returns
    its :class:`~plantvr.types.TreeArrays`."""
    from plantvr.documents.treewand import Model
    m = Model(seed=seed, base_length=0.2, occupation_radius=0.2, view_radius=0.8, darts_per_paint=400)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    while m.n_internodes < target and time.perf_counter() - t0 < max_s:
        m.paint_stroke(rng.uniform([-4, 0.5, -4], [4, 9, 4], (20, 3)), radius=2.0)
        m.step(2)
    return m.latest.tree


def synthetic_tree(n: int, seed: int = 0):
    """A seeded branching tree with exactly ``n`` internodes (main axis continues, laterals at 45°)."""
    from plantvr.types import TreeArrays
    rng = np.random.default_rng(seed)
    pos = np.zeros((n + 1, 3))
    parent = np.full(n + 1, -1, np.int64)
    order = np.zeros(n + 1, np.int64)
    head = np.zeros((n + 1, 3))
    head[0] = (0, 1, 0)
    tips, k = [0], 1
    while k <= n:
        new = []
        for t in tips:
            if k > n:
                break
            kids = [head[t]]
            if rng.random() < 0.35:
                side = np.cross(head[t], rng.normal(size=3))
                side /= np.linalg.norm(side) + 1e-12
                kids.append(np.cos(np.pi / 4) * head[t] + np.sin(np.pi / 4) * side)
            for j, d in enumerate(kids):
                if k > n:
                    break
                d = d + rng.normal(0, 0.08, 3) + (0, 0.03, 0)
                d /= np.linalg.norm(d)
                pos[k], parent[k], head[k] = pos[t] + 0.2 * d, t, d
                order[k] = order[t] + (j > 0)
                new.append(k)
                k += 1
        tips = new if rng.random() < 0.97 or len(new) < 8 else new[: len(new) // 2]
        if not tips:
            tips = [int(rng.integers(1, k))]
    size = np.ones(n + 1)
    for i in range(n, 0, -1):
        size[parent[i]] += size[i]
    radius = 0.01 * size ** (1 / 2.5)
    main_child = np.full(n + 1, -1, np.int64)
    first = np.flatnonzero(parent >= 0)[::-1]          # reversed: the lowest index (main) child wins
    main_child[parent[first]] = first
    return TreeArrays.from_arrays(pos, parent, radius, order, main_child)


def _eyes(frame: int):
    from plantvr.vr import fake_openvr as f
    from plantvr.vr.math3d import hmd34_to_array, hmd44_to_array
    system = f.IVRSystem()
    hmd = f.pose_matrix((0.0, 1.6, 0.6), yaw=0.05 * np.sin(frame / 7))
    eyes = [hmd @ hmd34_to_array(system.getEyeToHeadTransform(e)) for e in (0, 1)]
    proj = [hmd44_to_array(system.getProjectionMatrix(e, 0.05, 100.0)) for e in (0, 1)]
    return eyes, proj


def time_layout(frame: dict, width: int, height: int, layout: str, frames: int, scene_matrix, *,
                ground: bool = True) -> list[float]:
    """ms per frame of ``layout`` ("side", "pair", or "single": one eye, the baseline) drawing ``frame`` (a View's
    layers, :meth:`plantvr.view.View.snapshot`, as the headset's mesher thread hands them over)."""
    from plantvr.vr.render import StereoRenderer
    r = StereoRenderer(width, height, layout="side" if layout == "single" else layout)
    if layout == "single":   # one window of one eye with one renderer
        rw = r.windows[0]
        rw.RemoveRenderer(r.renderers[1])
        r.renderers = r.renderers[:1]
        r.renderers[0].SetViewport(0, 0, 1, 1)
        rw.SetSize(width, height)
    r.set_content(frame)
    r.set_ground(ground)
    r.set_model_matrix(scene_matrix)
    out = []
    for i in range(frames + 1):
        eyes, proj = _eyes(i)
        t0 = time.perf_counter()
        r.render(eyes, proj)
        if layout != "single":
            r.textures()
        ms = 1000 * (time.perf_counter() - t0)
        if i:                     # frame 0 compiles shaders and uploads buffers
            out.append(ms)
    r.close()
    return out


def bridge_run(tree, width: int, height: int, frames: int):
    """Frame times of the full headset bridge (fake runtime) showing ``tree``; returns the headset."""
    from plantvr.document import Document
    from plantvr.vr import Headset, fake_openvr

    class Shown(Document):
        """A document whose scene is the benchmark tree."""

        KIND = "benchmark_tree"

        def scene(self):
            return {"tree": tree}

    fake_openvr.install()
    fake_openvr.runtime.render_size = (width, height)
    b = Headset(Shown())
    b.controls.scene.scale, b.controls.scene.translation = 0.25, np.array([0.0, 0.0, -0.6])
    b.start(timeout=600)
    b.wait_content(timeout=600)  # the mesher thread has published the tree and a frame has drawn it
    b.wait_frames(1, timeout=600)
    b.frame_ms.clear()           # drop warm-up (shader compile, first upload)
    b.wait_frames(frames, timeout=600)
    b.stop()
    fake_openvr.uninstall()
    return b


def _rss_gib() -> float:
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20


#: Triangles of the gerbera-class mesh (18 M vertices / 36 M faces, 000_vine §5.7).
GERBERA_FACES = 36_000_000
#: Peak RSS per full-resolution triangle of mesh + DisplayProxy build (fast-simplification dominates), measured
#: here: 15.55 GiB at 36.26 M triangles (+ margin).
PEAK_BYTES_PER_FACE = 0.45 * 2 ** 30 / 1e6


def vine_segmentation(n_faces: int, head: int = 256, seed: int = 0):
    """A synthetic flower head (``head``³ voxels) tiled to at least ``n_faces`` triangles, with the
    ground-truth component labels of every vertex; returns ``(Segmentation, head_faces)``."""
    from plantvr.documents.labels import Segmentation
    from plantvr.vine.colors import ColorTable
    from plantvr.adapters.vtk_isosurface import extract_isosurface
    from plantvr.vine.synth import synth_flowerhead, tile_mesh, vertex_labels_from_volume
    fh = synth_flowerhead(head, rng=seed)
    s = extract_isosurface(fh.volume, fh.level)
    lab = vertex_labels_from_volume(s.vertices, fh.volume, fh.labels)
    del fh
    copies = max(1, int(np.ceil(n_faces / max(len(s.faces), 1))))
    v, f = tile_mesh(s.vertices, s.faces, copies * len(s.vertices))
    labels = np.tile(lab, len(v) // len(lab))
    n_colors = len(ColorTable())
    seg = Segmentation(v, f, labels=(labels % n_colors).astype(np.uint8))
    return seg, len(s.faces)


def vine_bridge_run(seg, width: int, height: int, frames: int, timeout: float = 900.0):
    """Frame times of the headset (fake runtime) drawing the segmentation document; returns the headset.

    Frames rendered before the mesher thread published the first coloured surface are not counted."""
    from plantvr.vr import attach, fake_openvr
    fake_openvr.install()
    fake_openvr.runtime.render_size = (width, height)
    b = attach(seg)
    t0 = time.perf_counter()
    b.start(timeout=timeout)
    while b.running and b._drawn_content is None and time.perf_counter() - t0 < timeout:
        time.sleep(0.01)
    b.wait_frames(1, timeout=timeout)        # the first frame with the surface uploads its buffers
    b.frame_ms.clear()
    b.wait_frames(frames, timeout=timeout)
    b.stop()
    fake_openvr.uninstall()
    return b


def vine_case(args, w: int, h: int, frames: int) -> dict:
    """ViNE mode: full mesh → DisplayProxy → stereo frames through the Headset (000_vine §4.5, §5.7)."""
    from plantvr.types import LabelledSurface
    from plantvr.view import View
    from plantvr.vine.proxy import DisplayProxy
    from plantvr.vr import Headset
    # full size: the gerbera class (36 M triangles) when the decimation's peak memory fits ``--mem-gib``
    n_faces = args.vine_faces or (150_000 if args.quick else
                                  int(min(GERBERA_FACES, args.mem_gib * 2 ** 30 / PEAK_BYTES_PER_FACE)))
    budget = args.proxy_faces or (40_000 if args.quick else 1_500_000)
    head = args.head or (64 if args.quick else 256)
    t0 = time.perf_counter()
    seg, head_faces = vine_segmentation(n_faces, head)
    t_make = time.perf_counter() - t0
    print(f"\nViNE: flower head {head}^3 ({head_faces:,} triangles) tiled to {len(seg.faces):,} triangles / "
          f"{seg.n_vertices:,} vertices in {t_make:.1f} s; peak RSS {_rss_gib():.2f} GiB")
    t0 = time.perf_counter()
    proxy = DisplayProxy(seg, target_faces=budget)
    t_proxy = time.perf_counter() - t0
    print(f"  DisplayProxy: {len(proxy.faces):,} triangles / {proxy.n_vertices:,} vertices in {t_proxy:.1f} s "
          f"({', '.join(f'{k} {v:.1f} s' for k, v in proxy.timings.items())}); peak RSS {_rss_gib():.2f} GiB")
    case = {"full_faces": len(seg.faces), "full_vertices": seg.n_vertices, "head": head,
            "proxy_faces": len(proxy.faces), "proxy_vertices": proxy.n_vertices, "make_s": t_make,
            "proxy_s": t_proxy, "peak_rss_gib": _rss_gib()}
    if not args.quick and not args.vine_faces and len(seg.faces) < GERBERA_FACES:
        print(f"  (36 M triangles need ~{GERBERA_FACES * PEAK_BYTES_PER_FACE / 2 ** 30:.0f} GiB peak, over "
              f"--mem-gib {args.mem_gib:g}: this is the largest mesh that fits; --vine-faces 36000000 runs it)")
    # the same coloured surface the mesher thread draws: the View's labelled-surface layer, depth-cued from the
    # benchmark's head position
    probe = Headset(seg)
    scene = probe.controls.scene.matrix
    eyes, _ = _eyes(0)
    eye_model = probe.controls.scene.to_model(0.5 * (eyes[0][:3, 3] + eyes[1][:3, 3]))
    t0 = time.perf_counter()
    mirror = View({"surface": LabelledSurface(proxy)}, off_screen=True, window_size=(16, 16), depth_cue=True)
    frame = mirror.snapshot(eye=eye_model)
    case["surface_ms"] = 1000 * (time.perf_counter() - t0)
    print(f"  coloured surface (the View's layer: colours, hidden triangles dropped, depth cue; mesher thread): "
          f"{case['surface_ms']:.0f} ms")
    single = time_layout(frame, w, h, "single", frames, scene, ground=False)
    side = time_layout(frame, w, h, "side", frames, scene, ground=False)
    mirror.close()
    case["single_ms"], case["side_ms"] = float(np.median(single)), float(np.median(side))
    one = case["single_ms"]
    print(f"  baseline single eye          {one:9.1f} ms   (x2 = {2 * one:.1f} ms)")
    print(f"  stereo side (renderer only)  {case['side_ms']:9.1f} ms   = {case['side_ms'] / one:.2f} x single eye")
    b = vine_bridge_run(seg, w, h, frames)
    st = b.stats()
    case["bridge"] = st
    ms = np.asarray(b.frame_ms, float)
    drawn = b.content[1]["surface"][0].n_cells if b.content else 0
    print(f"  Headset on the segmentation ({drawn:,} triangles drawn; fake runtime, layout side, {len(ms)} frames): median {st['median_ms']:.1f} ms, "
          f"p95 {st['p95_ms']:.1f} ms per stereo frame = {st['median_ms'] / one:.2f} x single eye; "
          f"target 11.1 ms (90 fps): {'met' if st['median_ms'] <= 11.1 else 'missed'}; status {st['status']}"
          + (f", errors {b.command_errors[:2]}" if b.command_errors else ""))
    print(b.histogram_text())
    proxy.close()
    return case


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="small eyes (504x560), trees of 500 and 5000, few frames (CI)")
    ap.add_argument("--eye", default=None, help="per-eye WxH (default 2016x2240; quick 504x560)")
    ap.add_argument("--trees", default=None, help="internode counts (default 5000,22000; quick 500,5000)")
    ap.add_argument("--frames", type=int, default=None, help="timed frames per case (default 5; quick 2)")
    ap.add_argument("--sides", type=int, default=6, help="branch cross-section sides at the tips (6 ~ LOD 6/32)")
    ap.add_argument("--grow-all", action="store_true",
                    help="grow every tree instead of synthesising the large one")
    ap.add_argument("--only", choices=("all", "trees", "vine"), default="all",
                    help="run the Tree Wand cases, the ViNE case, or both (default)")
    ap.add_argument("--vine-faces", type=int, default=None,
                    help="ViNE full-mesh triangles (default: 36M, the gerbera class, or the most whose proxy build "
                         "fits --mem-gib; quick 150k)")
    ap.add_argument("--mem-gib", type=float, default=10.0,
                    help="peak-memory budget that sizes the default ViNE mesh (36M triangles need ~16 GiB)")
    ap.add_argument("--proxy-faces", type=int, default=None,
                    help="ViNE DisplayProxy triangle budget (default 1.5M; quick 40k)")
    ap.add_argument("--head", type=int, default=None, help="flower-head volume size (default 256; quick 64)")
    args = ap.parse_args(argv)
    w, h = map(int, (args.eye or ("504x560" if args.quick else "2016x2240")).split("x"))
    sizes = [int(s) for s in (args.trees or ("500,5000" if args.quick else "5000,22000")).split(",")]
    frames = args.frames or (2 if args.quick else 5)

    from plantvr.types import Points
    from plantvr.view import View
    from plantvr.view.polydata import tube_polydata
    from plantvr.vr.gestures import SceneTransform
    scene = SceneTransform(scale=0.25, translation=(0.0, 0.0, -0.6)).matrix
    sides = (args.sides, max(args.sides, 12))                 # as the Headset asks its tree layers
    results: dict = {"eye": (w, h), "frames": frames, "cases": []}
    print(f"stereo frame time, {w}x{h} per eye, {frames} frames after warm-up, branch sides {sides}")
    print("note: the 11.1 ms (90 fps) target needs a GPU; this run renders on the CPU (EGL + Mesa llvmpipe) "
          "unless VTK found one")
    big = None
    for i, n in enumerate(sizes if args.only in ("all", "trees") else []):
        t0 = time.perf_counter()
        if i == 0 or args.grow_all:
            snap, how = grown_tree(n), "grown"
        else:
            snap, how = synthetic_tree(n), "synthetic"
        t_make = time.perf_counter() - t0
        View({"tree": synthetic_tree(50)}, off_screen=True, window_size=(16, 16), sides=sides).close()  # JIT first
        t0 = time.perf_counter()
        mirror = View({"tree": snap, "markers": Points(np.zeros((0, 3)))}, off_screen=True, window_size=(16, 16),
                      ground=False, sides=sides)            # the headset's View: never rendered
        frame = mirror.snapshot()
        t_layer = 1000 * (time.perf_counter() - t0)
        kids = np.flatnonzero(snap.parent >= 0)
        t0 = time.perf_counter()
        tube_polydata(snap, kids, snap.radius[kids], sides=args.sides, capping=False)
        t_tube = 1000 * (time.perf_counter() - t0)
        tris = frame["tree"][0].n_cells
        print(f"\ntree: {snap.n_internodes} internodes ({how} in {t_make:.1f} s), {tris} triangles; mesh build "
              f"(mesher thread, off the render thread): the View's tree layer (generalized cylinders, bark "
              f"coordinates) {t_layer:.0f} ms; baseline VTK tube filter (straight tubes, no joins or bark "
              f"coordinates: less work) {t_tube:.0f} ms")
        case = {"internodes": snap.n_internodes, "how": how, "triangles": tris, "layer_ms": t_layer,
                "tube_filter_ms": t_tube}
        single = time_layout(frame, w, h, "single", frames, scene)
        case["single_ms"] = float(np.median(single))
        one = case["single_ms"]
        print(f"  baseline single eye          {one:9.1f} ms   (x2 = {2 * one:.1f} ms)")
        for layout in ("side", "pair"):
            ms = time_layout(frame, w, h, layout, frames, scene)
            case[f"{layout}_ms"] = float(np.median(ms))
            print(f"  stereo {layout:5s}                 {case[f'{layout}_ms']:9.1f} ms   "
                  f"= {case[f'{layout}_ms'] / case['single_ms']:.2f} x single eye; "
                  f"target 11.1 ms (90 fps): {'met' if case[f'{layout}_ms'] <= 11.1 else 'missed'}")
        results["cases"].append(case)
        big = snap
        mirror.close()
    if big is not None:
        b = bridge_run(big, w, h, frames)
        st = b.stats()
        results["bridge"] = st
        print(f"\nfull bridge (fake runtime, {big.n_internodes} internodes, layout side): "
              f"median {st['median_ms']:.1f} ms, p95 {st['p95_ms']:.1f} ms per stereo frame; histogram:")
        print(b.histogram_text())
    if args.only in ("all", "vine"):
        results["vine"] = vine_case(args, w, h, frames)
    return results


if __name__ == "__main__":
    main()
