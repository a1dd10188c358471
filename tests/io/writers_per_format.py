"""Count the functions of plantvr that write each mesh format's bytes to disk, at a git revision (issue 30).

    python tests/io/writers_per_format.py [REV]      # default: the work tree

A function counts as a writer of a format when it puts bytes on disk (``atomic_write``, ``write_atomic``,
``write_png``, ``open(..., "w")``, a resolver's ``open``/``write``, or trimesh's exporters) and its own source
produces that format (PLY header, OBJ records, glTF container/buffer, a USD stage; trimesh's exporter writes
OBJ and glTF). The writer registry and its resolver (``plantvr/io/writers.py``, ``plantvr/io/parts.py``) write no format.
"""
from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WRITES = re.compile(r"(?<![\w.])(atomic_write|write_atomic|write_png)\(|\bres\.(open|write|write_png)\(|"
                    r"trimesh\.exchange|(?<![\w.])open\([^)]*[\"'][wa]b?[\"']")
FORMATS = {"ply": r"end_header", "obj": r"mtllib|[\"']v %|trimesh\.exchange", "gltf/glb": r"\.glb\(\)|blob\(\)|"
           r"trimesh\.exchange", "usd": r"_write_stage\(|Usd\.Stage"}


def sources(rev: str | None) -> dict[str, str]:
    if rev is None:
        return {p.relative_to(ROOT).as_posix(): p.read_text() for p in (ROOT / "plantvr").rglob("*.py")}
    names = subprocess.run(["git", "-C", str(ROOT), "ls-tree", "-r", "--name-only", rev, "plantvr"],
                           capture_output=True, text=True, check=True).stdout.split()
    return {n: subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:{n}"], capture_output=True, text=True,
                              check=True).stdout for n in names if n.endswith(".py")}


def writers(rev: str | None = None) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {f: [] for f in FORMATS}
    for path, text in sorted(sources(rev).items()):
        if path in ("plantvr/io/writers.py", "plantvr/io/parts.py"):
            continue
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                src = ast.get_source_segment(text, node) or ""
                if WRITES.search(src):
                    for fmt, pat in FORMATS.items():
                        if re.search(pat, src):
                            out[fmt].append(f"{path}:{node.name}")
    return out


if __name__ == "__main__":
    rev = sys.argv[1] if len(sys.argv) > 1 else None
    w = writers(rev)
    for fmt, fns in w.items():
        print(f"{fmt:9s} {len(fns)}  {' '.join(fns)}")
    print(f"total     {sum(len(v) for v in w.values())}")
