"""The grammar's Python text as L-Py's parser reads it (issue 33): comments and strings skipped, triple-quoted
strings followed over lines, ``produce (...)`` statements joined over lines, the patterns of ``InLeftContext`` /
``InRightContext`` quoted (``lpy_parser.cpp``)."""
from __future__ import annotations

import re

from .lexer import LSystemError, _depths

__all__ = ["PRODUCE", "in_string", "join_produce", "open_quote", "quote_context_patterns", "strip_comment"]

#: ``produce`` / ``nproduce`` statements in rule bodies and grammar functions.
PRODUCE = re.compile(r"\b(nproduce|produce)\b")
_CONTINUED = re.compile(r"\b(?:nproduce|produce)\b|-static->|-->|->")


def strip_comment(s: str) -> str:
    """``s`` up to its first ``#`` outside strings."""
    if "#" not in s:
        return s
    j = 0
    while j < len(s):
        c = s[j]
        if c in "\"'":
            q = c
            j += 1
            while j < len(s) and s[j] != q:
                j += 2 if s[j] == "\\" else 1
            j += 1
            continue
        if c == "#":
            return s[:j]
        j += 1
    return s


_ASK = re.compile(r"\b(InLeftContext|InRightContext)\s*\(")


def quote_context_patterns(code: str) -> str:
    """``InLeftContext(A(x) B, args)`` as ``InLeftContext('A(x) B', args)``: L-Py's parser takes the first argument
    of the capitalised context tests as a pattern (``pInLeftContext``); a string literal there stays."""
    out, pos = [], 0
    for m in _ASK.finditer(code):
        if m.start() < pos or in_string(code, m.start()):
            continue
        j, depth, quote = m.end(), 0, None
        while j < len(code):
            c = code[j]
            if quote:
                quote = None if c == quote else quote
            elif c in "'\"":
                quote = c
            elif c in "([{":
                depth += 1
            elif c in ")]}" and depth:
                depth -= 1
            elif c in ",)" and not depth:
                break
            j += 1
        arg = code[m.end():j].strip()
        if arg and arg[0] not in "'\"":
            out += [code[pos:m.end()], repr(arg)]
            pos = j
    return "".join(out) + code[pos:]


def open_quote(line: str, quote: str | None) -> str | None:
    """The triple quote still open at the end of ``line`` of Python code, given the one open at its start (L-Py's
    parser skips strings while it looks for ``Axiom:`` and the other sections: ``lcode = '''Axiom: A ...'''`` is
    Python)."""
    if quote is None and "'" not in line and '"' not in line:
        return None
    j, n = 0, len(line)
    while j < n:
        if quote is not None:
            end = line.find(quote, j)
            if end < 0:
                return quote
            j, quote = end + 3, None
            continue
        c = line[j]
        if c == "#":
            return None
        if line.startswith(('"""', "'''"), j):
            quote, j = line[j:j + 3], j + 3
        elif c in "\"'":                                    # a one-line string: to its closing quote
            j += 1
            while j < n and line[j] != c:
                j += 2 if line[j] == "\\" else 1
            j += 1
        else:
            j += 1
    return quote


def join_produce(lines: list[str]) -> list[str]:
    """``lines`` with each L-string that leaves a parenthesis open at the end of its line (after ``produce`` /
    ``nproduce``, or a rule's ``-->``) made one line with the lines that close it, comments dropped, the lines it
    took left blank so the others keep their numbers (L-Py's multi-line produce and successors)."""
    out = list(lines)
    k = 0
    while k < len(out):
        line = out[k]
        if "produce" not in line and "->" not in line:
            k += 1
            continue
        code = strip_comment(line)
        m = next((m for m in _CONTINUED.finditer(code) if not in_string(code, m.start())), None)
        depth = _open_parens(code[m.end():]) if m else 0
        j = k
        while depth > 0 and j + 1 < len(out):
            j += 1
            piece = strip_comment(out[j]).strip()
            code, out[j] = code + " " + piece, ""
            depth = _open_parens(code[m.end():])
        out[k] = code if j > k else out[k]
        k = j + 1
    return out


def _open_parens(s: str) -> int:
    """How many parentheses ``s`` leaves open (0 for an unterminated string: nothing to join)."""
    try:
        return max(0, sum((c == "(") - (c == ")") for _, c, _ in _depths(s, pairs=("(", ")"))))
    except LSystemError:
        return 0


def in_string(code: str, at: int) -> bool:
    q = None
    j = 0
    while j < at:
        c = code[j]
        if q:
            if c == "\\":
                j += 1
            elif c == q:
                q = None
        elif c in "\"'":
            q = c
        j += 1
    return q is not None
