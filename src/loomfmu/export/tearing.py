"""The block-triangular split of an implicit model's equations (tearing).

A model solved by Newton (F(t, x, w) = 0 nonlinear in w) usually has most
of its unknowns in closed form: a composed loom's frames give their
accelerations explicitly, and only the backrest's friction moments and
accelerations form a loop.  Newton on the whole w evaluates every
equation at every iteration and works with a dense dF/dw of all of them.

:func:`tear` orders the unknowns block-lower-triangularly (a matching of
equations to unknowns, then the strong components of the dependency graph
in the order they can be computed) and, inside each block that is not
linear in its own unknowns, chooses the fewest unknowns (the *torn* ones)
such that the block's other unknowns follow from some of its equations in
closed form (those equations linear in them, with coefficients that do
not depend on them); the block's remaining equations are the residual of
the torn unknowns.  The result:

* ``pre``: the unknowns that do not depend on a torn one, in closed form
  from (t, x, u, p, q, d): evaluated once per solve;
* ``torn``: Newton's unknowns, ``res`` their residual and ``jac`` its exact
  Jacobian, functions of the torn unknowns and the ``pre`` unknowns (read
  from w, not recomputed);
* ``post``: the other unknowns, in closed form from the ``pre`` and torn
  ones.

The runtime (lf_newton.c) then iterates on the torn unknowns only.  Closed
forms divide by the coefficient of an unknown in its equation, which may
depend on the states (a mass matrix): where it vanishes the division gives
a non-finite unknown, which the runtime reports as it reports a singular
dF/dw.  Structural decisions only use the sparsity of dF/dw and whether a
coefficient depends on w; the choice is deterministic.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from graphlib import TopologicalSorter

import casadi as ca
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, maximum_bipartite_matching

#: blocks larger than this are torn whole (the search over tear sets grows
#: combinatorially); the loops of our models have 2 to 4 unknowns
MAX_SEARCH_BLOCK = 8


@dataclass
class Tearing:
    """The split of w (indices into w) and the generated expressions."""

    pre: list[int]
    torn: list[int]
    post: list[int]
    rows: list[int]          # F's rows that make the torn unknowns' residual
    pre_expr: ca.SX          # (len(pre), 1) in t, x, u, p, q, d
    res: ca.SX               # (len(torn), 1) in w[pre], w[torn], h and t, x, u, p, q, d
    jac: ca.SX               # d res / d w[torn], dense
    post_expr: ca.SX         # (len(post), 1) in w[pre], w[torn], h and t, x, u, p, q, d
    h: ca.SX                 # symbols of the hoisted subexpressions
    h_expr: ca.SX            # their values, in t, x, u, p, q, d (as pre_expr)


def _blocks(F: ca.SX, w: ca.SX) -> tuple[list[list[int]], dict[int, int]] | None:
    """The strong components of the unknowns in computation order and the
    matching (unknown -> its equation); None if dF/dw is structurally
    singular."""
    n = w.numel()
    rows, cols = ca.jacobian(F, w).sparsity().get_triplet()
    if n == 0:
        return [], {}
    incidence = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    match = maximum_bipartite_matching(incidence, perm_type="column")
    if (match < 0).any():
        return None
    eq_of = {int(match[i]): i for i in range(n)}
    dep = csr_matrix((np.ones(len(rows)), ([int(match[i]) for i in rows], cols)),
                     shape=(n, n))
    _, label = connected_components(dep, directed=True, connection="strong")
    members: dict[int, list[int]] = {}
    for j in range(n):
        members.setdefault(int(label[j]), []).append(j)
    needs: dict[int, set[int]] = {b: set() for b in members}
    for i, k in zip(rows, cols):
        a, b = int(label[match[i]]), int(label[k])
        if a != b:
            needs[a].add(b)
    order = list(TopologicalSorter(needs).static_order())
    return [members[b] for b in order], eq_of


def _linear_in(Fr: ca.SX, v: ca.SX, fixed: ca.SX) -> ca.SX | None:
    """d Fr / d v where Fr is linear in v with a structurally regular
    coefficient that depends on none of ``fixed`` (the unknowns and the
    modes: a mode may switch an equation to another unknown); else None."""
    A = ca.jacobian(Fr, v)
    if ca.depends_on(A, fixed) or ca.sprank(A.sparsity()) < v.numel():
        return None
    return A


def _solve(Fr: ca.SX, v: ca.SX, A: ca.SX) -> ca.SX:
    """v from Fr(v) = A v + Fr(0) = 0, Fr linear in v."""
    f0 = ca.substitute(Fr, v, ca.SX.zeros(v.numel()))
    if v.numel() == 1:
        return -f0 / A
    return ca.solve(A, -f0)


def _tear_block(F: ca.SX, w: ca.SX, fixed: ca.SX, block: list[int], eqs: list[int]):
    """(explicit unknowns, their equations, torn unknowns, residual equations)
    of a block not linear in its unknowns: the fewest torn unknowns."""
    n = len(block)
    if n <= MAX_SEARCH_BLOCK:
        for s in range(1, n):
            for torn in itertools.combinations(block, s):
                rest = [j for j in block if j not in torn]
                v = ca.vertcat(*[w[j] for j in rest])
                for rows in itertools.combinations(eqs, len(rest)):
                    Fr = ca.vertcat(*[F[i] for i in rows])
                    A = _linear_in(Fr, v, fixed)
                    if A is not None:
                        return rest, list(rows), list(torn), [i for i in eqs if i not in rows]
    return [], [], list(block), list(eqs)


def tear(F: ca.SX, w: ca.SX, q: ca.SX) -> Tearing | None:
    """The split of F(w) = 0 (module docstring), q: the modes; None where it
    gains nothing (every unknown torn, or dF/dw structurally singular)."""
    fixed = ca.vertcat(w, q)
    found = _blocks(F, w)
    if found is None:
        return None
    blocks, eq_of = found
    n = w.numel()
    expl: dict[int, ca.SX] = {}   # unknown -> closed form in w's other symbols
    order: list[int] = []         # explicit unknowns in computation order
    torn: list[int] = []
    res_rows: list[int] = []
    for block in blocks:
        eqs = [eq_of[j] for j in block]
        v = ca.vertcat(*[w[j] for j in block])
        Fr = ca.vertcat(*[F[i] for i in eqs])
        A = _linear_in(Fr, v, fixed)
        if A is not None:
            rest, rows, t_block, r_block = block, eqs, [], []
            sol = _solve(Fr, v, A)
        else:
            rest, rows, t_block, r_block = _tear_block(F, w, fixed, block, eqs)
            if rest:
                vr = ca.vertcat(*[w[j] for j in rest])
                Fr = ca.vertcat(*[F[i] for i in rows])
                sol = _solve(Fr, vr, _linear_in(Fr, vr, fixed))
        for k, j in enumerate(rest):
            expl[j] = sol[k]
            order.append(j)
        torn += t_block
        res_rows += r_block
    if len(torn) == n:
        return None
    tset = set(torn)
    pre, post = [], []
    full: dict[int, ca.SX] = {}     # pre unknowns: closed form without w
    inner: dict[int, ca.SX] = {}    # post unknowns: in w[pre], w[torn]
    for j in order:
        e = expl[j]
        deps = [k for k, on in enumerate(ca.which_depends(e, w, 1, False)) if on and k != j]
        if any(k in tset or k in inner for k in deps):
            post.append(j)
            subs = [k for k in deps if k in inner]
            if subs:
                e = ca.substitute(e, ca.vertcat(*[w[k] for k in subs]),
                                  ca.vertcat(*[inner[k] for k in subs]))
            inner[j] = e
        else:
            pre.append(j)
            if deps:
                e = ca.substitute(e, ca.vertcat(*[w[k] for k in deps]),
                                  ca.vertcat(*[full[k] for k in deps]))
            full[j] = e
    res = ca.vertcat(*[F[i] for i in res_rows]) if res_rows else ca.SX(0, 1)
    if post and res_rows:
        res = ca.substitute(res, ca.vertcat(*[w[k] for k in post]),
                            ca.vertcat(*[inner[k] for k in post]))
    wt = ca.vertcat(*[w[j] for j in torn]) if torn else ca.SX(0, 1)

    def column(items):
        return ca.vertcat(*items) if items else ca.SX(0, 1)

    pre_expr = column([full[j] for j in pre])
    jac = ca.densify(ca.jacobian(res, wt))
    post_expr = column([inner[j] for j in post])
    # Hoisting: the subexpressions of the residual, its Jacobian and the
    # closed forms after Newton that do not depend on the torn unknowns
    # (the states' trigonometry, the loads from outside the loop) are
    # computed once per solve with pre_expr, not at every iteration.
    parts = [res, ca.vec(jac), post_expr]
    sizes = [e.numel() for e in parts]
    h, h_expr = ca.SX(0, 1), ca.SX(0, 1)
    if torn and sum(sizes):
        others = [k for k in range(n) if k not in tset]
        fixed_part = ca.vertcat(*[v for v in ca.symvar(F)
                                  if not any(ca.is_equal(v, w[j]) for j in torn)])
        flat, hs, hx = ca.extract_parametric(ca.vertcat(*parts), fixed_part)
        if hs:
            h = ca.vertcat(*hs)
            h_expr = ca.vertcat(*hx)
            wp = [w[k] for k in others if k in full]
            if wp:
                h_expr = ca.substitute(h_expr, ca.vertcat(*wp),
                                       ca.vertcat(*[full[k] for k in others if k in full]))
            res, jvec, post_expr = ca.vertsplit(flat, list(itertools.accumulate([0] + sizes)))
            jac = ca.reshape(jvec, len(torn), len(torn))
    return Tearing(pre=pre, torn=torn, post=post, rows=res_rows, pre_expr=pre_expr,
                   res=res, jac=jac, post_expr=post_expr, h=h, h_expr=h_expr)
