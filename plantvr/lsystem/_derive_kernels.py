"""Derivation kernels (issue 23): one parallel rewriting step of constant (non-parametric) rules as a count pass
and a fill pass over the int module ids and CSR parameters, and bracket matching for context matching.

Each numba kernel has a readable numpy/Python twin (``*_py``); tests assert equality on seeded strings.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["count_constant", "count_constant_py", "fill_constant", "fill_constant_py", "match_brackets",
           "match_brackets_py"]


@numba.njit(cache=True, nogil=True)
def count_constant(ids, arg_ptr, rule_arity, succ_ptr, succ_arg_ptr):
    """Length of the rewritten string and of its parameter array, and how many modules a rule rewrites.

    Module ``i`` (symbol ``s = ids[i]``) is rewritten when ``rule_arity[s]`` equals its parameter count; its
    successor is modules ``succ_ptr[s]:succ_ptr[s + 1]`` of the successor table, whose parameters are
    ``succ_arg_ptr[succ_ptr[s]]:succ_arg_ptr[succ_ptr[s + 1]]``. Other modules are copied.
    """
    n_out = 0
    m_out = 0
    hits = 0
    for i in range(ids.shape[0]):
        s = ids[i]
        na = arg_ptr[i + 1] - arg_ptr[i]
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
                  out_ids, out_ptr, out_args):
    """Write the rewritten string into ``out_ids``/``out_ptr``/``out_args`` (sized by :func:`count_constant`)."""
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
