"""Rollouts: ``lax.scan`` over blocks of ``rebuild_every`` steps, checkpointed for gradients.

This module owns the differentiable time loop. A *block* is: rebuild the neighbour list
(re-sorting the particles; built under ``stop_gradient`` in ``sph.neighbours``), then
``config.rebuild_every`` steps with that list. ``make_rollout(config, n_blocks)`` advances
``n_blocks`` blocks, i.e. ``n_blocks * config.rebuild_every`` steps. Trip counts are fixed
(``lax.scan`` only, no ``while_loop``), so ``jax.grad``, ``jax.jvp`` and ``jax.vmap`` go through
(``jax.jvp`` where the WCSPH pair sums use ``Adjoint.AUTODIFF``: ``Config.effective_adjoint``).

Displacement-triggered rebuilds (``rebuild_on_displacement=True``, the default): before each step
of a block the list is also rebuilt (``lax.cond``) when the positions that step will produce,
``x + dt (v + dt/2 a)`` (exact for the fluid's kick-drift), would move any particle more than
``skin / 2`` from where the list was built (``needs_rebuild``). So a list is never used stale,
``rebuild_every`` becomes the longest a list is kept, and a small skin (fewer neighbour slots) can
be run with long blocks: the list is rebuilt only as often as the flow requires. Under ``jax.vmap``
the ``cond`` becomes a select that evaluates the rebuild every step (correct, but slow): vmapped
ensembles should pass ``rebuild_on_displacement=False`` with a skin that covers ``rebuild_every``
steps (``ensembles.ensemble`` maps members one at a time on the CPU, where the ``cond`` stays one).
A small skin with long blocks and the trigger is faster than a wide skin on a fixed short schedule,
both at rest and in a developed flow (RESULTS.md "WCSPH settings A/B", "Verlet skin").

Memory of reverse mode (``checkpoint=True``). By default two nested levels under ``jax.checkpoint``:

* outer scan over ``n_blocks // chunk`` *chunks* (it stores one State per chunk);
* a chunk (``chunk`` blocks of ``rebuild_every`` steps) is recomputed in the backward pass and
  stores one State per step (the steps are checkpointed), and each step is recomputed once more
  for its own vector-Jacobian product.

So reverse mode holds about ``n_blocks / chunk + chunk * rebuild_every`` States plus one step's
intermediates, at the price of two extra forward passes (the chunk's and the step's). The default
``chunk`` is ``ceil(sqrt(n_blocks))``, which makes the memory grow like ``sqrt(T)`` in the number of
steps T (``experiments/bench_grad.py`` measures it). ``checkpoint_levels`` chooses the nesting:
1 = chunks only (a chunk's steps keep their intermediates for the backward pass), 2 = chunks and
steps (the default), 3 = chunks, blocks and steps (one State per block of the live chunk instead
of one per step, for one more forward pass). Two levels are the default: a step's intermediates
are tens of MB of [n, K] pair arrays, which cost more to write and read back than to recompute,
so one level is both slower and far larger on the CPU (RESULTS.md "Gradients": checkpoint levels).
Under ``Adjoint.PAIR_SUMS`` a checkpointed step saves the outputs of its two pair passes
(per-particle arrays, ``sph.pair_sum.SAVED_NAME``; checkpoint policy ``save_only_these_names``):
the recomputation of the step for its VJP then skips the pair passes, whose custom VJP needs only
their inputs: a gradient a few per cent cheaper at the same memory (``Tuning(save_pair_sums=False)``
turns it off for A/B timings; RESULTS.md "Gradients").
``checkpoint=False`` is a plain scan of blocks (the host driver's forward-only path; no memory
saving, nothing recomputed).
"""

from __future__ import annotations

import math
from typing import Callable, Optional

import jax
import jax.numpy as jnp

from .sph.pair_sum import SAVED_NAME
from .step import advance, max_displacement2, refresh
from .types import Adjoint, Config, Kind, Params, State

__all__ = ["make_rollout", "rollout", "n_blocks_for", "default_chunk", "needs_rebuild", "scheduled_step"]

