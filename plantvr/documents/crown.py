"""The implicit-crown document: the state the thesis command language builds (spec 003_implicit_sca §5.1-§5.2,
§2.9; C-13; issue 21).

Named surfaces (BlobTrees), meshes, one composite tagged point set and grown trees, changed by scripts in the
command language (:mod:`plantvr.implicit.commands` parses them). :meth:`CrownDocument.run` is the one command:
a script is parsed completely before anything runs, and it runs on the state that is restored if any line
fails, so a rejected script leaves the document unchanged; the files its ``save_point_set`` lines write are
written (atomically) only then, too. Each run is logged (``run(text=...)``) in the document's
:class:`~plantvr.commandlog.CommandLog`, which is the session record: replaying it into a fresh document with the
same ``seed`` reproduces the session, bit for bit. Each run is one undo step (a whole-state atom).
Thesis scripts on disk are input to :meth:`CrownDocument.run_file`.
"""
from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from .._fileio import read_text
from .._validation import MAX_COORD, check_int, check_range
from ..document import Document
from ..history import StateAtom
from ..implicit import blobtree as bt
from ..implicit.band import FieldCache, sample_band
from ..implicit.commands import COMMANDS as LANGUAGE
from ..implicit.commands import DISTRIBUTIONS, MAX_MESH_ELEMENTS, Command, CommandError, parse_script
from ..implicit.crown import default_roots, grow_in_crown, pipe_radii
from ..implicit.fields import ISO
from ..implicit.mesh_sampling import sample_mesh_near
from ..implicit.pointsets import (
    PROPS_DEFAULTS,
    PointSet,
    densify,
    load_point_set,
    read_props,
    save_point_set,
)
from ..implicit.polygonize import polygonize
from ..implicit.sampling import cluster_kernel, lane_in_node, poisson_kernel, sample_inside
from ..implicit.skinning import Circle2D, Revolution, Skin, SkinPath
from ..implicit.warps import Warp
from ..types import Points, TreeArrays, TriMesh

__all__ = ["TAG_COLORS", "CrownDocument"]

#: Colours of the point-set source tags (cycled), as #rrggbb.
TAG_COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2")


def _pickle_by_value(x: Any) -> bytes:
    """Pickle without the memo, so the bytes depend on the values only, not on which equal objects are one object
    (a script's text shared by two lines, or the same text read back from a log file)."""
    buf = io.BytesIO()
    p = pickle.Pickler(buf, protocol=4)
    p.fast = True
    p.dump(x)
    return buf.getvalue()


