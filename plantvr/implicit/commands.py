"""The thesis command language: its commands, their argument counts and the parser (spec 003_implicit_sca
§5.1, §2.9; C-13).

Verbatim thesis scripts run as written::

    sphere s1              sphere s                               point_set_thin crown secondary 80
    line s2                scale s 50 80 50
    diff s1 s2 s3          point_set_gen s poisson poisson.props
                           save_point_set points.txt

A script is parsed completely (:func:`parse_script`) before anything runs. The state the commands build (named
surfaces, meshes, the tagged point set, grown trees) lives in :class:`plantvr.documents.crown.CrownDocument`,
which runs a script all or nothing as one logged, undoable command. Errors are ``CommandError`` (a
``ValueError``) naming the line number and the offending token.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["COMMANDS", "DISTRIBUTIONS", "Command", "CommandError", "parse_script"]

DISTRIBUTIONS = ("uniform", "poisson", "cluster", "near_boundary", "inverse_field", "outside_near", "mesh_near",
                 "mesh_uniform")


class CommandError(ValueError):
    """A command line that cannot be parsed or run; names the line and the token."""

    def __init__(self, lineno: int, token: str, message: str, line: str = ""):
        self.lineno, self.token = lineno, token
        super().__init__(f"line {lineno}: token {token!r}: {message}" + (f"  [{line.strip()}]" if line else ""))


@dataclass(frozen=True)
class Command:
    """One parsed line: its number, command name, argument tokens and text."""

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
