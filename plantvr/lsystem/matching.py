"""Context matching: a rule's pattern bound at a module of the string, its left and right contexts found.

:class:`_Matching` (a base of :class:`~plantvr.lsystem.engine.LSystem`) binds a rule's actual parameters at a
module (pattern constants compared, multi-module predecessors read), matching contexts along the axial tree (a
left context skips lateral branches, a right context skips them unless the pattern opens one; ``ignore:`` /
``consider:``) in the current string or, for the new contexts ``<<`` / ``>>``, in the string being built. The
helpers read a module's parameters as rule code sees them. It mirrors L-Py's ``src/cpp/matching.cpp`` (and
``matching_tmpl.h``, ``consider.cpp``).
"""
from __future__ import annotations

import math

from .lexer import Token, lex
from .modules import _EMPTY, is_number
from .rules import _Compiled


class _Reversed:
    """Read-only view of a list in reverse order (the new string built backward)."""

    def __init__(self, seq: list) -> None:
        self.seq = seq

    def __len__(self) -> int:
        return len(self.seq)

    def __getitem__(self, k: int):
        return self.seq[len(self.seq) - 1 - k]


def _pyval(v):
    return int(v) if type(v) is float and v.is_integer() and abs(v) < 2 ** 53 else v


def _same(value, const) -> bool:
    """Whether a module's parameter matches a pattern constant (``==``, without raising)."""
    try:
        return bool(type(value) is type(const) or (is_number(value) and is_number(const))) and value == const
    except (TypeError, ValueError, ArithmeticError):             # e.g. an array's ambiguous truth value
        return False


def _module_vals(ptr, args, objs, i: int) -> list:
    """Parameters of module ``i`` as rule code sees them: integral floats as int, objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return [objs.get(a + q, v) if math.isnan(v) else _pyval(v) for q, v in enumerate(vals)]
    return [_pyval(v) for v in vals]


def _raw_vals(ptr, args, objs, i: int) -> tuple:
    """Parameters of module ``i`` as stored: floats, and objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return tuple(objs.get(a + q, v) if math.isnan(v) else v for q, v in enumerate(vals))
    return tuple(vals)