class CrownDocument(Document):
    """Named surfaces, meshes, one composite tagged point set and grown trees, driven by text commands.

    Parameters
    ----------
    base_dir : str or Path
        Directory for relative file names (props, point files, meshes).
    seed : int
        Session seed; the k-th generator call uses ``default_rng([seed, k])`` unless its props give a seed.
    default_radius : float
        R of ``sphere``/``line``/``torus`` when not given (surface at R/2).
    max_undo, max_undo_bytes : int
        Undo depth and byte budget.

    Attributes
    ----------
    surfaces : dict
        ``{name: BlobTree node}``.
    meshes : dict
        ``{name: (vertices, faces)}`` loaded by ``load_mesh``.
    points : PointSet
        The composite tagged point set.
    trees : list
        Colonization results (``nodes``, ``parent``) of the ``grow`` lines.
    lines : list of str
        The command lines that built the current state (undone with it).

    References
    ----------
    .. [1] Kochhar 2010, §4.1, §7.0.1, §7.1; spec 003 §5.1-5.2.
    """

    KIND = "crown"
    COMMANDS = ("run", "undo", "redo")
    EVENTS = ("crown",)

    def __init__(self, *, base_dir=".", seed: int = 0, default_radius: float = 1.0, max_undo: int = 20,
                 max_undo_bytes: int = 512 * 2 ** 20):
        try:
            base_dir = Path(base_dir)
        except TypeError:
            raise ValueError(f"base_dir must be a path, got {type(base_dir).__name__}") from None
        seed = check_int("seed", seed, 0, 2**63 - 1)
        default_radius = check_range("default_radius", default_radius, bt.MIN_RADIUS, MAX_COORD)
        super().__init__(max_undo=max_undo, max_undo_bytes=max_undo_bytes)
        self.base_dir, self.seed, self.default_radius = base_dir, seed, default_radius
        self.surfaces: dict = {}
        self.meshes: dict = {}
        self.points = PointSet()
        self.trees: list = []
        self.lines: list[str] = []
        self._gen_count = 0
        self._to_write: dict = {}                    # path -> PointSet written when the running script commits

    # ------------------------------------------------------------------ commands
    def _check_run(self, text: str) -> list[Command]:
        return parse_script(text)

    def run(self, text: str) -> CrownDocument:
        """Parse and run a script as one command (logged, one undo step); on any error the document is left
        unchanged and ``CommandError`` is raised."""
        commands = self._check_run(text)
        with self._lock:
            before = self.get_state()
            self._to_write = {}
            try:
                for c in commands:
                    try:
                        getattr(self, f"_cmd_{c.name}")(c)
                    except CommandError:
                        raise
                    except (ValueError, OverflowError, ZeroDivisionError) as exc:
                        raise CommandError(c.lineno, c.name, str(exc), c.text) from exc
                    self.lines.append(c.text.strip())
                for path, (points, header) in self._to_write.items():   # every line ran: write the saved files
                    try:
                        save_point_set(path, points, header=header)
                    except (OSError, ValueError) as exc:
                        raise ValueError(f"save_point_set: cannot write {str(path)!r}: {exc}") from None
            except BaseException:
                self.set_state(before)
                raise
            finally:
                self._to_write = {}
            if not commands:
                return self
            self.history.push(StateAtom(before, self.get_state(), "crown"))
            self.log.record("run", text=text)
        self.changed("crown", command="run")
        return self

    def run_file(self, path) -> CrownDocument:
        """Run the script file at ``path`` (a thesis script; relative names inside it resolve against
        :attr:`base_dir`). The log records the script's text, so a replay does not need the file."""
        return self.run(read_text(path, what="script"))

    def surface(self, name: str) -> bt.Node:
        """The named surface (ValueError if unknown)."""
        if name not in self.surfaces:
            raise ValueError(f"name {name!r} is not a surface; known: {sorted(self.surfaces)}")
        return self.surfaces[name]

    # ------------------------------------------------------------------ state
    def get_state(self) -> dict[str, Any]:
        p = self.points
        return {"surfaces": dict(self.surfaces), "meshes": dict(self.meshes),
                "points": (p.points, p.tags, list(p.sources)), "trees": list(self.trees), "lines": list(self.lines),
                "gen_count": self._gen_count, "seed": self.seed}

    def set_state(self, state: dict[str, Any]) -> None:
        pts, tags, sources = state["points"]
        self.surfaces, self.meshes = dict(state["surfaces"]), dict(state["meshes"])
        self.points = PointSet(pts, tags, list(sources))
        self.trees, self.lines = list(state["trees"]), list(state["lines"])
        self._gen_count, self.seed = state["gen_count"], state["seed"]

    def state_bytes(self) -> bytes:
        p = self.points
        parts = [_pickle_by_value((self.surfaces, self.meshes, list(p.sources), self.lines, self._gen_count,
                                   self.seed)), p.points.tobytes(), p.tags.tobytes()]
        for t in self.trees:
            parts += [np.asarray(t.nodes).tobytes(), np.asarray(t.parent).tobytes()]
        return b"\0".join(parts)

    def scene(self, *, resolution: int = 40) -> dict[str, Any]:
        """The newest surface as a :class:`~plantvr.types.TriMesh` (polygonized at ``resolution``; none when its
        envelope is empty), the point set as :class:`~plantvr.types.Points` coloured by source tag, and each
        grown tree as :class:`~plantvr.types.TreeArrays` with pipe-model radii."""
        resolution = check_int("resolution", resolution, 8, 160)
        out: dict[str, Any] = {}
        if self.surfaces:
            name = list(self.surfaces)[-1]
            try:
                v, f = polygonize(self.surfaces[name], resolution=resolution)
            except ValueError:             # an empty envelope draws nothing
                pass
            else:
                out[f"surface {name}"] = TriMesh(v, f)
        if len(self.points):
            rgb = np.array([[int(c[i:i + 2], 16) for i in (1, 3, 5)] for c in TAG_COLORS], np.uint8)
            out["points"] = Points(self.points.points, colors=rgb[self.points.tags % len(TAG_COLORS)])
        for k, t in enumerate(self.trees):
            parent = np.asarray(t.parent)
            out[f"tree {k}"] = TreeArrays.from_arrays(t.nodes, parent, radius=pipe_radii(parent))
        return out

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _nums(c: Command, tokens, what="number"):
        out = []
        for t in tokens:
            try:
                v = float(t)
            except ValueError:
                raise CommandError(c.lineno, t, f"expected a {what}", c.text) from None
            if not np.isfinite(v):
                raise CommandError(c.lineno, t, f"expected a finite {what}", c.text)
            out.append(v)
        return out

    def _get(self, c: Command, name: str) -> bt.Node:
        if name not in self.surfaces:
            raise CommandError(c.lineno, name, f"no surface with this name; known: {sorted(self.surfaces)}", c.text)
        return self.surfaces[name]

    def _radius(self, c, tokens):
        if not tokens:
            return self.default_radius
        r = self._nums(c, tokens[:1])[0]
        if not bt.MIN_RADIUS <= r <= MAX_COORD:
            raise CommandError(c.lineno, tokens[0], f"radius R must be in [{bt.MIN_RADIUS:g}, {MAX_COORD:g}]",
                               c.text)
        return r

    def _rows(self, c, tokens, width: int, least: int, what: str) -> np.ndarray:
        """The numbers of ``tokens`` as rows of ``width`` (at least ``least`` rows), e.g. x y z triples."""
        v = self._nums(c, tokens)
        if len(v) % width or len(v) < width * least:
            raise CommandError(c.lineno, c.args[-1], f"expected {what}", c.text)
        return np.reshape(v, (-1, width))

    def _path(self, name):
        p = Path(name)
        return p if p.is_absolute() else self.base_dir / p

    def _kv(self, c: Command, tokens) -> dict:
        out = {}
        for t in tokens:
            if "=" not in t:
                raise CommandError(c.lineno, t, "expected key=value", c.text)
            k, v = t.split("=", 1)
            out[k] = v
        return out

    # ------------------------------------------------------------------ modeling commands
    def _cmd_sphere(self, c):
        a = c.args
        if len(a) not in (1, 2, 5):
            raise CommandError(c.lineno, a[-1], "expected " + LANGUAGE["sphere"][2], c.text)
        r = self._radius(c, a[1:2])
        centre = self._nums(c, a[2:5]) if len(a) == 5 else [0.0, 0.0, 0.0]
        self.surfaces[a[0]] = bt.sphere(centre, r)

    def _cmd_line(self, c):
        a = c.args
        if len(a) not in (1, 2, 8):
            raise CommandError(c.lineno, a[-1], "expected " + LANGUAGE["line"][2], c.text)
        r = self._radius(c, a[1:2])
        ends = self._nums(c, a[2:8]) if len(a) == 8 else [0.0, -0.5, 0.0, 0.0, 0.5, 0.0]
        self.surfaces[a[0]] = bt.segment(ends[:3], ends[3:], r)

    def _cmd_torus(self, c):
        a = c.args
        rho = self._nums(c, a[1:2])[0] if len(a) > 1 else 1.0
        if rho <= 0:
            raise CommandError(c.lineno, a[1], "rho must be > 0", c.text)
        self.surfaces[a[0]] = bt.torus(normal=(0.0, 1.0, 0.0), rho=rho, radius=self._radius(c, a[2:3]))

    def _cmd_polyline(self, c):
        a = c.args
        r = self._radius(c, a[1:2])
        self.surfaces[a[0]] = bt.polyline(self._rows(c, a[2:], 3, 2, "x y z triples (at least two)"), r)

    def _cmd_revolve(self, c):
        a = c.args
        r = self._radius(c, a[1:2])
        self.surfaces[a[0]] = Revolution(self._rows(c, a[2:], 2, 3, "rho z pairs (at least three)"), radius=r)

    def _cmd_sweep(self, c):
        a = c.args
        r = self._radius(c, a[1:2])
        sec = self._nums(c, a[2:3])[0]
        v = self._nums(c, a[3:])
        if len(v) % 3 or len(v) < 6 or sec <= 0:
            raise CommandError(c.lineno, a[-1], "expected r > 0 then x y z triples (at least two)", c.text)
        path = SkinPath(np.reshape(v, (-1, 3)))
        self.surfaces[a[0]] = Skin(path, [(0.0, Circle2D(sec)), (1.0, Circle2D(sec))], radius=r)

    def _cmd_skin(self, c):
        a = c.args
        r = self._radius(c, a[1:2])
        interp = a[2]
        if interp not in ("linear", "quadratic", "cubic"):
            raise CommandError(c.lineno, interp, "expected linear, quadratic or cubic", c.text)
        if "|" not in a:
            raise CommandError(c.lineno, a[-1], "expected '|' between path points and sections", c.text)
        k = a.index("|")
        v, s = self._nums(c, a[3:k]), self._nums(c, a[k + 1:])
        if len(v) % 3 or len(v) < 6 or len(s) % 2 or len(s) < 4:
            raise CommandError(c.lineno, "|", "expected x y z triples | s r pairs", c.text)
        secs = [(si, Circle2D(ri)) for si, ri in np.reshape(s, (-1, 2))]
        self.surfaces[a[0]] = Skin(SkinPath(np.reshape(v, (-1, 3))), secs, radius=r, interpolation=interp)

    def _binary(self, c, cls):
        *ops, out = c.args
        nodes = [self._get(c, o) for o in ops]
        self.surfaces[out] = cls(*nodes)

    def _cmd_diff(self, c):
        self._binary(c, bt.Difference)

    def _cmd_diff2(self, c):
        self._binary(c, bt.Difference2)

    def _cmd_union(self, c):
        self._binary(c, bt.Union)

    def _cmd_inter(self, c):
        self._binary(c, bt.Intersection)

    def _cmd_blend(self, c):
        self._binary(c, bt.Blend)

    def _cmd_copy(self, c):
        self.surfaces[c.args[1]] = self._get(c, c.args[0])

    def _cmd_delete(self, c):
        self._get(c, c.args[0])
        del self.surfaces[c.args[0]]

    def _cmd_scale(self, c):
        node = self._get(c, c.args[0])
        s = self._nums(c, c.args[1:])
        for t, v in zip(c.args[1:], s):
            if v == 0:
                raise CommandError(c.lineno, t, "scale factors must be non-zero", c.text)
        self.surfaces[c.args[0]] = node.scaled(*s)

    def _cmd_translate(self, c):
        self.surfaces[c.args[0]] = self._get(c, c.args[0]).translated(self._nums(c, c.args[1:]))

    def _cmd_rotate(self, c):
        v = self._nums(c, c.args[1:])
        self.surfaces[c.args[0]] = self._get(c, c.args[0]).rotated(v[:3], v[3])

    def _cmd_twist(self, c):
        self.surfaces[c.args[0]] = Warp(self._get(c, c.args[0]), "twist", self._nums(c, c.args[1:2])[0])

    def _cmd_taper(self, c):
        v = self._nums(c, c.args[1:])
        self.surfaces[c.args[0]] = Warp(self._get(c, c.args[0]), "taper", v[0], z0=v[1] if len(v) > 1 else 0.0)

    def _cmd_bend(self, c):
        v = self._nums(c, c.args[1:])
        if v[1] <= 0:
            raise CommandError(c.lineno, c.args[2], "bent length L must be > 0", c.text)
        self.surfaces[c.args[0]] = Warp(self._get(c, c.args[0]), "bend", v[0], length=v[1])

    def _cmd_load_mesh(self, c):
        import trimesh

        path = self._path(c.args[1])
        if not path.is_file():
            raise CommandError(c.lineno, c.args[1], "mesh file does not exist", c.text)
        try:
            m = trimesh.load(path, process=False, force="mesh")
            v = np.asarray(m.vertices, dtype=float).reshape(-1, 3)
            f = np.asarray(m.faces, dtype=np.int64).reshape(-1, 3)
        except Exception as exc:      # trimesh raises many kinds on a corrupt file: report it as this line's error
            raise CommandError(c.lineno, c.args[1], f"cannot read the mesh ({type(exc).__name__}: {exc})",
                               c.text) from None
        if len(v) > MAX_MESH_ELEMENTS or len(f) > MAX_MESH_ELEMENTS:
            raise CommandError(c.lineno, c.args[1], f"mesh has more than {MAX_MESH_ELEMENTS} vertices or faces",
                               c.text)
        if len(f) == 0 or len(v) < 3:
            raise CommandError(c.lineno, c.args[1], "mesh has no triangles", c.text)
        if not np.all(np.isfinite(v)) or np.abs(v).max() > MAX_COORD:
            raise CommandError(c.lineno, c.args[1], f"mesh vertices must be finite and inside +-{MAX_COORD:g}",
                               c.text)
        if f.min() < 0 or f.max() >= len(v):
            raise CommandError(c.lineno, c.args[1], f"mesh faces must index its {len(v)} vertices", c.text)
        self.meshes[c.args[0]] = (v, f)

    def _cmd_seed(self, c):
        v = self._nums(c, c.args)[0]
        if v < 0 or v != int(v) or v > 2**63 - 1:
            raise CommandError(c.lineno, c.args[0], "seed must be an integer in [0, 2**63 - 1]", c.text)
        self.seed, self._gen_count = int(v), 0

    # ------------------------------------------------------------------ point commands
    def _props(self, c, tokens) -> dict:
        props = dict(PROPS_DEFAULTS)
        for t in tokens:
            if "=" in t:
                k, v = t.split("=", 1)
                if k not in PROPS_DEFAULTS:
                    raise CommandError(c.lineno, t, f"unknown key; allowed: {sorted(PROPS_DEFAULTS)}", c.text)
                try:
                    props.update({k: read_props(f"{k} = {v.replace(',', ' ')}", name=f"line {c.lineno}")[k]})
                except ValueError as exc:
                    raise CommandError(c.lineno, t, str(exc), c.text) from None
            else:
                path = self._path(t)
                if not path.is_file():
                    raise CommandError(c.lineno, t, "props file does not exist", c.text)
                try:
                    file_props = read_props(path)
                except ValueError as exc:
                    raise CommandError(c.lineno, t, str(exc), c.text) from None
                props.update({k: v for k, v in file_props.items() if v != PROPS_DEFAULTS[k]})
        return props

    def _rng(self, props, explicit_seed: bool):
        self._gen_count += 1
        if explicit_seed:
            return np.random.default_rng(props["seed"])
        return np.random.default_rng([self.seed, self._gen_count])

    def _cmd_point_set_gen(self, c):
        target, dist = c.args[0], c.args[1]
        if dist not in DISTRIBUTIONS:
            raise CommandError(c.lineno, dist, f"unknown distribution; known: {', '.join(DISTRIBUTIONS)}", c.text)
        props = self._props(c, c.args[2:])
        explicit_seed = props["seed"] != PROPS_DEFAULTS["seed"] or any(t.startswith("seed=") for t in c.args[2:])
        rng = self._rng(props, explicit_seed)
        n = props["num_points"]
        if dist.startswith("mesh"):
            if target not in self.meshes:
                raise CommandError(c.lineno, target, f"no mesh with this name; known: {sorted(self.meshes)}", c.text)
            v, f = self.meshes[target]
            pts, _ = sample_mesh_near(v, f, n, offset=props["offset"], rng=rng,
                                      selection="area" if dist == "mesh_near" else "uniform")
        else:
            node = self._get(c, target)
            grid = props["grid"]
            r = props["min_distance"]
            if dist == "uniform":
                pts = sample_inside(node, n, rng=rng)
            elif dist in ("poisson", "cluster", "inverse_field", "near_boundary"):
                kernel = poisson_kernel(r) if dist != "cluster" else cluster_kernel(r, props["r1"], props["alpha"])
                mode = {"poisson": "inside", "cluster": "inside", "inverse_field": "inverse",
                        "near_boundary": "band"}[dist]
                band = props["band"] or (ISO, ISO + 0.05)
                pts = lane_in_node(node, n, kernel=kernel, shape=grid, mode=mode, band=band, gamma=props["gamma"],
                                   exact=props["exact"], rng=rng).points
            else:  # outside_near
                band = props["band"] or (ISO - 0.1, ISO)
                pts = sample_band(node, n, band=band, method="cache", cache=FieldCache(node, edge=0.5 * r, band=band),
                                  rng=rng)
        self.points = self.points.add(pts, f"{target}:{dist}")

    def _cmd_point_set_thin(self, c):
        crown, secondary, pct = c.args
        sec = self._get(c, secondary)
        d = self._nums(c, [pct])[0]
        if not 0 <= d <= 100:
            raise CommandError(c.lineno, pct, "percent must be in [0, 100]", c.text)
        src = [i for i, s in enumerate(self.points.sources) if s.split(":")[0] == crown]
        if not src:
            raise CommandError(c.lineno, crown, "no points were generated for this surface", c.text)
        idx = np.flatnonzero(np.isin(self.points.tags, src))
        inside = idx[sec.inside(self.points.points[idx])]
        k = int(np.floor(d * len(inside) / 100.0 + 1e-9))   # same rule as pointsets.thin (thesis §7.1)
        keep = np.ones(len(self.points), dtype=bool)
        keep[inside[:k]] = False
        self.points = self.points.select(keep)

    def _cmd_point_set_densify(self, c):
        sec = self._get(c, c.args[0])
        n = self._nums(c, c.args[1:2])[0]
        if n < 0 or n != int(n) or n > 10**8:
            raise CommandError(c.lineno, c.args[1], "N must be an integer in [0, 100000000]", c.text)
        kv = self._props(c, c.args[2:])
        rng = self._rng(kv, False)
        self.points = densify(self.points, sec, int(n), source=f"{c.args[0]}:densify", r_min=kv["min_distance"],
                              respect_existing=True, shape=kv["grid"], rng=rng)

    def _cmd_point_set_clear(self, c):
        self.points = PointSet()

    def _cmd_save_point_set(self, c):
        path = self._path(c.args[0])
        if not path.parent.is_dir():
            raise CommandError(c.lineno, c.args[0], "the folder of this point file does not exist", c.text)
        # written when the whole script has run (a later bad line must not leave the file changed)
        self._to_write.pop(path, None)
        self._to_write[path] = (self.points, {"seed": self.seed})

    def _cmd_load_point_set(self, c):
        path = self._path(c.args[0])
        if path in self._to_write:                   # saved earlier in this script: read what it will hold
            self.points = self._to_write[path][0]
            return
        if not path.is_file():
            raise CommandError(c.lineno, c.args[0], "point file does not exist", c.text)
        self.points = load_point_set(path)

    def _cmd_grow(self, c):
        kv = self._kv(c, c.args)
        allowed = {"step", "kill", "influence", "max_steps", "root"}
        for k in kv:
            if k not in allowed:
                raise CommandError(c.lineno, k, f"unknown grow key; allowed: {sorted(allowed)}", c.text)
        step = self._nums(c, [kv.get("step", "1.0")])[0]
        kill = self._nums(c, [kv.get("kill", str(2 * step))])[0]
        infl = np.inf if kv.get("influence", "inf") == "inf" else self._nums(c, [kv["influence"]])[0]
        ms = self._nums(c, [kv.get("max_steps", "500")])[0]
        if ms != int(ms):
            raise CommandError(c.lineno, kv["max_steps"], "max_steps must be an integer", c.text)
        max_steps = int(ms)
        if len(self.points) == 0:
            raise CommandError(c.lineno, "grow", "no attraction points: run point_set_gen first", c.text)
        if "root" in kv:
            r = self._nums(c, kv["root"].split(","))
            if len(r) == 0 or len(r) % 3:
                raise CommandError(c.lineno, kv["root"], "root must be x,y,z (triples)", c.text)
            roots = np.reshape(r, (-1, 3))
        else:
            roots = default_roots(self.points.points)
        self.trees.append(grow_in_crown(self.points.points, roots, step_size=step, kill_radius=kill,
                                        influence_radius=infl, max_steps=max_steps))
