"""One rewriting of a string by the active rules: production steps, decomposition and homomorphism passes.

:class:`_Rewriting` (a base of :class:`~plantvr.lsystem.engine.LSystem`) rewrites a string with the rules of
one kind, fastest path first: the constant numba kernels (``_derive_kernels``), modules grouped by predecessor
with vectorised rules on parameter columns, or module by module in string order where new contexts need it;
decomposition and homomorphism up to their maximum depth (with contexts, L-Py's recursion); the cut ``%``; and
the query pass answering request modules (``?P``...) with the turtle's frames. It mirrors L-Py's
``Lsystem::__step``, ``__stepWithMatching`` and ``__recursiveSteps`` (``src/cpp/lsystem.cpp``).
"""
from __future__ import annotations

import itertools
import math
import operator
import time

import numpy as np

from . import _derive_kernels as K
from .lexer import LSystemError
from .matching import _raw_vals
from .modules import ModuleString, is_number
from .patterns import ANY
from .rules import _Compiled

_WARM_TURTLE: list = []


def _answer(kind: str, frame: np.ndarray, old: tuple) -> tuple:
    """The parameters of a request module of ``kind`` (:data:`~plantvr.lsystem.turtle.QUERY_MODULES`) that had
    ``old``, answered with the turtle's ``frame`` (position, H, L, U; see :meth:`LSystem._query`)."""
    from .plantgl import Vector3
    p, h, left, u = (Vector3(*v) for v in frame.tolist())
    if kind == "F":
        return (p, h, u, left) + old[4:]
    v = {"P": p, "H": h, "U": u, "L": left, "R": -left}[kind]
    if len(old) == 1 and is_number(old[0]):
        return (v[0],)
    if len(old) < 2:
        return (v,)
    return tuple(v[:len(old)]) + old[3:]


def _py_column(col: np.ndarray) -> list:
    """A parameter column as rule code sees it (:func:`~plantvr.lsystem.matching._module_vals`): integral
    floats below 2**53 as int, the others as float."""
    whole = (col == np.trunc(col)) & (np.abs(col) < 2 ** 53)
    if whole.all():
        return col.astype(np.int64).tolist()
    out = col.tolist()
    for k in np.flatnonzero(whole).tolist():
        out[k] = int(out[k])
    return out


#: Types of successor parameters the batch plan stores as floats directly (the others go through ``_params``).
_NUMBERS = frozenset({float, int, np.float64, np.int64})
_NONES = itertools.repeat(None)


def _link_brackets(dest: list, at: int, partner: list, opens: list, opener: int) -> None:
    """Extend ``partner`` (the index of each bracket's partner in ``dest``, -1 elsewhere) over ``dest[at:]``;
    ``opener`` is the id that opens a branch in ``dest``'s order ('[' forward, ']' when built backward)."""
    for k in range(at, len(dest)):
        s = dest[k][0]
        partner.append(-1)
        if s == opener:
            opens.append(k)
        elif s == 1 - opener and opens:
            j = opens.pop()
            partner[j], partner[k] = k, j


def _pack(mods: list) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """``[(sid, values), ...]`` (values floats or objects) as ids, arg_ptr, args and the object side-table."""
    ids = np.array([m[0] for m in mods], np.int32)
    ptr = np.zeros(len(mods) + 1, np.int64)
    np.cumsum([len(m[1]) for m in mods], out=ptr[1:])
    flat = [v for m in mods for v in m[1]]
    objs = {k: v for k, v in enumerate(flat) if type(v) is not float}
    if objs:
        flat = [math.nan if k in objs else v for k, v in enumerate(flat)]
    return ids, ptr, np.array(flat, np.float64), objs


