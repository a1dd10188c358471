"""The ``.lpy`` reader (issue 23): splits an L-Py file into its Python code and its L-system parts.

Layout read, as L-Py's ``lpy_parser`` does: Python code (functions, constants, ``extern(...)``, ``module A, B``
declarations, ``nproduce`` in functions) before and after the L-system; ``Axiom:`` (an L-string, or an indented
Python block of ``nproduce`` statements below it); ``derivation length:``;
``ignore:`` / ``consider:``; sections ``production:``, ``decomposition:`` and ``homomorphism:`` /
``interpretation:`` (``maximum depth:`` inside the last two); ``endlsystem``; the trailing
``###### INITIALISATION ######`` block of L-Py's editor (its ``scalars`` are read as declared parameters; a trusted
grammar also runs its code and ``__initialiseContext__``, which define the curves and functions of its panels).

Rules: ``left < pred > right``, ``newleft << pred >> newright`` headers; ``pred --> successor`` or
``pred -> successor`` (``pred -static-> successor`` and ``pred : @static`` + a block: made once, see
:attr:`Rule.static`); ``pred : produce successor`` or ``pred :`` followed by an indented Python block with
``produce`` / ``nproduce`` statements (a block that produces nothing has failed and the next rule is tried, as in
L-Py); and the cpfg-style condition ``pred : condition --> successor``.

A predecessor may be several modules (``A B --> C``, ``A(x) B(y) --> ...``; issue 33): as L-Py's
``LsysRule::match`` they match modules at consecutive positions, which the successor replaces all together, the
right context being matched after the last (brackets in it are matched as modules, ``A [ B ] --> C``, and
must balance); the string is then rewritten left to right (right to left after
``backward()``, a predecessor then found by its last module, as L-Py's ``MatchingEngine::reverse_match``).

A pattern parameter is a variable name or a constant (``M(0) --> ...``, ``A(1, x)``, ``L("a")``: the module
matches when its parameter equals the constant, as L-Py's pattern matching compares non-variable arguments).

Decomposition and homomorphism rules may have contexts ``<`` / ``>`` (issue 33), matched as L-Py's
``Lsystem::__recursiveSteps`` does: in the whole string at the first level, then within each successor.

Rule groups (issue 33, L-Py's ``lpy_parser.cpp``): the rules after ``group N:`` are in group N (an integer
expression, at least 0) until ``endgroup`` or the next ``group``; the others are in group 0.

Request modules (``?P(x, y, z)``, ``?H(h)``, ...; issue 33) may be in any pattern: the engine answers them
before the step (:mod:`plantvr.lsystem.rewrite`).

L-Py's pattern modules (issue 33; :mod:`plantvr.lsystem.patterns`): the wildcard ``*`` (``any``) in predecessors
and contexts (``*(name, x, *rest)`` binding the module's name and parameters), ``*args`` star parameters
(``A(x, *rest)``; ``A(*p)`` in a successor unpacks ``p``), the repetition ``x(pattern, lo, hi)`` (``all``) in
contexts, ``[`` in left contexts, the exact closing bracket ``=]`` in right contexts and a bracket first in a
predecessor.

Brackets in a predecessor are matched as modules, balanced or not (``[] -->``, ``[S(p) --> [ _(1) S(p)``: L-Py
checks none and finds the rule at its first module, ``RulePtrMap``).

Not supported (LSystemError naming the construct with its line and column): a ``]`` in a left context (a ``[``
there is the module just before, as L-Py's ``TreeLeftMatcher``: ``F [ < A``), value constraints inside
repetitions and alternatives, the unnamed parameter ``-``, ``x(...)`` repetitions and ``or(...)`` alternatives
in predecessors, ``None`` outside ``or(...)`` (in a successor ``or`` and ``None`` are plain modules, as L-Py
has them), ``=]`` outside right contexts, iterator requests (``?I``) in patterns, new contexts (``<<`` /
``>>``) in decomposition and homomorphism rules.
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass, field

from .lexer import GETMODULE, LSystemError, Token, _close_paren, find_top, lex, split_top
from .patterns import PATTERN_NAMES, read_pattern
from .pytext import PRODUCE, in_string, join_produce, open_quote, quote_context_patterns, strip_comment

__all__ = ["Grammar", "Rule", "lstring_to_py", "parse_grammar"]

_INIT_TAG = "###### INITIALISATION ######"
_SECTIONS = {"production": "production", "decomposition": "decomposition", "homomorphism": "homomorphism",
             "interpretation": "homomorphism"}
_HEADER = re.compile(r"^(Axiom|derivation length|production|decomposition|homomorphism|interpretation|"
                     r"maximum depth|ignore|consider|endlsystem|endgroup|group\s+\S+)\s*(:?)(.*)$")


@dataclass
class Rule:
    """One rule as written: its pattern parts (tokens), its body as Python source lines and where it is."""

    kind: str                        # "production" | "decomposition" | "homomorphism"
    pred: Token
    left: list[Token]
    right: list[Token]
    newleft: list[Token]
    newright: list[Token]
    params: list[str]                # formal parameters, L-Py order: left, newleft, pred, newright, right
    body: list[tuple[int, str]]      # (line, python source) — produce statements already translated
    successor: list[Token] | None    # the one-line successor (``-->`` or ``: produce``), for fast paths
    condition: str | None            # cpfg-style condition source, with ``successor``
    line: int
    col: int
    header: str
    #: Constants of the pattern's parameter lists, ``(index, value)`` with ``index`` counting every pattern
    #: parameter in L-Py order (issue 33: ``M(0) --> ...`` matches only ``M`` modules whose parameter is 0).
    consts: list = field(default_factory=list)
    #: The modules after the first of a multi-module predecessor (``A B --> C``: ``[B]``; issue 33).
    pred_rest: list = field(default_factory=list)
    #: The rule group (``group N:`` ... ``endgroup``; issue 33): ``(expression source, line)``, None for group 0.
    group: tuple | None = None
    #: ``pred -static-> successor`` (L-Py's ``LsysRule::setStatic``): the successor is made once, when the grammar
    #: is read, with the pattern's variables unbound, and is the same for every module the rule matches.
    static: bool = False
    #: The compiled patterns (:class:`~plantvr.lsystem.patterns.Pattern`) of ``left``, ``newleft``, ``pred``
    #: (all its modules), ``newright`` and ``right``.
    patterns: dict = field(default_factory=dict)
    #: The ``ignore:`` / ``consider:`` in force where the rule is written (L-Py's ``currentConsider``, one per
    #: rule): ``(module list source, line, col, is_ignore)``, None for none.
    filter: tuple | None = None


@dataclass
class Grammar:
    """An L-Py file split into its parts (see the module docstring)."""

    python: str                                        # the Python code, line numbers kept
    axiom: tuple[str, int, int] | None = None          # (l-string source, line, col)
    derivation_length: tuple[str, int] | None = None   # (expression source, line)
    max_depth: dict = field(default_factory=dict)      # kind -> (expression source, line)
    declared: dict = field(default_factory=dict)       # module name -> line
    scales: dict = field(default_factory=dict)         # module name -> its ': scale = n' (multiscale matching)
    param_names: dict = field(default_factory=dict)    # module name -> the parameter names of its declaration
    bases: dict = field(default_factory=dict)          # module name -> the names of its ': base = A'
    rules: list[Rule] = field(default_factory=list)
    scalars: dict = field(default_factory=dict)        # name -> value, from the editor's INITIALISATION block
    init: str = ""                                     # that block's code, line numbers kept (run when trusted)
    first_use: dict = field(default_factory=dict)      # module name -> (line, col) of its first appearance
    axiom_tokens: list = field(default_factory=list)
    axiom_block: list = field(default_factory=list)    # (line, Python) of an 'Axiom:' written as an nproduce block


def lstring_to_py(tokens: list[Token]) -> str:
    """Python expression building the module list ``[(name, (args...)), ...]`` of an L-string."""
    items = []
    for t in tokens:
        if t.name == "*" and len(tokens) == 1 and t.args is None:
            return "[]"                                       # ``produce *``: the empty string
        args = "".join(f"{a}," if a.startswith("*") and not a.startswith("**") else    # A(*p): unpacked
                       f"__lsys_kwds__({a[2:]})," if a.startswith("**") else f"({a}),"  # A(**p): by name
                       for a in (t.args or ()))
        items.append(f"({t.name!r}, ({args}))")
    return "[" + ", ".join(items) + "]"


class _Reader:
    def __init__(self, text: str, deadline: float | None = None) -> None:
        self.text = text
        self.deadline = deadline
        self.known: set[str] = set(_turtle_names())
        self.aliases: dict[str, str] = {}                    # ``module A = F``: alias -> module name
        self.g = Grammar(python="")
        self.group: tuple | None = None                      # the ``group N:`` the rules being read are in
        self.filter: tuple | None = None                     # the ``ignore:`` / ``consider:`` in force

    # -- helpers -----------------------------------------------------------------------------------------------
    def lex(self, s: str, line: int, col: int, known=None) -> list[Token]:
        toks = lex(s, self.known if known is None else known, line=line, col=col, deadline=self.deadline)
        if self.aliases:                                      # L-Py's ModuleClassTable alias: the same class
            toks = [Token(self.aliases.get(t.name, t.name), t.args, t.line, t.col) for t in toks]
        for t in toks:
            self.g.first_use.setdefault(t.name, (t.line, t.col))
        return toks

    def lex_pattern(self, s: str, line: int, col: int) -> list[Token]:
        """Lex a rule header's part, L-Py's pattern modules (``any``, ``all``, ``or``) known as whole names."""
        toks = self.lex(s, line, col, frozenset(self.known) | PATTERN_NAMES)
        for k in range(len(toks) - 2, -1, -1):                # ``$A(a)``: L-Py's GetModule pattern, one token
            t, nxt = toks[k], toks[k + 1]
            if t.name == "$" and t.args is None and nxt.args is not None and s[nxt.col - col:][:1].isalpha():
                toks[k:k + 2] = [Token(GETMODULE, (nxt.name, *nxt.args), t.line, t.col)]
        return toks

    def translate_produce(self, src: str, line: int, *, in_rule: bool, col0: int = 0) -> str:
        """Replace ``produce X`` / ``nproduce X`` statements in one line of Python (``src``, which starts at column
        ``col0 + 1`` of the grammar) by their calls (and quote the patterns of ``InLeftContext(A(x), args)``, which
        L-Py's parser reads as L-strings)."""
        out, pos = [], 0
        code = quote_context_patterns(strip_comment(src))
        for m in PRODUCE.finditer(code):
            if in_string(code, m.start()):
                continue
            out.append(code[pos:m.start()])
            rest, at = code[m.end():], m.end()
            inner = rest.lstrip()
            if inner.startswith("("):                         # ``produce ( A B )``: the L-string in parentheses
                close = _close_paren(inner, 0, line, col0 + at + len(rest) - len(inner) + 1, m.group(1))
                if not inner[close + 1:].strip():
                    at += len(rest) - len(inner) + 1
                    rest = inner[1:close]
            toks = self.lex(rest, line, col0 + at + 1)
            expr = lstring_to_py(toks)
            if m.group(1) == "produce":
                if not in_rule:
                    raise LSystemError("'produce' outside a rule body or function", line,
                                       col0 + m.start() + 1)
                out.append(f"return __lsys_produce__({expr})")
            else:
                out.append(f"__lsys_nproduce__({expr})")
            pos = len(code)
            break                                             # the L-string runs to the end of the line
        out.append(code[pos:])
        return "".join(out)

    # -- the file ----------------------------------------------------------------------------------------------
    def read(self) -> Grammar:
        text = self.text.replace("\r\n", "\n").replace("\r", "\n")
        if _INIT_TAG in text:
            text, init = text.split(_INIT_TAG, 1)
            self.read_scalars(init)
            self.g.init = "\n" * text.count("\n") + init
        lines = join_produce(text.split("\n"))
        self.pre_declare(lines)
        py = [""] * len(lines)
        mode = "python"
        rule_lines: list[tuple[int, str]] = []

        def flush() -> None:
            if rule_lines:
                self.rule(mode, list(rule_lines))
                rule_lines.clear()

        block: list | None = None                             # the lines of an 'Axiom:' block, while open
        quote = None                                          # the Python code's open triple-quoted string
        for k, raw in enumerate(lines):
            ln = k + 1
            s = raw.rstrip()
            if block is not None:
                if not s.strip() or raw[0] in " \t":
                    block.append((ln, raw))
                    continue
                block = self.read_axiom_block(block)
            if (mode == "python" or mode == "after") and quote is not None:
                py[k], quote = raw, open_quote(raw, quote)   # inside a string: Python text, never a section
                continue
            if mode == "python" or mode == "after":
                quote = open_quote(raw, None)
                m = _HEADER.match(s) if mode == "python" else None
                if m and (m.group(2) or m.group(1).startswith(("endlsystem", "endgroup"))):
                    mode = self.header(m, ln, raw) or mode
                    block = [] if m.group(1) == "Axiom" and not self.g.axiom[0] else None
                    continue
                if s.startswith("module ") or s.startswith("module\t"):
                    self.declare(s, ln)
                    continue
                if s.startswith("undeclare "):
                    continue
                # ``produce`` in a function returns its modules (L-Py: StartInterpretation / EndInterpretation)
                py[k] = self.translate_produce(raw, ln, in_rule=raw[:1] in " \t") if "produce" in raw else raw
                continue
            # inside the L-system
            if not s.strip() or s.lstrip().startswith("#"):
                continue
            if raw[0] in " \t":
                if not rule_lines:
                    raise LSystemError("unexpected indent (no rule header above)", ln, 1)
                rule_lines.append((ln, raw))
                continue
            m = _HEADER.match(s)
            if m and (m.group(2) or m.group(1).startswith(("endlsystem", "endgroup", "group"))):
                flush()
                mode = self.header(m, ln, raw, section=mode) or mode
                block = [] if m.group(1) == "Axiom" and not self.g.axiom[0] else None
                continue
            if s.startswith("def ") or s.startswith("class "):
                raise LSystemError("Python definitions inside the rule sections are not supported (move them "
                                   "before 'Axiom:' or after 'endlsystem')", ln, 1)
            flush()
            rule_lines.append((ln, raw))
        flush()
        if block is not None:
            self.read_axiom_block(block)
        self.g.python = "\n".join(py)
        if self.g.axiom is None:                  # L-Py's Lsystem::clear: no 'Axiom:' line, the empty axiom
            self.g.axiom = ("", 1, 1)
        return self.g

    def read_axiom_block(self, block: list[tuple[int, str]]) -> None:
        """An 'Axiom:' with nothing after it and an indented block of Python below (``nproduce`` statements, loops),
        as L-Py reads it: the block's code, ``produce``/``nproduce`` translated, is the axiom's."""
        code = [(k, raw) for k, raw in block if strip_comment(raw).strip()]
        if not code:                # an empty axiom, as L-Py reads it: the empty L-string
            return
        indent = min(len(raw) - len(raw.lstrip()) for _, raw in code)
        self.g.axiom_block = [(k, self.translate_produce(raw[indent:], k, in_rule=True, col0=indent))
                              for k, raw in code]

    def read_scalars(self, init: str) -> None:
        m = re.search(r"scalars\s*=\s*(\[.*?\])\s*\n", init, re.DOTALL)
        if not m:
            return
        try:
            vals = ast.literal_eval(m.group(1))
        except (ValueError, SyntaxError):
            return
        for item in vals:
            if isinstance(item, (tuple, list)) and len(item) >= 3 and isinstance(item[0], str):
                if isinstance(item[2], (int, float)) and not isinstance(item[2], bool):
                    self.g.scalars[item[0]] = float(item[2])

    def pre_declare(self, lines: list[str]) -> None:
        for k, raw in enumerate(lines):
            if raw.startswith("module ") or raw.startswith("module\t"):
                self.declare(raw.rstrip(), k + 1)

    def declare(self, s: str, ln: int) -> None:
        body = strip_comment(s)[len("module"):]
        body, _, options = body.partition(":")                # ``module A : scale = 1, base = (B, C)``
        scale, bases = self.module_options(options, s, ln)
        for part in split_top(body):
            part = part.strip()
            if not part:
                continue
            name = part.split("(", 1)[0].strip()
            if "=" in name:                                   # ``module A = F``: A is another name of F
                alias, _, target = (x.strip() for x in name.partition("="))
                if not alias or not target or "=" in target or alias == target:
                    raise LSystemError(f"module alias {part!r} must be 'module A = B'", ln, s.find(part) + 1)
                self.aliases[alias] = self.aliases.get(target, target)
                self.known.update((alias, target))
                continue
            if not name:
                raise LSystemError(f"module declaration {part!r} has no name", ln, s.find(part) + 1)
            self.known.add(name)
            self.g.declared.setdefault(name, ln)
            if "(" in part:                                   # ``module A(age, size)``: NodeModule's a.age
                self.g.param_names[name] = tuple(p.strip() for p in split_top(part.split("(", 1)[1].rsplit(")", 1)[0])
                                                 if p.strip())
            if scale is not None:
                self.g.scales[name] = scale
            if bases:
                self.g.bases[name] = bases

    @staticmethod
    def module_options(options: str, s: str, ln: int) -> tuple[int | None, tuple[str, ...]]:
        """A declaration's ``scale = n`` (an integer, L-Py's ``ModuleClass.scale``) and ``base = A`` /
        ``base = (A, B)`` (its base classes, ``lpy_parser.cpp``)."""
        scale, bases = None, ()
        rest = options
        for m in re.finditer(r"\b(scale|base|bases)\s*=\s*(\([^)]*\)|[^,\s]+)", options):
            key, val = m.group(1), m.group(2)
            rest = rest.replace(m.group(0), "", 1)
            if key == "scale":
                if not re.fullmatch(r"-?\d+", val):
                    raise LSystemError(f"a module scale must be an integer, got {val!r:.40}", ln, s.find(val) + 1)
                scale = int(val)
            else:
                bases = tuple(b.strip() for b in val.strip("()").split(",") if b.strip())
                bad = [b for b in bases if not re.fullmatch(r"[A-Za-z_]\w*", b)]
                if bad:
                    raise LSystemError(f"module base {bad[0]!r:.40} is not a module name", ln, s.find(bad[0]) + 1)
        left = rest.replace(",", " ").strip()
        if left:
            raise LSystemError(f"unknown module option {left!r:.40} (L-Py's are scale = n and base = A)", ln,
                               s.find(left.split()[0]) + 1)
        return scale, bases

    def header(self, m: re.Match, ln: int, raw: str, section: str = "python") -> str | None:
        key, rest = m.group(1), m.group(3)
        col = raw.find(rest) + 1 if rest.strip() else len(raw) + 1
        if key == "Axiom":
            if not strip_comment(rest).strip():              # the L-string follows as an indented block
                self.g.axiom = ("", ln, col)
                return None
            self.g.axiom = (rest, ln, raw.find(":") + 2)
            self.g.axiom_tokens = self.lex(rest, ln, raw.find(":") + 2)
            return None
        if key == "derivation length":
            if not rest.strip():
                raise LSystemError("cannot find a value for 'derivation length'", ln, col)
            self.g.derivation_length = (strip_comment(rest).strip(), ln)
            return None
        if key in ("ignore", "consider"):              # the filter of the rules after it (lpy_parser.cpp)
            src = strip_comment(rest)
            self.filter = (src, ln, raw.find(":") + 2, key == "ignore") if src.strip() else None
            return None
        if key == "maximum depth":
            if section not in ("decomposition", "homomorphism"):
                raise LSystemError("'maximum depth:' outside a decomposition or homomorphism section", ln, 1)
            self.g.max_depth[section] = (strip_comment(rest).strip(), ln)
            return None
        if key == "endlsystem":
            return "after"
        if key == "endgroup":
            self.group = None
            return None
        if key.startswith("group"):
            src = key[len("group"):].rstrip(":").strip()
            if not (m.group(2) or key.endswith(":")) or not src:
                raise LSystemError("cannot find a value and ':' after 'group'", ln, 1)
            self.group = (src, ln)
            return None
        if rest.strip() and not rest.strip().startswith("#"):
            raise LSystemError(f"unexpected text after '{key}:'", ln, col)
        return _SECTIONS[key]

    # -- rules -------------------------------------------------------------------------------------------------
    def rule(self, kind: str, lines: list[tuple[int, str]]) -> None:
        ln, first = lines[0]
        head_at, delim = find_top(first, ("-static->", "-->", "->", ":"), modules=True)
        if head_at < 0:
            code = strip_comment(first)
            if code.count("[") != code.count("]"):
                raise LSystemError(f"unbalanced brackets in the rule {first.strip()!r}", ln, 1)
            raise LSystemError(f"rule without ':' or '-->': {first.strip()!r}", ln, 1)
        # a predecessor '-' before the arrow: '- --> +' is found at the arrow, '---> ' would be ambiguous
        header = first[:head_at]
        rest = first[head_at + len(delim):]
        parts = self.parse_header(header, ln, kind)
        preds, left, right, newleft, newright = parts
        pred = preds[0]
        pats = {}
        params: list[str] = []
        consts: list = []
        k = 0
        for key, grp in (("left", left), ("newleft", newleft), ("pred", preds), ("newright", newright),
                         ("right", right)):
            pats[key] = pat = read_pattern(grp, first, self.lex_pattern, where=key)
            consts.extend((k + q, v) for q, v in pat.consts)
            for a in pat.variables:
                if a in params:
                    t = next(t for t in pat.tokens() if a in (t.args or ()) or "*" + a in (t.args or ()))
                    raise LSystemError(f"parameter {a!r} defined twice in the rule header", ln, t.col)
                params.append(a)
            k += len(pat.names)
        body: list[tuple[int, str]] = []
        successor = condition = None
        static = delim == "-static->"
        constraints = " and ".join(f"({c})" for p in pats.values() for c in p.conds) or None
        if delim in ("-->", "->", "-static->"):
            if len(lines) > 1:
                raise LSystemError(f"a '{delim}' rule has no indented body", lines[1][0], 1)
            successor = self.lex(strip_comment(rest), ln, head_at + len(delim) + 1)
            if constraints is None:
                body.append((ln, "return __lsys_produce__(" + lstring_to_py(successor) + ")"))
            else:                                     # value constraints: L-Py's match fails, the next rule is tried
                condition = constraints
                body.append((ln, f"if {condition}: return __lsys_produce__({lstring_to_py(successor)})"))
        else:
            inline = strip_comment(rest)
            if inline.strip().startswith("@static"):      # ``pred : @static`` + block: made once (lpy_parser.cpp)
                static = True
                inline = inline.replace("@static", "", 1)
            at, arrow = find_top(inline, ("-->", "->"))
            if at >= 0:                                       # cpfg condition: pred : cond --> successor
                condition = inline[:at].strip()
                if not condition:
                    raise LSystemError("empty condition before the arrow", ln, head_at + 2)
                if constraints is not None:
                    condition = f"{constraints} and ({condition})"
                if len(lines) > 1:
                    raise LSystemError("a conditional '-->' rule has no indented body", lines[1][0], 1)
                col = head_at + len(delim) + at + len(arrow) + 1
                successor = self.lex(inline[at + len(arrow):], ln, col)
                body.append((ln, f"if ({condition}): return __lsys_produce__({lstring_to_py(successor)})"))
            else:
                if constraints is not None:
                    body.append((ln, f"if not ({constraints}): return None"))
                    condition = constraints
                if inline.strip():
                    stripped = inline.strip()
                    if stripped.startswith("produce") and PRODUCE.match(stripped) and len(lines) == 1:
                        successor = self.lex(stripped[len("produce"):], ln, first.find("produce") + 8)
                    body.append((ln, self.translate_produce(stripped, ln, in_rule=True,
                                                            col0=head_at + len(delim) + inline.find(stripped[0]))))
                block = [(k, s) for k, s in lines[1:]]
                if block:
                    indent = min(len(s) - len(s.lstrip()) for _, s in block if s.strip())
                    for k, s in block:
                        body.append((k, self.translate_produce(s[indent:], k, in_rule=True, col0=indent)))
        self.g.rules.append(Rule(kind, pred, left, right, newleft, newright, params, body, successor, condition,
                                 ln, 1, header.strip(), consts, preds[1:], self.group, static, pats,
                                 self.filter))

    def parse_header(self, header: str, ln: int, kind: str):
        # left < newleft << pred >> newright > right
        s = header
        pieces = {"left": "", "newleft": "", "newright": "", "right": ""}
        cols = {}
        rest, off = s, 0
        i, op = find_top(rest, ("<<", "<"), modules=True)
        while i >= 0:
            key = "newleft" if op == "<<" else "left"
            if pieces[key] or (key == "left" and pieces["newleft"]):
                raise LSystemError(f"ill-formed rule header {header.strip()!r}", ln, off + i + 1)
            pieces[key], cols[key] = rest[:i], off + 1
            off += i + len(op)
            rest = rest[i + len(op):]
            i, op = find_top(rest, ("<<", "<"), modules=True)
        i, op = find_top(rest, (">>", ">"), modules=True)
        pred_src, pred_col = rest, off + 1
        if i >= 0:
            pred_src = rest[:i]
            tail, toff = rest[i + len(op):], off + i + len(op)
            key = "newright" if op == ">>" else "right"
            j, op2 = find_top(tail, (">",), modules=True)
            if key == "newright" and j >= 0:
                pieces["newright"], cols["newright"] = tail[:j], toff + 1
                pieces["right"], cols["right"] = tail[j + 1:], toff + j + 2
            else:
                if j >= 0:
                    raise LSystemError(f"ill-formed rule header {header.strip()!r}", ln, toff + j + 1)
                pieces[key], cols[key] = tail, toff + 1
        pred_toks = self.lex_pattern(pred_src, ln, pred_col)
        if not pred_toks:
            raise LSystemError("rule without a predecessor", ln, pred_col)
        out = {}
        for key in pieces:
            toks = self.lex_pattern(pieces[key], ln, cols.get(key, 1)) if pieces[key].strip() else []
            out[key] = toks
        if kind != "production" and (out["newleft"] or out["newright"]):
            raise LSystemError(f"new contexts ('<<', '>>') in {kind} rules are not supported", ln,
                               (out["newleft"] or out["newright"])[0].col)
        for key, toks in [("pred", pred_toks)] + list(out.items()):
            for t in toks:
                if key in ("left", "newleft") and t.name == "]":     # a parent is never a bracket (L-Py)
                    raise LSystemError("']' in a left context is not supported (it never matches)", ln, t.col)
        return pred_toks, out["left"], out["right"], out["newleft"], out["newright"]


def _turtle_names() -> frozenset:
    """The turtle's module names (longest match in the lexer); empty until the turtle module exists."""
    try:
        from .turtle import LPY_UNSUPPORTED, TURTLE_MODULES
    except ImportError:                                       # pragma: no cover - built in parallel (issue 23)
        return frozenset()
    return frozenset(TURTLE_MODULES) | frozenset(LPY_UNSUPPORTED)


def parse_grammar(text: str, *, deadline: float | None = None) -> Grammar:
    """Read ``.lpy`` text into a :class:`Grammar` (see the module docstring); ``deadline`` (``time.monotonic``
    seconds) bounds the time spent lexing.

    Raises
    ------
    LSystemError
        For a layout error, an unsupported construct, a character Python cannot read (NUL, a lone surrogate) or
        the deadline passed, naming it with line and column.
    """
    if not isinstance(text, str):
        raise LSystemError(f"text must be a str, got {type(text).__name__}")
    bad = _BAD_CHAR.search(text)
    if bad is not None:
        k = bad.start()
        line = text.count("\n", 0, k) + 1
        col = k - (text.rfind("\n", 0, k) + 1) + 1
        raise LSystemError(f"character {text[k]!r} cannot be part of a grammar", line, col)
    return _Reader(text, deadline).read()


_BAD_CHAR = re.compile("[\x00\ud800-\udfff]")