def needs_rebuild(state: State, config: Config) -> jax.Array:
    """Whether the next step would move a particle more than ``skin / 2`` from the list's build
    positions (bool scalar; no gradient). Predicts ``x + dt (v + dt/2 a)`` for every particle
    (the fluid's own ``x`` for a scheme whose sums use the step's start, ``FluidScheme.sums_at_start``:
    the blocks move first in a step, so their particles are predicted either way) (the fluid's
    drift exactly; walls at rest do not move; block-carried particles approximately, which
    ``step.check`` still guards with ``Status.NEIGHBOUR_STALE``)."""
    if not config.has_particles or state.nbrs is None:
        return jnp.zeros((), bool)
    P = jax.lax.stop_gradient(state.particles)
    dt = config.dt
    pred = P.x + dt * (P.v + (0.5 * dt) * P.a)
    if config.scheme.sums_at_start:  # the fluid's sums use these positions: the list must hold for them
        pred = jnp.where((P.kind == Kind.FLUID)[:, None], P.x, pred)
    return max_displacement2(pred, state.nbrs.x_ref, P.kind != Kind.PAD, config) > (0.5 * config.skin) ** 2


def n_blocks_for(config: Config, n_steps: int) -> int:
    """Number of blocks that make ``n_steps`` steps; ``n_steps`` must be a positive multiple of
    ``config.rebuild_every`` (ValueError otherwise)."""
    k = config.rebuild_every
    if int(n_steps) != n_steps or n_steps < 1:
        raise ValueError(f"n_steps must be a positive integer (got {n_steps})")
    if n_steps % k:
        raise ValueError(f"n_steps ({n_steps}) must be a multiple of Config.rebuild_every ({k}); "
                         f"use {k * max(1, round(n_steps / k))}")
    return int(n_steps) // k


def default_chunk(n_blocks: int) -> int:
    """Blocks per checkpointed chunk for a rollout of ``n_blocks`` blocks: ``ceil(sqrt(n_blocks))``."""
    return max(1, math.ceil(math.sqrt(n_blocks)))


def _step_in_block(config: Config, rebuild_on_displacement: bool):
    """``advance`` preceded, when the displacement trigger fires, by a list rebuild."""

    def one_step(state, params):
        if rebuild_on_displacement and config.has_particles:
            state = jax.lax.cond(needs_rebuild(state, config), lambda s: refresh(s, config), lambda s: s, state)
        return advance(state, params, config)

    return one_step


def scheduled_step(config: Config, *, rebuild_on_displacement: bool = True, period: Optional[int] = None):
    """``step(state, params)``: one step with the rollout's rebuild rule, keyed to the step counter.

    The list is rebuilt when ``state.step`` is a multiple of ``period`` (default
    ``config.rebuild_every``) or, with ``rebuild_on_displacement``, when ``needs_rebuild``; then
    ``advance``. With the default period and a state whose counter started at a block boundary
    (rollouts start at 0) it takes exactly the steps ``make_rollout`` takes. The host driver scans
    it between output frames (any number of steps, with a longer ``period``: the displacement
    trigger keeps the list valid, the period only bounds how long particles go un-sorted).
    """
    inner = _step_in_block(config, rebuild_on_displacement)
    period = config.rebuild_every if period is None else int(period)
    if period < 1:
        raise ValueError(f"scheduled_step: period must be >= 1 (got {period})")

    def step(state, params):
        if config.has_particles:
            state = jax.lax.cond(state.step % period == 0, lambda s: refresh(s, config), lambda s: s, state)
        return inner(state, params)

    return step


