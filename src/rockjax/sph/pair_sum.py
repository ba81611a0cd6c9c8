"""Per-row sums over the neighbour list, and their reverse mode by gathers only.

A WCSPH pass computes, for every fluid row i, ``out_i = sum_k fn(i, j = idx[i, k])`` over its
listed neighbours. Reverse-mode AD of that (``Adjoint.AUTODIFF``) transposes every neighbour
gather into a scatter-add and materialises each per-pair intermediate of the pass as an
[n_fluid, K] array (about a hundred of them in a step's VJP against 15 in its forward), which
makes a step's VJP many times its forward on the CPU.

``Adjoint.PAIR_SUMS`` gives the pass a custom VJP that uses the list's symmetry instead (fluid j
is listed in row i exactly when i is listed in row j; a pair that is in one list only lies beyond
the kernel's support, where every pair term and its derivatives vanish). Given the cotangent
``ct`` of the outputs [n_fluid, ...], in one pass over the rows again:

* as the pair's i (row r = i): the VJP of ``sum_k fn(r, idx[r, k])`` with respect to r's own
  values, its positions and the parameters (cotangent ``ct_r``);
* as the pair's j (row r = j, fluid neighbours i = idx[r, k]): the VJP of ``fn(i, r)`` with respect
  to r's column values and positions, with i's cotangent ``ct_i`` gathered;
* wall (and block-particle) columns, which have no rows, over the flat (fluid, wall) pair list
  (``NeighbourList.wall_row``), with a scatter of that short list only.

Both row parts produce per-row results (no scatter, no [n, K] cotangent array written out), and
run in row blocks (``scan_rows``). Where the pair function has a hand-derived pullback
(``with_pullback``; ``sph.pullbacks``: the default momentum and continuity terms) the two ends of
each pair come from one evaluation of the quantities they share instead of two ``jax.vjp``
evaluations, in the row blocks and over the wall list alike. The forward is the same computation
either way; the custom VJP serves reverse mode only (``jax.grad``, ``jax.vjp``): ``jax.jvp``
through it raises, so forward mode needs ``Adjoint.AUTODIFF``.

Why the default (``Tuning.adjoint``, ``effective_adjoint``): where the forward runs in row blocks
(lists over 2^19 slots) a checkpointed gradient is markedly cheaper with ``PAIR_SUMS``; on smaller
lists, in one block, ``AUTODIFF`` is about as fast inside a rollout's scan (XLA runs JAX's
transposed pass faster there than alone, and this VJP's row blocks add operations) and keeps
``jax.jvp`` working (RESULTS.md "Gradients": adjoint A/B). The hand-derived pullbacks make a row
block's backward cheaper than ``jax.vjp`` from each end; the pass's reverse still costs several
forwards, since XLA:CPU writes each per-pair intermediate of a block to memory as its own loop.
The wall columns' cotangents take one scatter per quantity: one stacked [M, C] scatter is slower
(XLA fuses the stack and recomputes each column's whole expression).
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
from jax.ad_checkpoint import checkpoint_name

from ..types import Adjoint, Config, GatherForm, Kind
from .neighbours import Pairs, Rows, neighbour_kind, pairs, scan_rows, take, wall_sum
from .walls import wall_pair_geometry

__all__ = ["pair_sum", "gathered", "with_pullback", "SAVED_NAME"]

#: ``fn(ri, cj, d, params, mask, fluid_j, config) -> tuple of per-pair arrays``: ``ri`` a dict of the
#: rows' values ([R, 1] or [M]), ``cj`` a dict of the neighbours' values ([R, K] or [M]), ``d`` three
#: arrays ``x_i - x_j`` (minimum image), ``mask`` True for a real pair, ``fluid_j`` True where j is
#: fluid. Elementwise with broadcasting; each output must vanish (with its derivatives) off ``mask``.
PairFn = Callable

#: ``jax.ad_checkpoint.checkpoint_name`` of the pair sums' outputs under ``Adjoint.PAIR_SUMS``:
#: per-particle arrays that a rollout's checkpointed step saves (``rollout.make_rollout``), so that
#: recomputing the step for its VJP does not run the pair passes again (their custom VJP keeps only
#: its inputs, which are cheap to recompute).
SAVED_NAME = "rockjax_pair_sums"


def gathered(pr: Pairs, row_vals: dict, col_vals: dict, config: Config):
    """``(ri, cj)`` of a row block: the rows' ``row_vals`` [R, 1] and their neighbours' ``col_vals``
    [R, K] (``config.effective_gather``: one gather per value, or one row gather of them stacked)."""
    ri = {k: pr.rows.of(a)[:, None] for k, a in row_vals.items()}
    if config.effective_gather != GatherForm.ROWS:
        return ri, {k: take(a, pr.idx) for k, a in col_vals.items()}
    keys = list(col_vals)
    g = take(jnp.stack([col_vals[k] for k in keys], axis=1), pr.idx)  # [R, K, C]
    return ri, {k: g[..., c] for c, k in enumerate(keys)}


def _fluid_j(pr: Pairs, config: Config):
    return neighbour_kind(pr.idx, config) == Kind.FLUID


def _sums(fn, config, shared, x, row_vals, col_vals, params, nbrs, kind):
    def tile(rows: Rows, own, carry):
        pr = pairs(x, kind, nbrs.idx, config, rows=rows)
        out = fn(*gathered(pr, row_vals, col_vals, config), pr.d, params, pr.mask, _fluid_j(pr, config), config)
        return carry, tuple(jnp.sum(o, axis=1) for o in out)

    return scan_rows(tile, config.n_fluid, config.effective_row_tile, None)[1]


def _sums_fwd(fn, config, shared, x, row_vals, col_vals, params, nbrs, kind):
    out = _sums(fn, config, shared, x, row_vals, col_vals, params, nbrs, kind)
    return out, (x, row_vals, col_vals, params, nbrs, kind)


def _symmetric(pr: Pairs, own, fluid_j, pullback, col_vals, params, ct, ct_pad, config: Config):
    """Row block ``pr``'s cotangents from both ends of its pairs by the hand-derived ``pullback``
    (``sph.pullbacks``): ``(ct_params, ct_row_values [R] dict, ct_x [R, 3])``."""
    rows = pr.rows
    on = pr.mask & fluid_j
    own_v, nb_v = gathered(pr, col_vals, col_vals, config)
    g_r = tuple(rows.of(c)[:, None] for c in ct)
    g_j = tuple(jnp.where(on, take(c, pr.idx), 0.0) for c in ct_pad)
    g_p = g_r if own is None else tuple(jnp.where(own[:, None], c, 0.0) for c in g_r)
    ct_own, ct_d, ct_params = pullback(own_v, nb_v, pr.d, pr.r, params, pr.mask, fluid_j, g_r, g_j, g_p)
    ct_vals = {k: jnp.sum(jnp.broadcast_to(ct_own[k], pr.mask.shape), axis=1) if k in ct_own
               else jnp.zeros((rows.size,), col_vals[k].dtype) for k in col_vals}
    return ct_params, ct_vals, jnp.stack([jnp.sum(c, axis=1) for c in ct_d], axis=1)


def _sums_bwd(fn, config, shared, res, ct):
    x, row_vals, col_vals, params, nbrs, kind = res
    nf, n = config.n_fluid, config.n_particles
    zero = jax.tree_util.tree_map(jnp.zeros_like, params)
    ct_pad = tuple(jnp.concatenate([c, jnp.zeros((n - nf,) + c.shape[1:], c.dtype)]) for c in ct)

    pullback = getattr(fn, "symmetric_pullback", None) if shared and config.tuning.hand_pullbacks else None
    pullback = pullback(config) if pullback is not None else None

    def tile(rows: Rows, own, ct_params):
        pr = pairs(x, kind, nbrs.idx, config, rows=rows)
        d, mask, fluid_j = pr.d, pr.mask, _fluid_j(pr, config)
        if pullback is not None:  # both ends at once; row and column values are the same arrays
            ct_p, ct_vals, ct_x = _symmetric(pr, own, fluid_j, pullback, col_vals, params, ct, ct_pad, config)
            ct_row = {k: jnp.zeros((rows.size,), a.dtype) for k, a in row_vals.items()}
            return jax.tree_util.tree_map(jnp.add, ct_params, ct_p), (ct_row, ct_vals, ct_x)
        ct_r = tuple(rows.of(c) for c in ct)
        if own is not None:  # an overlapping last block: count its shared rows' parameters once
            ct_r = tuple(jnp.where(own, c, 0.0) for c in ct_r)
        ri_own, cj = gathered(pr, row_vals, col_vals, config)

        def as_i(ri, d, params):
            return tuple(jnp.sum(o, axis=1) for o in fn(ri, cj, d, params, mask, fluid_j, config))

        _, pull = jax.vjp(as_i, ri_own, d, params)
        ct_ri, ct_d_i, ct_p = pull(ct_r)
        # the same pairs seen from j = this row: i = idx (fluid only: walls have no rows, no outputs)
        on = mask & fluid_j
        cj_own, ri = gathered(pr, col_vals, row_vals, config)  # this row's column values, the neighbours' row values
        ct_i = tuple(jnp.where(on, take(c, pr.idx), 0.0) for c in ct_pad)

        def as_j(cj_own, d_ij):
            return fn(ri, cj_own, d_ij, params, on, jnp.ones_like(on), config)

        _, pull_j = jax.vjp(as_j, cj_own, tuple(-c for c in d))
        ct_cj, ct_d_j = pull_j(ct_i)
        squeeze = lambda t: jax.tree_util.tree_map(lambda a: a[:, 0], t)  # noqa: E731
        ct_x = jnp.stack([jnp.sum(ct_d_i[a], axis=1) - jnp.sum(ct_d_j[a], axis=1) for a in range(3)], axis=1)
        ct_params = jax.tree_util.tree_map(jnp.add, ct_params, ct_p)
        return ct_params, (squeeze(ct_ri), squeeze(ct_cj), ct_x)

    # when the forward runs in one block, the reverse pass runs in ``Tuning.backward_tile`` rows (its
    # per-pair derivatives stay in cache: 512 was the fastest block of a step's VJP on the CPU)
    ct_params, (ct_row, ct_col, ct_x) = scan_rows(tile, nf, config.effective_row_tile or config.tuning.backward_rows(),
                                                  zero)
    pad = lambda a: jnp.concatenate([a, jnp.zeros((n - nf,) + a.shape[1:], a.dtype)])  # noqa: E731
    ct_row = jax.tree_util.tree_map(pad, ct_row)
    ct_col = jax.tree_util.tree_map(pad, ct_col)
    ct_x = pad(ct_x)
    if n > nf:  # the wall columns, over the flat (fluid row, wall) list
        wp = wall_pair_geometry(x, nbrs, config.grid)
        row, col, valid = wp.row, wp.col, wp.valid
        ct_w = tuple(jnp.where(valid, take(c, row), 0.0) for c in ct_pad)
        if pullback is not None:  # the wall as the pair's j end: own = wall, neighbour = fluid row
            no = tuple(jnp.zeros((), ct[0].dtype) for _ in ct)
            ct_cw, ct_dw, _ = pullback({k: take(a, col) for k, a in col_vals.items()},
                                       {k: take(a, row) for k, a in col_vals.items()}, tuple(-c for c in wp.d), wp.r,
                                       params, valid, jnp.zeros_like(valid), no, ct_w, no)
            ct_cw = {k: jnp.broadcast_to(ct_cw.get(k, 0.0), valid.shape) for k in col_vals}
            ct_xw = ct_dw  # d = x_col - x_row: the wall's own position
        else:
            ri_w = {k: take(a, row) for k, a in row_vals.items()}

            def as_wall(cj_w, d_w):
                return fn(ri_w, cj_w, d_w, params, valid, jnp.zeros_like(valid), config)

            _, pull_w = jax.vjp(as_wall, {k: take(a, col) for k, a in col_vals.items()}, wp.d)
            ct_cw, ct_dw = pull_w(ct_w)
            ct_xw = tuple(-c for c in ct_dw)  # wp.d = x_row - x_col
        # a scatter per quantity: stacked into one [M, C] scatter, XLA:CPU computed every column's
        # whole expression again per column (continuity at 8.4k water: 7.2 ms against 2.6-3.5 ms)
        seg = lambda v: wall_sum(jnp.where(valid, v, 0.0), wp, config)  # noqa: E731
        ct_col = jax.tree_util.tree_map(lambda a, v: a + seg(v), ct_col, ct_cw)
        ct_x = ct_x + jnp.stack([seg(ct_xw[a]) for a in range(3)], axis=1)
    return ct_x, ct_row, ct_col, ct_params, None, None


_sums_custom = jax.custom_vjp(_sums, nondiff_argnums=(0, 1, 2))
_sums_custom.defvjp(_sums_fwd, _sums_bwd)


def pair_sum(fn: PairFn, x, row_vals: dict, col_vals: dict, params, nbrs, kind, config: Config):
    """``out_i = sum_k fn(i, idx[i, k])`` for every fluid row i: a tuple of [n_fluid] arrays.

    Args:
        fn: the pair function (``PairFn``); x: [N, 3] positions m; row_vals, col_vals: dicts of [N]
            per-particle arrays that ``fn`` reads as the row's (``ri``) and the neighbour's
            (``cj``) values; params: ``Params``; nbrs: the ``NeighbourList`` (``idx`` and, for
            ``Adjoint.PAIR_SUMS``, the flat wall pairs); kind: [N] ``Kind`` codes.
    The reverse mode is ``config.effective_adjoint``'s (module docstring); the forward is the same.
    """
    shared = all(k in col_vals and col_vals[k] is a for k, a in row_vals.items())
    if config.effective_adjoint != Adjoint.PAIR_SUMS:
        return _sums(fn, config, shared, x, row_vals, col_vals, params, nbrs, kind)
    out = _sums_custom(fn, config, shared, x, row_vals, col_vals, params, nbrs, kind)
    return tuple(checkpoint_name(o, SAVED_NAME) for o in out)


def with_pullback(factory: Callable):
    """Give a pair function a hand-derived reverse mode for both ends of a pair (``sph.pullbacks``):
    ``factory(config)`` returns the pullback, or None where it does not cover the configuration.
    ``Adjoint.PAIR_SUMS`` uses it when every row value is also passed, as the same array, as a
    column value (then the pair's two ends read the same quantities)."""
    def attach(fn):
        fn.symmetric_pullback = factory
        return fn

    return attach