class _Matching:
    """Binding rules at modules (a base of :class:`~plantvr.lsystem.engine.LSystem`)."""

    def _ignore_set(self) -> tuple[frozenset, bool] | None:
        g = self._g
        if not (g.ignore or g.consider):
            return None
        src, ln, col = g.ignore or g.consider
        names = frozenset(t.name for t in lex(src, g.declared, line=ln, col=col))
        return names, bool(g.ignore)

    def _is_ignored(self, sid: int) -> bool:
        """Whether module id ``sid`` is skipped in context matching (``ignore:`` / not in ``consider:``)."""
        if self._ignored is None or sid < 2:
            return False
        names, ignore = self._ignored
        return (self._names[sid] in names) == ignore

    def _bind(self, r: _Compiled, i: int, ids, ptr, args, partner, dest, objs=_EMPTY) -> list | None:
        """Actual parameters of rule ``r`` at module ``i`` (None if a context does not match)."""
        rule = r.rule
        vals: list = []
        if rule.left:
            lv = self._left(rule.left, i - 1, _ArrSeq(ids, ptr, args, objs), partner)
            if lv is None:
                return None
            vals += lv
        if rule.newleft:
            if self._direction != 1:
                return None
            lv = self._left(rule.newleft, len(dest) - 1, _ListSeq(dest), None)
            if lv is None:
                return None
            vals += lv
        vals += _module_vals(ptr, args, objs, i)
        for j, t in enumerate(r.rest, 1):                     # multi-module predecessor: consecutive modules
            p = i + j
            if p >= len(ids) or ids[p] != self._pattern_sid(t) or ptr[p + 1] - ptr[p] != t.arity:
                return None
            vals += _module_vals(ptr, args, objs, p)
        if rule.newright:
            if self._direction != -1:
                return None
            rv = self._right(rule.newright, 0, _ListSeq(_Reversed(dest)), None)
            if rv is None:
                return None
            vals += rv
        if rule.right:
            rv = self._right(rule.right, i + 1 + len(r.rest), _ArrSeq(ids, ptr, args, objs), partner)
            if rv is None:
                return None
            vals += rv
        if r.keep is not None:                                # pattern constants: equal values only
            for k, v in r.consts:
                if not _same(vals[k], v):
                    return None
            vals = [vals[k] for k in r.keep]
        return vals

    def _pattern_sid(self, t: Token) -> int:
        return self._sid(t.name)

    def _left(self, pattern: list[Token], pos: int, seq, partner) -> list | None:
        vals: list = []
        for t in reversed(pattern):
            while pos >= 0:
                s = seq.sid(pos)
                if s == 1:                                     # ']': skip the lateral branch
                    if partner is not None:
                        pos = int(partner[pos])
                        if pos < 0:
                            return None
                    else:
                        depth = 1
                        while depth and pos > 0:
                            pos -= 1
                            depth += (seq.sid(pos) == 1) - (seq.sid(pos) == 0)
                        if depth:
                            return None
                    pos -= 1
                elif s == 0 or self._is_ignored(s):
                    pos -= 1
                else:
                    break
            if pos < 0 or seq.sid(pos) != self._pattern_sid(t) or seq.nargs(pos) != t.arity:
                return None
            vals[:0] = seq.args(pos)
            pos -= 1
        return vals

    def _right(self, pattern: list[Token], pos: int, seq, partner) -> list | None:
        vals: list = []
        n = len(seq)
        for t in pattern:
            if t.name == "]":                                  # the rest of this branch is skipped
                while pos < n and seq.sid(pos) != 1:
                    pos = self._skip_branch(seq, pos, partner) if seq.sid(pos) == 0 else pos + 1
                    if pos < 0:
                        return None
                if pos >= n:
                    return None
                pos += 1
                continue
            while pos < n:
                s = seq.sid(pos)
                if s == 0 and t.name != "[":
                    pos = self._skip_branch(seq, pos, partner)
                    if pos < 0:
                        return None
                elif s != 0 and s != 1 and self._is_ignored(s):
                    pos += 1
                else:
                    break
            if pos >= n or seq.sid(pos) != self._pattern_sid(t) or seq.nargs(pos) != t.arity:
                return None
            vals += seq.args(pos)
            pos += 1
        return vals

    @staticmethod
    def _skip_branch(seq, pos: int, partner) -> int:
        """Index after the branch opened at ``pos`` (-1 if it never closes)."""
        if partner is not None:
            p = int(partner[pos])
            return p + 1 if p >= 0 else -1
        depth, n = 0, len(seq)
        while pos < n:
            s = seq.sid(pos)
            depth += (s == 0) - (s == 1)
            pos += 1
            if depth == 0:
                return pos
        return -1


class _ArrSeq:
    """Module access on the arrays of the current string."""

    def __init__(self, ids, ptr, args, objs=_EMPTY) -> None:
        self.ids, self.ptr, self.a, self.objs = ids, ptr, args, objs

    def __len__(self) -> int:
        return len(self.ids)

    def sid(self, k: int) -> int:
        return int(self.ids[k])

    def nargs(self, k: int) -> int:
        return int(self.ptr[k + 1] - self.ptr[k])

    def args(self, k: int) -> list:
        return _module_vals(self.ptr, self.a, self.objs, k)


class _ListSeq:
    """Module access on the new string being built (a list of ``(sid, params)``)."""

    def __init__(self, seq) -> None:
        self.seq = seq

    def __len__(self) -> int:
        return len(self.seq)

    def sid(self, k: int) -> int:
        return self.seq[k][0]

    def nargs(self, k: int) -> int:
        return len(self.seq[k][1])

    def args(self, k: int) -> list:
        return [_pyval(v) for v in self.seq[k][1]]
