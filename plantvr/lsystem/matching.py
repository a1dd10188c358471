"""Context matching: a rule's pattern bound at a module of the string, its left and right contexts found.

:class:`_Matching` (a base of :class:`~plantvr.lsystem.engine.LSystem`) binds a rule's actual parameters at a
module (pattern constants compared, multi-module predecessors read), matching contexts along the axial tree (a
left context skips lateral branches, a right context skips them unless the pattern opens one; ``ignore:`` /
``consider:``) in the current string or, for the new contexts ``<<`` / ``>>``, in the string being built, with
L-Py's pattern modules (:mod:`plantvr.lsystem.patterns`: ``*``, ``*args``, ``x(...)``). The helpers read a module's parameters as rule code sees them. It mirrors L-Py's ``src/cpp/matching.cpp`` (and
``matching_tmpl.h``, ``consider.cpp``).
"""
from __future__ import annotations

import math

from .lexer import LSystemError, Token, lex
from .modules import _EMPTY, _module_vals, _pyval
from .nodes import FINEST, NodeModule, _Tree
from .patterns import ANY, ERB, LB, MOD, OR, RB, REP, Pattern, PatternModule, _same, read_pattern
from .rules import _Compiled


#: Pattern names that are not modules (a wildcard, a repetition).
_WILD = frozenset({"*", "any", "x", "all"})
#: L-Py's ``String matching`` option (``MatchingEngine::eStringMatchingMethod``).
AS_STRING, AS_AXIAL_TREE, AS_MULTILEVEL, AS_MULTISCALE = range(4)


class _Reversed:
    """Read-only view of a list in reverse order (the new string built backward); with ``indices``, a list of
    indices into it (bracket partners), seen in reversed coordinates too."""

    def __init__(self, seq: list, indices: bool = False) -> None:
        self.seq, self.indices = seq, indices

    def __len__(self) -> int:
        return len(self.seq)

    def __getitem__(self, k: int):
        n = len(self.seq)
        v = self.seq[n - 1 - k]
        return (n - 1 - v if v >= 0 else -1) if self.indices else v


def _raw_vals(ptr, args, objs, i: int) -> tuple:
    """Parameters of module ``i`` as stored: floats, and objects from the side-table."""
    a = int(ptr[i])
    vals = args[a:ptr[i + 1]].tolist()
    if objs:
        return tuple(objs.get(a + q, v) if math.isnan(v) else v for q, v in enumerate(vals))
    return tuple(vals)


