"""Derivation kernels (issue 23): one parallel rewriting step of constant (non-parametric) rules as a count pass
and a fill pass over the int module ids and CSR parameters, n steps of them at once as block copies, and bracket
matching for context matching.

Each numba kernel has a readable numpy/Python twin (``*_py``); tests assert equality on seeded strings.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["count_constant", "count_constant_py", "expand_constant", "expand_constant_py", "expand_lengths",
           "expand_lengths_py", "fill_constant", "fill_constant_py", "match_brackets",
           "match_brackets_py"]


@numba.njit(cache=True, nogil=True)
def count_constant(ids, arg_ptr, rule_arity, succ_ptr, succ_arg_ptr, with_ptr):
    """Length of the rewritten string and of its parameter array, and how many modules a rule rewrites.

    Module ``i`` (symbol ``s = ids[i]``) is rewritten when ``rule_arity[s]`` equals its parameter count; its
    successor is modules ``succ_ptr[s]:succ_ptr[s + 1]`` of the successor table, whose parameters are
    ``succ_arg_ptr[succ_ptr[s]]:succ_arg_ptr[succ_ptr[s + 1]]``. Other modules are copied. With ``with_ptr``
    False (no parameters in the string nor in the successors) ``arg_ptr`` is not read.
    """
    n_out = 0
    m_out = 0
    hits = 0
    for i in range(ids.shape[0]):
        s = ids[i]
        na = arg_ptr[i + 1] - arg_ptr[i] if with_ptr else 0
        if rule_arity[s] == na:
            hits += 1
            n_out += succ_ptr[s + 1] - succ_ptr[s]
            m_out += succ_arg_ptr[succ_ptr[s + 1]] - succ_arg_ptr[succ_ptr[s]]
        else:
            n_out += 1
            m_out += na
    return n_out, m_out, hits


@numba.njit(cache=True, nogil=True)
def fill_constant(ids, arg_ptr, args, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, succ_args,
                  out_ids, out_ptr, out_args, with_ptr):
    """Write the rewritten string into ``out_ids``/``out_ptr``/``out_args`` (sized by :func:`count_constant`).

    With ``with_ptr`` False (no parameters anywhere) only ``out_ids`` is written (``out_ptr`` stays zeros).
    """
    if not with_ptr:
        k = 0
        for i in range(ids.shape[0]):
            s = ids[i]
            if rule_arity[s] == 0:
                for j in range(succ_ptr[s], succ_ptr[s + 1]):
                    out_ids[k] = succ_ids[j]
                    k += 1
            else:
                out_ids[k] = s
                k += 1
        return
    k = 0
    m = 0
    out_ptr[0] = 0
    for i in range(ids.shape[0]):
        s = ids[i]
        a0 = arg_ptr[i]
        na = arg_ptr[i + 1] - a0
        if rule_arity[s] == na:
            for j in range(succ_ptr[s], succ_ptr[s + 1]):
                out_ids[k] = succ_ids[j]
                for q in range(succ_arg_ptr[j], succ_arg_ptr[j + 1]):
                    out_args[m] = succ_args[q]
                    m += 1
                k += 1
                out_ptr[k] = m
        else:
            out_ids[k] = s
            for q in range(na):
                out_args[m] = args[a0 + q]
                m += 1
            k += 1
            out_ptr[k] = m


def count_constant_py(ids, arg_ptr, rule_arity, succ_ptr, succ_arg_ptr):
    """numpy twin of :func:`count_constant`."""
    na = np.diff(arg_ptr)
    hit = rule_arity[ids] == na
    slen = np.diff(succ_ptr)[ids]
    sarg = (succ_arg_ptr[succ_ptr[1:]] - succ_arg_ptr[succ_ptr[:-1]])[ids]
    return int(np.where(hit, slen, 1).sum()), int(np.where(hit, sarg, na).sum()), int(hit.sum())


def fill_constant_py(ids, arg_ptr, args, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, succ_args):
    """Python twin of :func:`fill_constant`: returns ``(out_ids, out_ptr, out_args)``."""
    oid, optr, oargs = [], [0], []
    for i, s in enumerate(ids.tolist()):
        a0, a1 = arg_ptr[i], arg_ptr[i + 1]
        if rule_arity[s] == a1 - a0:
            for j in range(succ_ptr[s], succ_ptr[s + 1]):
                oid.append(succ_ids[j])
                oargs.extend(succ_args[succ_arg_ptr[j]:succ_arg_ptr[j + 1]].tolist())
                optr.append(len(oargs))
        else:
            oid.append(s)
            oargs.extend(args[a0:a1].tolist())
            optr.append(len(oargs))
    return np.array(oid, np.int32), np.array(optr, np.int64), np.array(oargs, np.float64)


@numba.njit(cache=True, nogil=True)
def match_brackets(ids, open_id, close_id):
    """Index of the partner bracket of each ``[``/``]`` (-1 elsewhere and for an unmatched bracket)."""
    n = ids.shape[0]
    partner = np.full(n, -1, np.int64)
    stack = np.empty(n, np.int64)
    top = 0
    for i in range(n):
        if ids[i] == open_id:
            stack[top] = i
            top += 1
        elif ids[i] == close_id and top > 0:
            top -= 1
            partner[i] = stack[top]
            partner[stack[top]] = i
    return partner


def match_brackets_py(ids, open_id, close_id):
    """Python twin of :func:`match_brackets`."""
    partner = np.full(len(ids), -1, np.int64)
    stack = []
    for i, s in enumerate(np.asarray(ids).tolist()):
        if s == open_id:
            stack.append(i)
        elif s == close_id and stack:
            j = stack.pop()
            partner[i], partner[j] = j, i
    return partner


# -- multi-step expansion of constant rules ------------------------------------------------------------------------
# Symbol ``s`` has a rule when ``rule_arity[s] >= 0``; successor slot ``j`` (module ``succ_ids[j]`` with the constant
# parameters ``succ_args[succ_arg_ptr[j]:succ_arg_ptr[j + 1]]``) is rewritten at the next step when its parameter
# count equals the arity of its symbol's rule. E(s, k), the expansion of a rewritten module ``s`` after ``k >= 1``
# steps, is the concatenation over its successor slots j of E(succ_ids[j], k - 1) (rewritten slots, k > 1) or the
# slot's own module (the others, or k = 1).


@numba.njit(cache=True, nogil=True)
def expand_lengths(n, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, cap):
    """Module and parameter counts of E(s, k), ``(n + 1, S)`` int64 each, saturated at ``cap``.

    Row 0 is a rewritten module itself: 1 module with ``rule_arity[s]`` parameters. Symbols without a rule keep
    ``(1, 0)`` (never read: no slot or module of theirs is rewritten).
    """
    S = rule_arity.shape[0]
    lm = np.ones((n + 1, S), np.int64)
    la = np.zeros((n + 1, S), np.int64)
    for s in range(S):
        if rule_arity[s] > 0:
            la[0, s] = rule_arity[s]
    for k in range(1, n + 1):
        for s in range(S):
            if rule_arity[s] < 0:
                continue
            m = 0
            a = 0
            for j in range(succ_ptr[s], succ_ptr[s + 1]):
                t = succ_ids[j]
                na = succ_arg_ptr[j + 1] - succ_arg_ptr[j]
                if rule_arity[t] == na:
                    m = min(m + lm[k - 1, t], cap)
                    a = min(a + la[k - 1, t], cap)
                else:
                    m = min(m + 1, cap)
                    a = min(a + na, cap)
            lm[k, s] = m
            la[k, s] = a
    return lm, la


@numba.njit(cache=True, nogil=True, inline="always")
def _put_module(out_ids, out_ptr, out_args, pm, pa, sym, src_args, a0, na, with_ptr):
    """Write module ``sym`` with parameters ``src_args[a0:a0 + na]`` at output module ``pm``, parameter ``pa``."""
    if with_ptr:
        out_ptr[pm] = pa
    out_ids[pm] = sym
    for q in range(na):
        out_args[pa + q] = src_args[a0 + q]


@numba.njit(cache=True, nogil=True, inline="always")
def _copy_block(out_ids, out_ptr, out_args, pm, pa, src_m, src_a, L, La, with_ptr):
    """Copy the block of ``L`` modules (``La`` parameters) at ``src_m``/``src_a`` to ``pm``/``pa`` (after it)."""
    d = out_ids[pm:pm + L]                                    # views: the loops vectorise
    s = out_ids[src_m:src_m + L]
    for q in range(L):
        d[q] = s[q]
    if with_ptr:
        shift = pa - src_a
        dp = out_ptr[pm:pm + L]
        sp = out_ptr[src_m:src_m + L]
        for q in range(L):
            dp[q] = sp[q] + shift
        da = out_args[pa:pa + La]
        sa = out_args[src_a:src_a + La]
        for q in range(La):
            da[q] = sa[q]


@numba.njit(cache=True, nogil=True)
def expand_constant(ids, arg_ptr, args, n, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, succ_args, lm, la,
                    out_ids, out_ptr, out_args, with_ptr):
    """Write the string after ``n >= 1`` steps of constant rules into ``out_ids``/``out_ptr``/``out_args`` (sized
    from :func:`expand_lengths`, unsaturated), each module once.

    Each block E(s, k) is built once, depth first, at its first place in the output; every later occurrence is a
    block copy of it (parameter offsets shifted). With ``with_ptr`` False (no parameters anywhere) ``out_ptr`` is
    left as it is (zeros).
    """
    S = rule_arity.shape[0]
    first_m = np.full((n + 1, S), -1, np.int64)
    first_a = np.zeros((n + 1, S), np.int64)
    st_s = np.empty(n + 1, np.int64)
    st_k = np.empty(n + 1, np.int64)
    st_j = np.empty(n + 1, np.int64)
    pm = 0
    pa = 0
    for i in range(ids.shape[0]):
        s = ids[i]
        a0 = arg_ptr[i]
        na = arg_ptr[i + 1] - a0
        if n < 1 or rule_arity[s] != na:                      # copied unchanged at every step
            _put_module(out_ids, out_ptr, out_args, pm, pa, s, args, a0, na, with_ptr)
            pm += 1
            pa += na
            continue
        if first_m[n, s] >= 0:
            _copy_block(out_ids, out_ptr, out_args, pm, pa, first_m[n, s], first_a[n, s], lm[n, s], la[n, s],
                        with_ptr)
            pm += lm[n, s]
            pa += la[n, s]
            continue
        first_m[n, s] = pm
        first_a[n, s] = pa
        top = 0
        st_s[0] = s
        st_k[0] = n
        st_j[0] = succ_ptr[s]
        while top >= 0:
            s = st_s[top]
            k = st_k[top]
            j = st_j[top]
            if j == succ_ptr[s + 1]:
                top -= 1
                continue
            st_j[top] = j + 1
            t = succ_ids[j]
            b0 = succ_arg_ptr[j]
            nb = succ_arg_ptr[j + 1] - b0
            if k == 1 or rule_arity[t] != nb:                 # the slot's own module
                _put_module(out_ids, out_ptr, out_args, pm, pa, t, succ_args, b0, nb, with_ptr)
                pm += 1
                pa += nb
            elif first_m[k - 1, t] >= 0:                       # a copy of the block built before
                _copy_block(out_ids, out_ptr, out_args, pm, pa, first_m[k - 1, t], first_a[k - 1, t],
                            lm[k - 1, t], la[k - 1, t], with_ptr)
                pm += lm[k - 1, t]
                pa += la[k - 1, t]
            else:                                             # built here, depth first
                first_m[k - 1, t] = pm
                first_a[k - 1, t] = pa
                top += 1
                st_s[top] = t
                st_k[top] = k - 1
                st_j[top] = succ_ptr[t]
    if with_ptr:
        out_ptr[pm] = pa


def expand_lengths_py(n, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, cap):
    """numpy twin of :func:`expand_lengths`: one row per level from the row below."""
    S = len(rule_arity)
    lm = np.ones((n + 1, S), np.int64)
    la = np.zeros((n + 1, S), np.int64)
    la[0] = np.maximum(rule_arity, 0)
    nslot = np.diff(succ_arg_ptr)
    rw = rule_arity[succ_ids] == nslot                        # slot rewritten at the next step
    owner = np.repeat(np.arange(S), np.diff(succ_ptr))
    has = rule_arity >= 0
    for k in range(1, n + 1):
        m = np.where(rw, lm[k - 1, succ_ids], 1)
        a = np.where(rw, la[k - 1, succ_ids], nslot)
        lm[k, has] = np.minimum(np.bincount(owner, m, S), cap).astype(np.int64)[has]
        la[k, has] = np.minimum(np.bincount(owner, a, S), cap).astype(np.int64)[has]
    return lm, la


def expand_constant_py(ids, arg_ptr, args, n, rule_arity, succ_ptr, succ_ids, succ_arg_ptr, succ_args):
    """Python twin of :func:`expand_constant`: the blocks E(s, k) as module lists, level by level; returns
    ``(out_ids, out_ptr, out_args)``."""
    def slot(j):
        return [(int(succ_ids[j]), tuple(succ_args[succ_arg_ptr[j]:succ_arg_ptr[j + 1]].tolist()))]

    def rewritten(s, na):
        return rule_arity[s] == na

    S = len(rule_arity)
    block = {s: None for s in range(S)}                       # E(s, k) of the current level k
    for k in range(1, n + 1):
        new = {}
        for s in range(S):
            if rule_arity[s] < 0:
                continue
            mods = []
            for j in range(succ_ptr[s], succ_ptr[s + 1]):
                t, nb = int(succ_ids[j]), succ_arg_ptr[j + 1] - succ_arg_ptr[j]
                mods += block[t] if k > 1 and rewritten(t, nb) else slot(j)
            new[s] = mods
        block = new
    mods = []
    for i, s in enumerate(ids.tolist()):
        a0, a1 = arg_ptr[i], arg_ptr[i + 1]
        mods += block[s] if n and rewritten(s, a1 - a0) else [(s, tuple(args[a0:a1].tolist()))]
    out_ptr = np.zeros(len(mods) + 1, np.int64)
    np.cumsum([len(v) for _, v in mods], out=out_ptr[1:])
    return (np.array([s for s, _ in mods], np.int32), out_ptr,
            np.array([x for _, v in mods for x in v], np.float64))
