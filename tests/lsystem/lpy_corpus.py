"""Run the L-Py distribution's grammars through plantvr.lsystem (issue 33), by hand: the grammars are not
committed (their licence is unclear), so CI does not run this.

    git clone https://github.com/openalea/lpy && python tests/lsystem/lpy_corpus.py lpy/share lpy/test/lpytest

Each ``.lpy`` file is read trusted and seeded, derived to its derivation length and drawn with shapes, in a child
process of its own (60 s each, from the file's folder); it prints ``ok``, ``refused`` (an LSystemError with its
line: a construct PlantVR does not support), ``error`` (any other exception: a bug) or ``timeout`` per file, then
the counts.
"""
from __future__ import annotations

import collections
import multiprocessing as mp
import os
import queue
import sys
import traceback
import warnings
from pathlib import Path


def _one(path: str, q) -> None:
    warnings.simplefilter("ignore")
    os.chdir(Path(path).parent)
    from plantvr.lsystem import LSystem, LSystemError
    try:
        ls = LSystem.from_file(path, trusted=True, time_budget=20, seed=1, max_modules=2_000_000)
        s = ls.derive()
        ls.draw(s, shapes=True)
        q.put(("ok", f"{len(s)} modules"))
    except LSystemError as e:
        q.put(("refused", str(e)[:300]))
    except Exception as e:  # noqa: BLE001  reported, not raised: the point is to count them
        q.put(("error", f"{type(e).__name__}: {e}"[:300] + " @ " + traceback.format_exc().splitlines()[-3][:200]))


def main(roots: list[str]) -> int:
    ctx = mp.get_context("spawn")
    counts = collections.Counter()
    for root in map(Path, roots):
        for p in sorted(root.rglob("*.lpy")):
            q = ctx.Queue()
            proc = ctx.Process(target=_one, args=(str(p), q))
            proc.start()
            proc.join(60)
            if proc.is_alive():
                proc.kill()
                kind, why = "timeout", ""
            else:
                try:                         # (Queue.empty() may say empty before the child's put arrives)
                    kind, why = q.get(timeout=10)
                except queue.Empty:
                    kind, why = "error", f"child exited {proc.exitcode}"
            counts[kind] += 1
            print(kind, p, why[:200], flush=True)
    print(dict(counts))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