class _Matching:
    """Binding rules at modules (a base of :class:`~plantvr.lsystem.engine.LSystem`).

    Contexts are read as L-Py's ``String matching`` option says (``matching.cpp``): as an axial tree (the
    default: lateral branches skipped), as a string (``AS_STRING``: the neighbours in string order, brackets are
    modules), as a multi-level tree (modules of other scales than the pattern module's skipped:
    ``predecessor_at_level``) or a multiscale tree (``predecessor_at_scale`` / ``next_module_at_scale`` of
    ``axialtree_manip.h``: a left context at a coarser scale is the module's complex, finer modules between are
    its components; ``module A : scale = n`` declares a module's scale, undeclared ones are the finest).
    """

    _mode = AS_AXIAL_TREE
    #: with L-Py's ``Module inheritance`` option: module id -> the ids of its base classes (transitively); a
    #: pattern module matches its own class and every class derived from it
    _bases: dict = {}
    _node_tree = None        # ((ids, filter), _Tree) of the NodeModules last bound
    _dest_partner = None     # the bracket partners of the string being built (new contexts), as it grows

    def _set_option(self, name: str, index: int) -> None:
        """``context().options.setSelection(name, index)`` of a matching option."""
        if name == "String matching":
            self._mode = index
            return
        self._bases = {}
        if index:
            for name in self._g.bases:
                todo, seen = list(self._g.bases[name]), set()
                while todo:
                    b = todo.pop()
                    if b not in seen and b != name:
                        seen.add(b)
                        todo.extend(self._g.bases.get(b, ()))
                self._bases[self._sid(name)] = frozenset(self._sid(b) for b in seen)
        if hasattr(self, "_tables"):                          # set in __initialiseContext__: before the tables
            self._tables.clear()

    def _is_a(self, sid: int, psid: int) -> bool:
        """Whether a module of id ``sid`` matches pattern module id ``psid`` (its class or, with inheritance, one
        of its bases: ``MatchingEngine::compatible_classes``)."""
        return sid == psid or (psid in self._bases.get(sid, ()) if self._bases else False)

    def _scale(self, sid: int) -> int:
        return self._scales.get(sid, FINEST)

    def _pattern_scale(self, m: PatternModule) -> int:
        return self._scales.get(self._pattern_sid(m.tok), FINEST) if m.kind == MOD else FINEST

    def _pred_other(self, seq, pos: int, partner, m: PatternModule, prev: int) -> int:
        """The module a left context's pattern module ``m`` reads at or left of ``pos`` when contexts are not
        read as an axial tree (the class docstring); ``prev`` is the scale of the module right of ``pos``."""
        if self._mode == AS_STRING:                           # previous_module: ignored ones skipped
            while pos >= 0 and self._is_ignored(seq.sid(pos)):
                pos -= 1
            return pos
        target = self._pattern_scale(m)
        p = self._parent(seq, pos, partner)
        if p < 0:
            return -1
        cur = self._scale(seq.sid(p))
        if self._mode == AS_MULTILEVEL:                      # predecessor_at_level
            while cur != target:
                p = self._parent(seq, p - 1, partner)
                if p < 0:
                    return -1
                cur = self._scale(seq.sid(p))
            return p
        if not target < prev:                                # a predecessor, not a complex: go up the complexes
            while cur < prev:
                p = self._parent(seq, p - 1, partner)
                if p < 0:
                    return -1
                cur = self._scale(seq.sid(p))
        while cur > target:                                  # skip the predecessor's components
            p = self._parent(seq, p - 1, partner)
            if p < 0:
                return -1
            cur = self._scale(seq.sid(p))
        return p if cur == target else -1

    def _next_other(self, seq, pos: int, m: PatternModule, from_prev: bool, prev: int) -> int:
        """``next_module_at_scale`` / ``next_module_at_level`` / ``next_module`` (the class docstring): the
        module right of ``pos`` (at ``pos`` itself with ``from_prev``) that pattern module ``m`` is matched
        to, ``len(seq)`` if none; ``prev`` is the scale of the module matched before when ``from_prev``."""
        n = len(seq)

        def step(p: int) -> int:
            p += 1
            while p < n and self._is_ignored(seq.sid(p)):
                p += 1
            return p

        if pos >= n:
            return n
        if from_prev:
            while pos < n and self._is_ignored(seq.sid(pos)):
                pos += 1
        else:
            prev = self._scale(seq.sid(pos))
            pos = step(pos)
        if self._mode == AS_STRING or pos >= n:
            return pos
        target = self._pattern_scale(m)
        if self._mode == AS_MULTILEVEL:
            while pos < n and self._scale(seq.sid(pos)) != target:
                pos = step(pos)
            return pos
        if not target > prev:                                # a successor, not a component: skip its components
            while pos < n and self._scale(seq.sid(pos)) > target:
                pos = step(pos)
            if pos >= n:
                return n
        cur = self._scale(seq.sid(pos))
        if cur < target:                                     # a component of the module reached: go down
            while True:
                pos = step(pos)
                if pos >= n:
                    return n
                prev, cur = cur, self._scale(seq.sid(pos))
                if not (prev < cur < target):
                    break
        return pos if cur == target else n

    def _right_other(self, mods, pos: int, seq, partner) -> tuple[list, int] | None:
        """A right context when contexts are not read as an axial tree: L-Py's ``TreeRightMatcher`` with the
        option's next element (``GetScaleSuccessor`` / ``GetLevelSuccessor`` / ``GetNext``); a lateral branch
        is skipped where a pattern module meets its ``[`` (in the tree matchings), ``]`` skips to the branch's
        end, and the position after the last module matched is returned."""
        n = len(seq)
        if pos >= n:
            return ([], pos) if not mods else None
        last_scale = self._scale(seq.sid(pos - 1)) if pos > 0 else self._here_scale
        vals: list = []
        stack: list = []
        k, last = 0, pos - 1
        it = self._next_other(seq, pos, mods[0], True, last_scale)
        while it < n and k < len(mods):
            m = mods[k]
            nextpattern = True
            s = seq.sid(it)
            if m.kind == MOD and s < 2 and self._mode != AS_STRING:
                if s == 1:
                    return None
                it = self._skip_branch(seq, it, partner) - 1          # on the branch's ']'
                if it < 0:
                    return None
                nextpattern = False
            elif m.kind in (MOD, ANY):
                v = self._module(m, seq, it)
                if v is None:
                    return None
                vals += v
            elif m.kind in (RB, ERB):
                if s != 1:
                    if m.kind == ERB or self._mode == AS_STRING:
                        return None
                    if stack:
                        stack.pop()
                    depth = 0                                # the ']' closing the branch that holds 'it'
                    while it < n and not (seq.sid(it) == 1 and depth == 0):
                        depth += (seq.sid(it) == 0) - (seq.sid(it) == 1)
                        it += 1
                    if it >= n:
                        return None
            else:                                            # '['
                if s != 0:
                    return None
                stack.append(it)
            if nextpattern:
                k += 1
            last = it
            if it < n and k < len(mods):
                it = self._next_other(seq, it, mods[k], False, 0)
        return (vals, last + 1) if k == len(mods) else None

    def _ignore_set(self, filt: tuple | None) -> tuple[frozenset, bool] | None:
        """A rule's ``ignore:`` / ``consider:`` (:attr:`Rule.filter`) as ``(module names, is_ignore)``."""
        if filt is None:
            return None
        src, ln, col, ignore = filt
        return frozenset(t.name for t in lex(src, self._g.declared, line=ln, col=col)), ignore

    def _is_ignored(self, sid: int) -> bool:
        """Whether module id ``sid`` is skipped in context matching by the filter of the rule being matched
        (``ignore:`` / not in ``consider:``)."""
        if self._ignored is None or sid < 2:
            return False
        names, ignore = self._ignored
        return (self._names[sid] in names) == ignore

    def _bind(self, r: _Compiled, i: int, ids, ptr, args, partner, dest, objs=_EMPTY) -> list | None:
        """Actual parameters of rule ``r`` at module ``i`` (None if the predecessor or a context does not match)."""
        rule = r.rule
        self._ignored = r.ignored
        if self._mode != AS_AXIAL_TREE:
            self._here_scale = self._scales.get(int(ids[i]), FINEST)
        vals: list = []
        seq = _ArrSeq(ids, ptr, args, objs) if r.more or r.contexts or r.asks else None
        leftpos = i - 1
        if rule.left:
            got = self._left_at(r.pats["left"].mods, i - 1, seq, partner)
            if got is None:
                return None
            vals += got[0]
            leftpos = got[1]
        if rule.newleft:
            if self._direction != 1:
                return None
            lv = self._left(r.pats["newleft"], len(dest) - 1, _ListSeq(dest), self._dest_partner)
            if lv is None:
                return None
            vals += lv
        if r.plain:                                           # the first module was checked by the caller
            vals += _module_vals(ptr, args, objs, i)
        if r.more:                                            # a multi-module predecessor: consecutive modules
            mods = r.pats["pred"].mods
            for j in range(1 if r.plain else 0, len(mods)):
                v = self._module(mods[j], seq, i + j) if i + j < len(ids) else None
                if v is None:
                    return None
                vals += v
        if rule.newright:
            if self._direction != -1:
                return None
            rv = self._right(r.pats["newright"], 0, _ListSeq(_Reversed(dest)), _Reversed(self._dest_partner, True)
                             if self._dest_partner is not None else None)
            if rv is None:
                return None
            vals += rv
        rightpos = i + 1 + len(r.rest)
        if rule.right:
            got = self._right_at(r.pats["right"].mods, rightpos, seq, partner)
            if got is None:
                return None
            vals += got[0]
            rightpos = got[1]
        if r.keep is not None:                                # pattern constants: equal values only
            for k, v in r.consts:
                if not _same(vals[k], v):
                    return None
            vals = [vals[k] for k in r.keep]
        self._asking = [seq, partner, leftpos, rightpos] if r.asks else None
        return vals

    def _in_context(self, pattern, args, left: bool) -> bool:
        """``InLeftContext(pattern, args)`` / ``InRightContext``: whether ``pattern`` (an L-string pattern, as a
        rule context) matches next to what the rule's match has covered so far, leftward or rightward, as L-Py's
        ``LstringMatcher::inLeftContext``: a match moves that edge past it, so calls in a row walk along the
        string, and ``args`` (a dict) receives the pattern's variables."""
        what = "InLeftContext" if left else "InRightContext"
        here = getattr(self, "_asking", None)
        if here is None:
            raise LSystemError(f"{what} is called outside a production rule's body")
        if not isinstance(pattern, str):
            raise LSystemError(f"{what} needs a pattern (an L-string), got {type(pattern).__name__}")
        if args is not None and not isinstance(args, dict):
            raise LSystemError(f"{what}'s second argument must be a dict, got {type(args).__name__}")
        pat = self._context_patterns.get(pattern) if hasattr(self, "_context_patterns") else None
        if pat is None:
            toks = lex(pattern, self._names)
            pat = read_pattern(toks, pattern, lambda src, line, col: lex(src, self._names, line=line, col=col),
                               where="left" if left else "right")
            if pat.conds:
                raise LSystemError(f"value constraints in a {what} pattern are not supported")
            self.__dict__.setdefault("_context_patterns", {})[pattern] = pat
        if any(t.name not in self._index for t in pat.tokens() if t.name not in "[]" and t.name not in _WILD):
            return False                                   # a name no module has: nothing can match
        seq, partner, lpos, rpos = here
        got = self._left_at(pat.mods, lpos, seq, partner) if left else self._right_at(pat.mods, rpos, seq, partner)
        vals = None if got is None else pat.filter(got[0])
        if vals is None:
            return False
        here[2 if left else 3] = got[1]
        if args is not None:
            args.update(zip(pat.variables, vals))
        return True

    def _pattern_sid(self, t: Token) -> int:
        return self._sid(t.name)

    def _module(self, m: PatternModule, seq, pos: int) -> list | None:
        """The values pattern module ``m`` binds at module ``pos`` of ``seq`` (None if it does not match), as
        L-Py's ``module_matching_with_star_and_valueconstraints``: one value per pattern parameter."""
        s, n = seq.sid(pos), seq.nargs(pos)
        kind = m.kind
        if m.kwds:
            if kind == MOD and not self._is_a(s, self._pattern_sid(m.tok)):
                return None
            name = self._names[s]
            return _bind_kwds(m, name, seq.args(pos), self._g.param_names.get(name, ()))
        if kind == MOD:
            if m.node:                                        # ``$A(a)``: any parameters, the module bound
                return [NodeModule(self._tree(seq), pos)] if self._is_a(s, self._pattern_sid(m.tok)) else None
            if not self._is_a(s, self._pattern_sid(m.tok)) or (n < m.nfixed if m.star else n != m.nfixed):
                return None
            a = seq.args(pos)
            return a if not m.star else a[:m.nfixed] + [a[m.nfixed:]]
        if kind == ANY:
            if (n < m.nfixed) if m.star else (m.name_var and n != m.nfixed):      # a bare '*': any module
                return None
            a = seq.args(pos)
            if not m.name_var:
                return [[self._names[s], *a]] if m.star else []
            return [self._names[s], *a] if not m.star else [self._names[s], *a[:m.nfixed], a[m.nfixed:]]
        return [] if s == kind - LB else None                 # a bracket: '[' is id 0, ']' id 1

    def _tree(self, seq) -> _Tree:
        """The tree :class:`~plantvr.lsystem.nodes.NodeModule` s of the current string walk, with the rule's
        ignore filter (one per string and filter)."""
        key = (seq.ids, self._ignored)
        if self._node_tree is None or self._node_tree[0][0] is not key[0] or self._node_tree[0][1] != key[1]:
            self._node_tree = (key, _Tree(seq.ids, seq.ptr, seq.a, seq.objs, self._names, self._scales,
                                          self._ignored, self._g.param_names))
        return self._node_tree[1]

    def _parent(self, seq, pos: int, partner) -> int:
        """Index of the module at or left of ``pos`` a left context reads (lateral branches, brackets and ignored
        modules skipped, as L-Py's ``parent``); -1 if there is none."""
        while pos >= 0:
            s = seq.sid(pos)
            if s == 1:                                         # ']': skip the lateral branch
                if partner is not None:
                    pos = int(partner[pos])
                    if pos < 0:
                        return -1
                else:
                    depth = 1
                    while depth and pos > 0:
                        pos -= 1
                        depth += (seq.sid(pos) == 1) - (seq.sid(pos) == 0)
                    if depth:
                        return -1
                pos -= 1
            elif s == 0 or self._is_ignored(s):
                pos -= 1
            else:
                break
        return pos

    def _left(self, pattern: Pattern, pos: int, seq, partner) -> list | None:
        got = self._left_at(pattern.mods, pos, seq, partner)
        return None if got is None else got[0]

    def _left_at(self, mods, pos: int, seq, partner) -> tuple[list, int] | None:
        """Values of pattern modules ``mods`` matched leftward from ``pos`` (L-Py's ``TreeLeftMatcher``), and the
        position left of the last one matched."""
        vals: list = []
        for m in reversed(mods):
            if m.kind in (REP, OR) and self._mode != AS_AXIAL_TREE:
                raise _repetition_refused(m)
            if m.kind in (REP, OR):
                got = (self._repeat if m.kind == REP else self._either)(m, pos, seq, partner, self._left_at, False)
                if got is None:
                    return None
                vals[:0] = got[0]
                pos = got[1]
                continue
            if m.kind == LB:                                   # the module just before, ignored ones skipped
                while pos >= 0 and self._is_ignored(seq.sid(pos)):
                    pos -= 1
            elif self._mode == AS_AXIAL_TREE:
                pos = self._parent(seq, pos, partner)
            else:
                prev = self._scale(seq.sid(pos + 1)) if 0 <= pos + 1 < len(seq) else self._here_scale
                pos = self._pred_other(seq, pos, partner, m, prev)
            if pos < 0:
                return None
            v = self._module(m, seq, pos)
            if v is None:
                return None
            vals[:0] = v
            pos -= 1
        return vals, pos

    def _repeat(self, m: PatternModule, pos: int, seq, partner, step, forward: bool) -> tuple[list, int] | None:
        """A repetition ``x(pattern, lo, hi)`` matched greedily from ``pos`` with ``step`` (``_left_at`` or
        ``_right_at``): each variable's list of values in string order, and the position after it (L-Py's
        ``RegExpMatcher``); None if it matched fewer than ``lo`` times."""
        sub = m.sub
        lists: list = [[] for _ in sub.variables]
        count = 0
        while count < m.hi:
            got = step(sub.mods, pos, seq, partner)
            v = None if got is None else sub.filter(got[0])
            if v is None or got[1] == pos:                    # no further match (or one of no module: stop)
                break
            for lst, x in zip(lists, v):
                lst.append(x) if forward else lst.insert(0, x)
            pos = got[1]
            count += 1
        return (lists, pos) if count >= m.lo else None

    def _either(self, m: PatternModule, pos: int, seq, partner, step, forward: bool) -> tuple[list, int] | None:
        """An alternative ``or(p1, p2, ...)`` matched from ``pos`` with ``step``: the values of the first
        alternative that matches, None for the others' variables (L-Py's ``RegExpMatcher``)."""
        for k, alt in enumerate(m.alts):
            got = step(alt.mods, pos, seq, partner)
            v = None if got is None else alt.filter(got[0])
            if v is not None:
                before = sum(len(a.variables) for a in m.alts[:k])
                after = sum(len(a.variables) for a in m.alts[k + 1:])
                return [None] * before + v + [None] * after, got[1]
        return None

    def _right(self, pattern: Pattern, pos: int, seq, partner) -> list | None:
        got = self._right_at(pattern.mods, pos, seq, partner)
        return None if got is None else got[0]

    def _right_at(self, mods, pos: int, seq, partner) -> tuple[list, int] | None:
        """Values of pattern modules ``mods`` matched rightward from ``pos`` (L-Py's ``TreeRightMatcher``: a
        lateral branch is skipped unless the pattern opens one, ``*`` matches the next module, bracket or not),
        and the position after the last one matched. As L-Py, a context starting at the string's end matches
        repetitions of nothing only, and one reaching it with pattern modules left fails. ``]`` skips the rest of
        the branch, ``=]`` needs it to close at once (``matching_tmpl.h``: ``isExactRightBracket``)."""
        if self._mode != AS_AXIAL_TREE:
            for m in mods:
                if m.kind in (REP, OR):
                    raise _repetition_refused(m)
            return self._right_other(mods, pos, seq, partner)
        vals: list = []
        n = len(seq)
        at_end = pos >= n
        for m in mods:
            kind = m.kind
            if pos >= n and not (at_end and kind in (REP, OR)):
                return None
            if kind in (REP, OR):
                got = (self._repeat if kind == REP else self._either)(m, pos, seq, partner, self._right_at, True)
                if got is None:
                    return None
                vals += got[0]
                pos = got[1]
                continue
            if kind == RB:                                     # the rest of this branch is skipped
                while pos < n and seq.sid(pos) != 1:
                    pos = self._skip_branch(seq, pos, partner) if seq.sid(pos) == 0 else pos + 1
                    if pos < 0:
                        return None
                if pos >= n:
                    return None
                pos += 1
                continue
            if kind == ERB:                                    # '=]': the next module (ignored ones skipped) is ']'
                while pos < n and seq.sid(pos) > 1 and self._is_ignored(seq.sid(pos)):
                    pos += 1
                if pos >= n or seq.sid(pos) != 1:
                    return None
                pos += 1
                continue
            while pos < n:
                s = seq.sid(pos)
                if s == 0 and kind == MOD:
                    pos = self._skip_branch(seq, pos, partner)
                    if pos < 0:
                        return None
                elif s != 0 and s != 1 and self._is_ignored(s):
                    pos += 1
                else:
                    break
            v = self._module(m, seq, pos) if pos < n else None
            if v is None:
                return None
            vals += v
            pos += 1
        return vals, pos

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