def make_rollout(config: Config, n_blocks: int, *, checkpoint: bool = True,
                 observe: Optional[Callable[[State, Params], object]] = None, chunk: Optional[int] = None,
                 rebuild_on_displacement: bool = True, checkpoint_levels: int = 2, tuning=None):
    """Build ``run(state, params) -> (state, observations)``.

    Args:
        config: static configuration.
        n_blocks: number of blocks; the rollout advances ``n_blocks * config.rebuild_every`` steps.
        checkpoint: wrap chunks, blocks and steps in ``jax.checkpoint`` (reverse-mode memory
            ~ sqrt(T), see the module docstring). Use False for forward-only runs.
        observe: optional ``observe(state, params) -> pytree`` evaluated after every block; the
            results are stacked along a leading axis of length ``n_blocks`` (None if not given).
        chunk: blocks per checkpointed chunk (``checkpoint=True`` only); default
            ``default_chunk(n_blocks)``. If it does not divide ``n_blocks`` the remainder runs as
            one shorter chunk at the end.
        rebuild_on_displacement: also rebuild within a block when ``needs_rebuild`` (module
            docstring); False gives the plain fixed schedule (one rebuild per block).
        checkpoint_levels: with ``checkpoint``, how many nested levels are checkpointed: 1 = chunks
            only (each chunk's steps store their intermediates in the backward pass: most memory,
            fewest recomputations), 2 = chunks and steps (the default), 3 = chunks, blocks and
            steps (least memory, one more forward pass). Module docstring.
        tuning: speed settings (``rockjax.Tuning``) replacing ``config.tuning``, or None.

    Returns:
        ``run(state, params)`` returning ``(final State, observations or None)``.
    """
    n_blocks = int(n_blocks)
    if tuning is not None:
        config = config.replace(tuning=tuning)
    if checkpoint_levels not in (1, 2, 3):
        raise ValueError(f"make_rollout: checkpoint_levels must be 1, 2 or 3 (got {checkpoint_levels!r})")
    if n_blocks < 1:
        raise ValueError(f"make_rollout: n_blocks must be >= 1 (got {n_blocks})")
    k = config.rebuild_every

    one_step = _step_in_block(config, rebuild_on_displacement)
    if checkpoint and checkpoint_levels >= 2:
        policy = None
        if config.tuning.save_pair_sums and config.effective_adjoint == Adjoint.PAIR_SUMS:
            policy = jax.checkpoint_policies.save_only_these_names(SAVED_NAME)
        one_step = jax.checkpoint(one_step, prevent_cse=False, policy=policy)

    def block(state, params):
        state = refresh(state, config)
        state, _ = jax.lax.scan(lambda s, _: (one_step(s, params), None), state, None, length=k)
        return state

    if checkpoint and checkpoint_levels == 3:
        block = jax.checkpoint(block, prevent_cse=False)

    def scan_blocks(state, params, length):
        def body(s, _):
            s = block(s, params)
            return s, (observe(s, params) if observe is not None else None)

        return jax.lax.scan(body, state, None, length=length)

    if not checkpoint:
        def run(state: State, params: Params):
            return scan_blocks(state, params, n_blocks)

        return run

    c = default_chunk(n_blocks) if chunk is None else int(chunk)
    if c < 1:
        raise ValueError(f"make_rollout: chunk must be >= 1 (got {chunk})")
    c = min(c, n_blocks)
    n_outer, rem = divmod(n_blocks, c)

    def chunk_fn(length):
        return jax.checkpoint(lambda s, p: scan_blocks(s, p, length), prevent_cse=False)

    full = chunk_fn(c)
    tail = chunk_fn(rem) if rem else None

    def run(state: State, params: Params):
        state, obs = jax.lax.scan(lambda s, _: full(s, params), state, None, length=n_outer)
        if observe is not None:
            obs = jax.tree_util.tree_map(lambda a: a.reshape((n_outer * c,) + a.shape[2:]), obs)
        if tail is not None:
            state, obs_t = tail(state, params)
            if observe is not None:
                obs = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b]), obs, obs_t)
        return state, obs

    return run


def rollout(config: Config, state: State, params: Params, n_blocks: int, *, checkpoint: bool = True,
            observe=None, chunk: Optional[int] = None, rebuild_on_displacement: bool = True,
            checkpoint_levels: int = 2, tuning=None):
    """Functional form of ``make_rollout(config, n_blocks, ...)(state, params)``; concrete
    ``params`` are checked on the host first (``scenes.check_param_values``: a ValueError naming
    the field, before anything is compiled)."""
    from .scenes.base import check_param_values

    check_param_values(params)
    return make_rollout(config, n_blocks, checkpoint=checkpoint, observe=observe, chunk=chunk,
                        rebuild_on_displacement=rebuild_on_displacement,
                        checkpoint_levels=checkpoint_levels, tuning=tuning)(state, params)