class _Rewriting:
    """Rewriting strings with the active rules (a base of :class:`~plantvr.lsystem.engine.LSystem`)."""

    def _decompose(self, s: ModuleString, kind: str) -> ModuleString:
        """Decomposition or homomorphism up to its maximum depth: whole-string passes for context-free rules;
        with contexts, L-Py's recursion (``Lsystem::__recursiveSteps``): each successor is decomposed on its own,
        its contexts matched within it."""
        depth = self._max_depth[kind]
        if not self._rules[kind] or not depth:
            return s
        if any(r.contexts for r in self._rules[kind]):
            try:
                return self._recursive(s, kind, depth)[0]
            except RecursionError:
                raise LSystemError(f"{kind} nested too deeply (maximum depth {depth})", *self._where) from None
        for _ in range(depth):
            s, changed = self._rewrite(s, kind)
            if not changed:
                break
        return s

    def _recursive(self, s: ModuleString, kind: str, depth: int,
                   origin: list | None = None) -> tuple[ModuleString, bool]:
        """L-Py's recursion over ``s`` (see :meth:`_decompose`); ``origin``, when given, receives for each module
        of the result the index in ``s`` of the module it came from (L-Py's turtle id, ``turtle.setId``)."""
        by_sym, anywhere = self._by_first(self._rules[kind], True)
        s = self._cut(s)
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        partner = K.match_brackets(ids, 0, 1) if len(s) else None
        nargs = np.diff(ptr)
        idl = ids.tolist()
        out: list = []
        changed = False
        i, n = 0, len(idl)
        while i < n:
            r, res = self._first_rule(by_sym.get(idl[i], anywhere), i, True, idl, nargs, ids, ptr, args, partner,
                                      None, objs)
            if res is None:
                out.append((idl[i], _raw_vals(ptr, args, objs, i)))
            else:
                changed = True
                if depth > 1 and res:
                    sub, _ = self._recursive(self._make(*_pack(res)), kind, depth - 1)
                    out.extend((int(sub.ids[k]), _raw_vals(sub.arg_ptr, sub.args, sub.objects, k))
                               for k in range(len(sub)))
                else:
                    out.extend(res)
                if len(out) > self.max_modules:
                    self._check_size(len(out), 0, self._where[0])
            if origin is not None:
                origin.extend([i] * (len(out) - len(origin)))
            i += 1 if res is None else 1 + len(r.rest)
        return self._make(*_pack(out)), changed

    def _rewrite(self, s: ModuleString, kind: str) -> tuple[ModuleString, bool]:
        rules = self._rules[kind]
        if not rules or not len(s):
            return s, False
        s = self._cut(s)
        if self._bases or any(r.newcontexts or r.rest or not r.plain for r in rules):
            return self._sequential(s, rules)                # (inheritance: rules are found by class, one by one)
        table = None if s.objects else self._constant_table(kind)
        if table is not None:
            rule_arity, sptr, sids, saptr, sargs = table
            if rule_arity.shape[0] < len(self._names):
                self._tables.clear()
                return self._rewrite(s, kind)
            with_ptr = bool(s.args.shape[0] or sargs.shape[0])
            n_out, m_out, hits = K.count_constant(s.ids, s.arg_ptr, rule_arity, sptr, saptr, with_ptr)
            self._check_size(n_out, m_out)
            out_ids = np.empty(n_out, np.int32)
            out_ptr = np.empty(n_out + 1, np.int64) if with_ptr else np.zeros(n_out + 1, np.int64)
            out_args = np.empty(m_out, np.float64)
            K.fill_constant(s.ids, s.arg_ptr, s.args, rule_arity, sptr, sids, saptr, sargs, out_ids, out_ptr,
                            out_args, with_ptr)
            return self._make_trusted(out_ids, out_ptr, out_args), hits > 0
        return self._grouped(s, rules)

    def _cut(self, s: ModuleString) -> ModuleString:
        """``s`` without what each ``%`` (``Cut``) cuts: itself and the rest of its branch, up to the ``]`` that
        closes the branch (kept) or the end of the string, as L-Py's steps skip it (``AxialTree::endBracket``)."""
        cut = [self._index[nm] for nm in ("%", "Cut") if nm in self._index]
        at = np.flatnonzero(np.isin(s.ids, cut)) if cut else ()
        if not len(at):
            return s
        depth = np.cumsum((s.ids == 0).astype(np.int64) - (s.ids == 1))      # ids 0, 1: '[', ']'
        keep = np.ones(len(s), bool)
        end = 0
        for i in at.tolist():
            if i >= end:
                below = np.flatnonzero(depth[i:] < depth[i])
                end = i + int(below[0]) if below.size else len(s)
                keep[i:end] = False
        cnt = np.diff(s.arg_ptr)
        akeep = np.repeat(keep, cnt)
        ptr = np.zeros(int(keep.sum()) + 1, np.int64)
        np.cumsum(cnt[keep], out=ptr[1:])
        new = np.cumsum(akeep) - 1
        return self._make(s.ids[keep], ptr, s.args[akeep], {int(new[k]): v for k, v in s.objects.items() if akeep[k]})

    def _query(self, s: ModuleString) -> ModuleString:
        """L-Py's query pass (``Lsystem::__step`` when a production's pattern has a request module): ``s``
        interpreted (homomorphism, then the turtle) and each request module's parameters set to the turtle's frame
        there, as ``ParamModule::_setValues`` does: none become one Vector3, one a Vector3 (or the x coordinate if
        it is a number), two x and y, three or more x, y and z; ``?F`` gets position, heading, up and left Vector3s.
        A request module a ``%`` cuts off keeps its parameters. As L-Py's query turtle (``LsysContext::envturtle``,
        a default PlantGL ``Turtle``), it ignores the grammar's turtle options (``setAngleIncrement``...)."""
        from .turtle import QUERY_MODULES, query_frames
        qsid = [k for k, nm in enumerate(self._names) if nm in QUERY_MODULES]
        at = np.flatnonzero(np.isin(s.ids, qsid))
        if not at.size:
            return s
        hom = self._rules["homomorphism"]
        for c in hom:
            if c.query:
                raise LSystemError("request modules (?P, ...) in an interpretation rule's pattern are not "
                                   "supported when productions query them (L-Py leaves them unanswered)",
                                   c.rule.line, c.rule.col)
        if not _WARM_TURTLE:                                  # numba compiling is not the grammar's time
            _WARM_TURTLE.append(True)
            start = time.monotonic()
            query_frames(ModuleString.from_modules(["F", "?P"]))
            self._deadline += time.monotonic() - start
        t = self._drawable(self.interpret(s), "error")
        tq = np.flatnonzero(np.isin(t.ids, qsid))
        if len(tq) != len(at):
            c = next((c for c in hom if any(nm in src for _, src in c.rule.body for nm in QUERY_MODULES)), hom[0])
            raise LSystemError("interpretation rules that produce request modules (?P, ...) are not supported",
                               c.rule.line, c.rule.col)
        idx, frames = self._turtle_call(query_frames, t, {})  # L-Py's envturtle: PlantGL's defaults
        answers = {int(at[k]): _answer(QUERY_MODULES[t.names[t.ids[j]]], fr,
                                       _raw_vals(s.arg_ptr, s.args, s.objects, at[k]))
                   for k, j, fr in zip(np.searchsorted(tq, idx).tolist(), idx.tolist(), frames)}
        return self._make(*_pack([(int(sid), answers[i] if i in answers else
                                   _raw_vals(s.arg_ptr, s.args, s.objects, i)) for i, sid in enumerate(s.ids)]))

    def _grouped(self, s: ModuleString, rules: list[_Compiled]) -> tuple[ModuleString, bool]:
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        n = len(ids)
        nargs = np.diff(ptr)
        has_obj = None
        if objs:                                              # modules holding objects: the per-module path
            has_obj = np.zeros(n, bool)
            has_obj[np.searchsorted(ptr, np.fromiter(objs, np.int64, len(objs)), "right") - 1] = True
        out_len = np.ones(n, np.int64)
        assigned = np.zeros(n, bool)
        vec_chunks: list = []
        py_chunks: dict[int, list] = {}
        partner = None
        grown, room = 0, self.max_modules - n                # modules added so far, and how many may be
        by_sym: dict[int, list[_Compiled]] = {}
        for r in rules:
            by_sym.setdefault(r.sid, []).append(r)
        for sid, rlist in by_sym.items():
            pos_all = np.flatnonzero(ids == sid)
            for r in rlist:
                pos = pos_all[(nargs[pos_all] == r.arity) & ~assigned[pos_all]]
                if pos.size and r.pred_consts and (r.vec is not None or r.batch is not None):
                    ok = np.ones(pos.size, bool)              # pattern constants, on the columns
                    for q, v in r.pred_consts:
                        ok &= args[ptr[pos] + q] == float(v)
                    pos = pos[ok | (has_obj[pos] if has_obj is not None else False)]
                if not pos.size:
                    continue
                if r.vec is not None and (has_obj is None or not has_obj[pos].any()):
                    added = self._grouped_vec(r, pos, ptr, args, vec_chunks, assigned, out_len, n + grown)
                    if added is not None:
                        grown += added
                        if time.monotonic() > self._deadline:
                            raise self._over_budget(r.rule.line, 1, f" in rule {r.rule.header!r}")
                        continue
                if r.batch is not None and (has_obj is None or not has_obj[pos].any()):
                    grown += self._grouped_batch(r, pos, ptr, args, vec_chunks, py_chunks, assigned, out_len,
                                                 n + grown)
                    continue
                if (r.contexts or r.asks) and partner is None:
                    partner = K.match_brackets(ids, 0, 1)
                for i in pos.tolist():
                    vals = self._bind(r, i, ids, ptr, args, partner, None, objs)
                    if vals is None:
                        continue
                    res = self._call(r, vals)
                    if res is not None:
                        py_chunks[i] = res
                        assigned[i] = True
                        out_len[i] = len(res)
                        grown += len(res) - 1
                        if grown > room:
                            self._check_size(n + grown, 0, r.rule.line)
        if not assigned.any():
            return s, False
        if time.monotonic() > self._deadline:
            raise self._over_budget()
        starts = np.zeros(n + 1, np.int64)
        np.cumsum(out_len, out=starts[1:])
        total = int(starts[-1])
        self._check_size(total, 0)
        out_ids = np.empty(total, np.int32)
        out_na = np.empty(total, np.int64)
        keep = np.flatnonzero(~assigned)
        out_ids[starts[keep]] = ids[keep]
        out_na[starts[keep]] = nargs[keep]
        for hit, slots, values in vec_chunks:                # one fancy assignment per chunk, all slots at once
            at = starts[hit][:, None] + np.arange(len(slots))
            out_ids[at] = np.array([tsid for tsid, _ in slots], np.int32)
            out_na[at] = np.array([len(fns) for _, fns in slots], np.int64)
        for i, res in py_chunks.items():
            b = starts[i]
            for j, (tsid, vals) in enumerate(res):
                out_ids[b + j] = tsid
                out_na[b + j] = len(vals)
        out_ptr = np.zeros(total + 1, np.int64)
        np.cumsum(out_na, out=out_ptr[1:])
        self._check_size(total, int(out_ptr[-1]))
        out_args = np.empty(int(out_ptr[-1]), np.float64)
        # copied modules: their parameter ranges, moved
        cnt = nargs[keep]
        if cnt.sum():
            L = int(cnt.sum())
            offs = np.arange(L) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            out_args[np.repeat(out_ptr[starts[keep]], cnt) + offs] = args[np.repeat(ptr[keep], cnt) + offs]
        for hit, slots, values in vec_chunks:
            cols = [(j, q, col) for j, vals in enumerate(values) for q, col in enumerate(vals)]
            if cols:
                first = out_ptr[starts[hit]]                  # where each hit's successor's parameters start
                rel = np.array([int(out_ptr[starts[hit[0]] + j] - first[0]) + q for j, q, _ in cols], np.int64)
                out_args[first[:, None] + rel] = np.stack([col for _, _, col in cols], axis=1)
        out_objs: dict = {}
        for k, v in objs.items():                             # copied modules' objects, moved
            i = int(np.searchsorted(ptr, k, "right")) - 1
            if not assigned[i]:
                out_objs[int(out_ptr[starts[i]]) + k - int(ptr[i])] = v
        for i, res in py_chunks.items():
            b = starts[i]
            for j, (tsid, vals) in enumerate(res):
                a = out_ptr[b + j]
                if all(type(v) is float for v in vals):
                    out_args[a:a + len(vals)] = vals
                    continue
                for q, v in enumerate(vals):
                    if type(v) is float:
                        out_args[a + q] = v
                    else:
                        out_args[a + q] = math.nan
                        out_objs[int(a) + q] = v
        return self._make(out_ids, out_ptr, out_args, out_objs), True

    def _grouped_vec(self, r: _Compiled, pos, ptr, args, vec_chunks, assigned, out_len, size: int) -> int | None:
        """Rule ``r`` applied on parameter columns at modules ``pos``: the modules it adds (None: it cannot,
        the per-module path runs it); ``size`` is the new string's length so far, checked against the cap before
        the successors are computed."""
        cond, slots = r.vec
        cols = [args[ptr[pos] + q] for q in r.pred_vars]
        try:
            with np.errstate(all="ignore"):
                if cond is not None:
                    mask = np.broadcast_to(np.asarray(cond(*cols), bool), pos.shape)
                    hit = pos[mask]
                    cols = [c[mask] for c in cols]
                else:
                    hit = pos
                if not hit.size:
                    return 0
                added = hit.size * (len(slots) - 1)
                self._check_size(size + added, 0, r.rule.line)
                raw = [[np.asarray(f(*cols)) for f in fns] for _, fns in slots]
                if any(v.dtype == bool for vals in raw for v in vals):
                    return None                               # a bool parameter stays a bool: Python path
                values = [[np.broadcast_to(v.astype(np.float64, copy=False), hit.shape) for v in vals]
                          for vals in raw]
        except (ArithmeticError, ValueError, TypeError) as e:
            if isinstance(e, LSystemError):
                raise
            return None                                       # let Python raise the rule's own error
        if not all(np.isfinite(v).all() for vals in values for v in vals):
            return None                                       # let Python raise the rule's own error
        vec_chunks.append((hit, slots, values))
        assigned[hit] = True
        out_len[hit] = len(slots)
        return added

    def _grouped_batch(self, r: _Compiled, pos, ptr, args, vec_chunks, py_chunks, assigned, out_len,
                       size: int) -> int:
        """Rule ``r``'s batch plan (:meth:`~plantvr.lsystem.rules._Rules._batch`) at modules ``pos``, in string
        order, in chunks that grow while they take under 5 ms: the time budget is checked between chunks and the
        module cap after each. Numeric successors join ``vec_chunks`` as columns; any other value is read as
        ``_call`` reads it (``_params``), module by module. Returns the modules added."""
        slots = r.batch[1]
        cols = [_py_column(args[ptr[pos] + q]) for q in r.pred_vars] or [range(pos.size)]
        rows: list = []
        applied: list = []                                    # with a condition: whether each module's holds
        at, chunk, grow = 0, 64, len(slots) - 1
        while at < pos.size:
            if time.monotonic() > self._deadline:
                raise self._over_budget(r.rule.line, 1, f" in rule {r.rule.header!r}")
            start = time.monotonic()
            part = self._call_batch(r, [c[at:at + chunk] for c in cols])
            if r.rule.condition is None:
                rows.extend(part)
            else:
                ok = list(map(operator.is_not, part, _NONES))
                applied.extend(ok)
                rows.extend(itertools.compress(part, ok))
            self._check_size(size + len(rows) * grow, 0, r.rule.line)
            at += chunk
            if time.monotonic() - start < 0.005:
                chunk = min(2 * chunk, 1 << 14)
        if not rows:
            return 0
        hit = pos[np.array(applied, bool)] if applied else pos
        assigned[hit] = True
        table = None
        if set(map(type, itertools.chain.from_iterable(rows))) <= _NUMBERS:
            try:
                width = sum(k for _, k in slots)
                table = np.fromiter(itertools.chain.from_iterable(rows), np.float64,
                                    len(rows) * width).reshape(len(rows), width)
            except OverflowError:                             # an int too large: _params says so
                table = None
        if table is not None:
            offs = np.cumsum([0] + [k for _, k in slots])
            vec_chunks.append((hit, [(sid, [None] * k) for sid, k in slots],
                               [[table[:, o + q] for q in range(k)] for (_, k), o in zip(slots, offs)]))
            out_len[hit] = len(slots)
            return len(rows) * grow
        added, line = 0, r.rule.line
        for i, t in zip(hit.tolist(), rows):
            res, o = [], 0
            for sid, k in slots:
                name = self._names[sid]
                res.append((sid, self._params(name, t[o:o + k], line) if k else ()))
                o += k
            py_chunks[i] = res
            out_len[i] = len(res)
            added += len(res) - 1
        return added

    def _sequential(self, s: ModuleString, rules: list[_Compiled]) -> tuple[ModuleString, bool]:
        """One step in string order (forward) or reverse order (backward): new contexts see the new string."""
        ids, ptr, args, objs = s.ids, s.arg_ptr, s.args, s.objects
        n = len(ids)
        fwd = self._direction == 1
        by_sym, anywhere = self._by_first(rules, fwd)        # backward: a predecessor is found by its last module
        partner = K.match_brackets(ids, 0, 1) if any(r.contexts for r in rules) else None
        dest: list = []
        changed = False
        order = range(n) if fwd else range(n - 1, -1, -1)
        nargs = np.diff(ptr)
        idl = ids.tolist()
        skip = -1 if fwd else n          # modules up to (forward) or from (backward) skip were matched already
        news = any(r.newcontexts for r in rules)
        self._dest_partner = dpart = [] if news else None     # dest's bracket partners, kept as dest grows
        opens: list = []
        for i in order:
            if (i <= skip) if fwd else (i >= skip):
                continue
            r, res = self._first_rule(by_sym.get(idl[i], anywhere), i, fwd, idl, nargs, ids, ptr, args, partner,
                                      dest, objs)
            if res is None:
                res = [(idl[i], _raw_vals(ptr, args, objs, i))]
            else:
                changed = True
                if r.rest:
                    skip = i + len(r.rest) if fwd else i - len(r.rest)
            at = len(dest)
            dest.extend(res if self._direction == 1 else reversed(res))
            if news:
                _link_brackets(dest, at, dpart, opens, 0 if fwd else 1)
            if len(dest) > self.max_modules:
                self._check_size(len(dest), 0, self._where[0])
        self._dest_partner = None
        if self._direction != 1:
            dest.reverse()
        return self._make(*_pack(dest)), changed

    def _by_first(self, rules: list[_Compiled], fwd: bool) -> tuple[dict, list]:
        """``rules`` by the id of the module a predecessor is found at (its first module, its last backward), each
        list in file order with the rules any module may start (a ``*`` or ``*args`` there, as L-Py's
        ``RulePtrMap`` gives star rules to every module class): ``(table, those)``; a module's rules are
        ``table.get(id, those)``."""
        keys = []
        for r in rules:
            m = r.pats["pred"].mods[0 if fwd else -1]
            keys.append(self._pattern_sid(m.tok) if m.kind != ANY and not m.star else None)
        anywhere = [r for r, k in zip(rules, keys) if k is None]
        table = {k: [r for r, k2 in zip(rules, keys) if k2 in (k, None)] for k in set(keys) - {None}}
        for d, bases in self._bases.items():                 # inheritance: a derived class has its bases' rules
            table[d] = [r for r, k2 in zip(rules, keys) if k2 is None or k2 == d or k2 in bases]
        return table, anywhere

    def _first_rule(self, rules, i: int, fwd: bool, idl, nargs, ids, ptr, args, partner, dest,
                    objs) -> tuple[_Compiled | None, list | None]:
        """The first of ``rules`` (file order) whose predecessor starts (``fwd``; else ends) at module ``i``, whose
        contexts match and that produces, with its successor: ``(rule, successor)``, or ``(None, None)``."""
        for r in rules:
            at = i if fwd else i - len(r.rest)               # where the predecessor starts
            if at < 0 or (r.plain and (not self._is_a(idl[at], r.sid) or nargs[at] != r.arity)):
                continue
            vals = self._bind(r, at, ids, ptr, args, partner, dest, objs)
            if vals is None:
                continue
            res = self._call(r, vals)
            if res is not None:
                return r, res
        return None, None
