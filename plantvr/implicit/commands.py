"""The thesis command language: text commands that build BlobTrees and point sets, saved and replayed
(spec 003_implicit_sca §5.1, §2.9; C-13).

Verbatim thesis scripts run as written::

    sphere s1              sphere s                               point_set_thin crown secondary 80
    line s2                scale s 50 80 50
    diff s1 s2 s3          point_set_gen s poisson poisson.props
                           save_point_set points.txt

A script is parsed completely before anything runs, and it runs on a copy of the session state that is committed
only if every line succeeds, so a rejected script leaves the session unchanged; the files its ``save_point_set``
lines write are written (atomically) only then, too. Errors are ``CommandError`` (a ``ValueError``) naming the
line number and the offending token. :meth:`CommandSession.save_script` writes a script that
:meth:`CommandSession.replay` with the same session ``seed`` turns back into the same session.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from plantvr._fileio import write_atomic
from plantvr._validation import MAX_COORD, check_int, check_range

from . import blobtree as bt
from .band import FieldCache, sample_band
from .crown import default_roots, grow_in_crown
from .fields import ISO
from .mesh_sampling import sample_mesh_near
from .pointsets import (PROPS_DEFAULTS, PointSet, densify, load_point_set, read_props, read_text_file,
                        save_point_set)
from .sampling import cluster_kernel, lane_in_node, poisson_kernel, sample_inside
from .skinning import Circle2D, Revolution, Skin, SkinPath
from .warps import Warp

__all__ = ["CommandError", "CommandSession", "COMMANDS", "DISTRIBUTIONS", "parse_script"]

DISTRIBUTIONS = ("uniform", "poisson", "cluster", "near_boundary", "inverse_field", "outside_near", "mesh_near",
                 "mesh_uniform")


class CommandError(ValueError):
    """A command line that cannot be parsed or run; names the line and the token."""

    def __init__(self, lineno: int, token: str, message: str, line: str = ""):
        self.lineno, self.token = lineno, token
        super().__init__(f"line {lineno}: token {token!r}: {message}" + (f"  [{line.strip()}]" if line else ""))


@dataclass(frozen=True)
class Command:
    lineno: int
    name: str
    args: tuple
    text: str


# name -> (min args, max args or None, usage)
COMMANDS = {
    "sphere": (1, 5, "sphere NAME [R [x y z]]"),
    "line": (1, 8, "line NAME [R [x0 y0 z0 x1 y1 z1]]"),
    "torus": (1, 3, "torus NAME [rho [R]]"),
    "polyline": (8, None, "polyline NAME R x y z x y z ..."),
    "revolve": (8, None, "revolve NAME R rho z rho z rho z ..."),
    "sweep": (9, None, "sweep NAME R r x y z x y z ..."),
    "skin": (11, None, "skin NAME R linear|quadratic|cubic x y z x y z ... | s r s r ..."),
    "diff": (3, 3, "diff A B RESULT"),
    "diff2": (3, 3, "diff2 A B RESULT"),
    "union": (3, None, "union A B ... RESULT"),
    "inter": (3, None, "inter A B ... RESULT"),
    "blend": (3, None, "blend A B ... RESULT"),
    "copy": (2, 2, "copy A B"),
    "delete": (1, 1, "delete A"),
    "scale": (4, 4, "scale NAME sx sy sz"),
    "translate": (4, 4, "translate NAME x y z"),
    "rotate": (5, 5, "rotate NAME ax ay az degrees"),
    "twist": (2, 2, "twist NAME k"),
    "taper": (2, 3, "taper NAME k [z0]"),
    "bend": (3, 3, "bend NAME k L"),
    "load_mesh": (2, 2, "load_mesh NAME FILE"),
    "seed": (1, 1, "seed N"),
    "point_set_gen": (2, None, "point_set_gen SURFACE DIST [FILE.props] [key=value ...]"),
    "point_set_thin": (3, 3, "point_set_thin CROWN SECONDARY PERCENT"),
    "point_set_densify": (2, None, "point_set_densify SECONDARY N [key=value ...]"),
    "point_set_clear": (0, 0, "point_set_clear"),
    "save_point_set": (1, 1, "save_point_set FILE"),
    "load_point_set": (1, 1, "load_point_set FILE"),
    "grow": (0, None, "grow [step=D] [kill=dk] [influence=di|inf] [max_steps=N] [root=x,y,z]"),
}


#: Most lines and characters of one script.
MAX_SCRIPT_LINES = 1_000_000
MAX_SCRIPT_CHARS = 1 << 28
#: Most vertices / faces of a mesh loaded by ``load_mesh``.
MAX_MESH_ELEMENTS = 50_000_000


def parse_script(text: str) -> list[Command]:
    """Parse a script into commands (``#`` comments, blank lines skipped); check names and argument counts."""
    if not isinstance(text, str):
        raise ValueError(f"text must be a string, got {type(text).__name__}")
    if len(text) > MAX_SCRIPT_CHARS:
        raise ValueError(f"text must hold at most {MAX_SCRIPT_CHARS} characters, got {len(text)}")
    if "\0" in text:
        raise ValueError("text must not contain NUL characters (a binary or corrupt file?)")
    out = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if len(out) >= MAX_SCRIPT_LINES:
            raise CommandError(lineno, line.split()[0], f"scripts hold at most {MAX_SCRIPT_LINES} commands", raw)
        tokens = line.split()
        name, args = tokens[0], tuple(tokens[1:])
        if name not in COMMANDS:
            raise CommandError(lineno, name, f"unknown command; known: {', '.join(sorted(COMMANDS))}", raw)
        lo, hi, usage = COMMANDS[name]
        if len(args) < lo or (hi is not None and len(args) > hi):
            tok = args[hi] if hi is not None and len(args) > hi else name
            raise CommandError(lineno, tok, f"expected {usage}", raw)
        out.append(Command(lineno, name, args, raw))
    return out


class CommandSession:
    """Named surfaces, meshes, one composite tagged point set and grown trees, driven by text commands.

    Parameters
    ----------
    base_dir : str or Path
        Directory for relative file names (props, point files, meshes).
    seed : int
        Session seed; the k-th generator call uses ``default_rng([seed, k])`` unless its props give a seed.
    default_radius : float
        R of ``sphere``/``line``/``torus`` when not given (surface at R/2).

    References
    ----------
    .. [1] Kochhar 2010, §4.1, §7.0.1, §7.1; spec 003 §5.1-5.2.
    """

    def __init__(self, *, base_dir=".", seed: int = 0, default_radius: float = 1.0):
        try:
            self.base_dir = Path(base_dir)
        except TypeError:
            raise ValueError(f"base_dir must be a path, got {type(base_dir).__name__}") from None
        self.seed = check_int("seed", seed, 0, 2**63 - 1)
        self.default_radius = check_range("default_radius", default_radius, bt.MIN_RADIUS, MAX_COORD)
        self.surfaces: dict = {}
        self.meshes: dict = {}
        self.points = PointSet()
        self.trees: list = []
        self.history: list[str] = []
        self._gen_count = 0
        self._pending: dict = {}                    # path -> PointSet written when the running script commits

    # ------------------------------------------------------------------ public API
    def run(self, text: str) -> "CommandSession":
        """Parse and run a script; on any error the session is left unchanged and ``CommandError`` is raised."""
        commands = parse_script(text)
        state = self._snapshot()
        self._pending = {}
        try:
            for c in commands:
                try:
                    getattr(self, f"_cmd_{c.name}")(c)
                except CommandError:
                    raise
                except (ValueError, OverflowError, ZeroDivisionError) as exc:
                    raise CommandError(c.lineno, c.name, str(exc), c.text) from exc
                self.history.append(c.text.strip())
            for path, (points, header) in self._pending.items():   # every line ran: write the saved files
                try:
                    save_point_set(path, points, header=header)
                except (OSError, ValueError) as exc:
                    raise ValueError(f"save_point_set: cannot write {str(path)!r}: {exc}") from None
        except BaseException:
            self._restore(state)
            raise
        finally:
            self._pending = {}
        return self

    def script_text(self) -> str:
        """The script :meth:`save_script` writes: the commands run so far, one per line. Replaying it with the
        session's seed (``replay(path, seed=...)``) reproduces the session."""
        return "\n".join(self.history) + "\n"

    def save_script(self, path) -> None:
        """Write the commands run so far, one per line (replay with :meth:`replay`); atomic."""
        write_atomic(path, self.script_text())

    @classmethod
    def replay(cls, path, **kwargs) -> "CommandSession":
        """A new session that runs the script file at ``path``."""
        path = Path(path)
        if not path.is_file():
            raise ValueError(f"path {str(path)!r} does not exist")
        kwargs.setdefault("base_dir", path.parent)
        session = cls(**kwargs)
        return session.run(read_text_file(path, "script"))

    def surface(self, name: str) -> bt.Node:
        """The named surface (ValueError if unknown)."""
        if name not in self.surfaces:
            raise ValueError(f"name {name!r} is not a surface; known: {sorted(self.surfaces)}")
        return self.surfaces[name]

    # ------------------------------------------------------------------ state
    def _snapshot(self):
        return (dict(self.surfaces), dict(self.meshes), self.points, list(self.trees), list(self.history),
                self._gen_count, self.seed)

    def _restore(self, s):
        (self.surfaces, self.meshes, self.points, self.trees, self.history, self._gen_count, self.seed) = \
            (dict(s[0]), dict(s[1]), s[2], list(s[3]), list(s[4]), s[5], s[6])

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
            raise CommandError(c.lineno, a[-1], "expected " + COMMANDS["sphere"][2], c.text)
        r = self._radius(c, a[1:2])
        centre = self._nums(c, a[2:5]) if len(a) == 5 else [0.0, 0.0, 0.0]
        self.surfaces[a[0]] = bt.sphere(centre, r)

    def _cmd_line(self, c):
        a = c.args
        if len(a) not in (1, 2, 8):
            raise CommandError(c.lineno, a[-1], "expected " + COMMANDS["line"][2], c.text)
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
        self._pending.pop(path, None)
        self._pending[path] = (self.points, {"seed": self.seed})

    def _cmd_load_point_set(self, c):
        path = self._path(c.args[0])
        if path in self._pending:                   # saved earlier in this script: read what it will hold
            self.points = self._pending[path][0]
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
