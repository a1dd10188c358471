"""Cold start (issue 24): every kernel a feature calls compiles once, for one signature, whatever dtypes and
layouts the caller passes (the doors normalise them), and ``plantvr warmup`` leaves nothing to compile.

Both checks run in fresh subprocesses: signatures accumulate per process, and other tests call kernels directly.
"""
import json
import os
import subprocess
import sys
import textwrap

import pytest

from plantvr._warmup import FEATURE_NAMES, warmup

#: Kernels called only from other kernels, legitimately typed once per calling kernel's argument types.
INNER = {"plantvr.grid.axis_range", "plantvr.geometry._kernels._eval_one"}

_MIXED = textwrap.dedent("""
    import json, sys
    import numpy as np
    from numba.core.registry import CPUDispatcher
    from plantvr.subdivision.loop import subdivide_loop
    from plantvr.geometry.mesh import build_branch_mesh
    from plantvr.geometry.synthetic import random_tree
    from plantvr.documents.labels import Segmentation
    from plantvr.vine.synth import synth_flowerhead

    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    for vd in (np.float32, np.float64):
        for fd in (np.int32, np.int64, np.uint32):
            subdivide_loop(v.astype(vd), f.astype(fd), 1)
            subdivide_loop(np.asfortranarray(v.astype(vd)), np.asfortranarray(f.astype(fd)), 1)
    pos, parent, radius, mc = random_tree(40, seed=0)
    for pd in (np.float32, np.float64):
        for idd in (np.int32, np.int64):
            build_branch_mesh(pos.astype(pd), parent.astype(idd), radius.astype(pd), main_child=mc.astype(idd))
    head = synth_flowerhead(24, rng=0)
    base = Segmentation.from_volume(head.volume, head.level)
    for vol in (head.volume.astype(np.uint16), head.volume.astype(np.float32)):
        Segmentation.from_volume(vol, float(head.level))
    for vd in (np.float32, np.float64):
        for fd in (np.int32, np.int64, np.uint32):
            seg = Segmentation(base.vertices.astype(vd), base.faces.astype(fd))
            c = base.vertices[len(base.vertices) // 2]
            seg.paint(c.astype(np.float32), 2.0, 1)
            seg.paint(c.astype(np.float64), 2, 2)
            seg.paint([float(x) for x in c], np.float32(2.0), 3)
    out = {}
    for name, mod in list(sys.modules.items()):
        if name.startswith("plantvr") and mod is not None:
            for attr, obj in list(vars(mod).items()):
                if isinstance(obj, CPUDispatcher) and obj.__module__ == name and obj.signatures:
                    out[name + "." + attr] = [str(s) for s in obj.signatures]
    print(json.dumps(out))
""")


def _run(code: str, env: dict | None = None) -> dict:
    res = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=900,
                         env={**os.environ, **(env or {})})
    assert res.returncode == 0, res.stderr[-3000:]
    return json.loads(res.stdout.strip().splitlines()[-1])


def test_one_signature_per_kernel_with_mixed_dtypes():
    sigs = _run(_MIXED)
    assert "plantvr.subdivision.loop._edge_table_numba" in sigs and "plantvr.vine.index._grid_paint" in sigs
    multi = {k: v for k, v in sigs.items() if len(v) > 1 and k not in INNER}
    assert not multi, f"kernels compiled for several signatures (normalise dtypes at the door): {multi}"


_AFTER_WARMUP = textwrap.dedent("""
    import json, time
    from numba.core import event
    from plantvr._warmup import run_feature

    class Compiles(event.Listener):
        def __init__(self):
            self.names = []
        def on_start(self, ev):
            d = ev.data["dispatcher"]
            self.names.append(d.py_func.__module__ + "." + d.py_func.__name__)
        def on_end(self, ev):
            pass

    c = Compiles()
    event.register("numba:compile", c)
    for name in {features!r}:
        run_feature(name)
    print(json.dumps(sorted(set(n for n in c.names if n.startswith("plantvr")))))
""")


def test_warmup_leaves_nothing_to_compile(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path)}
    features = ["loop", "paint"]
    res = subprocess.run([sys.executable, "-m", "plantvr._warmup", "--jobs", "2", "--features", *features],
                         check=False, capture_output=True, text=True, timeout=900, env={**os.environ, **env})
    assert res.returncode == 0, res.stderr[-3000:]
    assert "numba kernels cached" in res.stdout
    assert any(tmp_path.iterdir())                           # the cache landed where NUMBA_CACHE_DIR says
    compiled = _run(_AFTER_WARMUP.format(features=features), env)
    assert compiled == [], f"compiled again after plantvr warmup: {compiled}"


def test_warmup_door():
    with pytest.raises(ValueError, match="features"):
        warmup(["nope"], verbose=False)
    with pytest.raises(ValueError, match="jobs"):
        warmup(["loop"], jobs=0, verbose=False)
    assert {"loop", "tree_mesh", "colonize", "isosurface", "paint", "demo_step", "demo"} <= set(FEATURE_NAMES)