def _bind_kwds(m: PatternModule, name: str, vals: list, pnames: tuple) -> list | None:
    """The values a pattern module ending in ``**kwds`` binds on module ``name(*vals)`` whose declaration names
    ``pnames``, or None: L-Py's ``module_matching_with_star`` (``matching.cpp``). The named parameters are the
    last ``len(pnames)`` values (``ParamModule::getNamedParameters``); ``*args`` before ``**kwds`` takes the
    values between the positional and the named ones; without it no value may be left over; a ``*`` pattern's
    dict holds the module's ``name`` unless a variable binds it."""
    n, k = len(vals), len(pnames)
    first = max(0, n - k)

    def named(start: int = 0) -> dict:
        return {p: vals[first + i] for i, p in enumerate(pnames) if i >= start and first + i < n}

    wild = m.kind == ANY
    if m.nfixed == 0 and not m.star and not m.name_var:            # (**kwds)
        return None if k != n else [({"name": name} if wild else {}) | named()]
    if m.star and m.nfixed == 0 and not m.name_var:                # (*args, **kwds)
        return None if k > n else [vals[:n - k], ({"name": name} if wild else {}) | named()]
    normal = m.nfixed
    if normal > n:
        return None
    out = ([name] if wild else []) + vals[:normal]
    if m.star:
        last = max(normal, n - k)
        out.append(vals[normal:last])
    elif k + normal < n:
        return None
    out.append(named(max(0, normal - first)))
    return out


def _repetition_refused(m: PatternModule) -> LSystemError:
    return LSystemError(f"{'repetition patterns x' if m.kind == REP else 'alternatives or'}(...) are matched in "
                        "axial-tree string matching only (L-Py: 'Multiscale context and Regular Expression not "
                        "compatible')", m.tok.line, m.tok.col)


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
