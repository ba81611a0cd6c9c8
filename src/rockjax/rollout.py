"""Rollouts: ``lax.scan`` over blocks of ``rebuild_every`` steps, checkpointed for gradients.

A block is: rebuild the neighbour list (re-sorting the particles), then ``rebuild_every`` steps
with that list. ``make_rollout(config, n_blocks)`` scans ``n_blocks`` blocks. With
``checkpoint=True`` each block and each step inside it is wrapped in ``jax.checkpoint``, so
reverse mode stores one state per block plus one block's steps (memory ~ sqrt(T) when
``n_blocks ~ rebuild_every``) instead of every intermediate of every step.
Trip counts are fixed (no ``while_loop``), so ``jax.grad`` and ``jax.vmap`` go through.
"""

from __future__ import annotations

from typing import Callable, Optional

import jax

from .step import advance, refresh
from .types import Config, Params, State

__all__ = ["make_rollout", "rollout"]


def make_rollout(config: Config, n_blocks: int, *, checkpoint: bool = True,
                 observe: Optional[Callable[[State, Params], object]] = None):
    """Build ``run(state, params) -> (state, observations)``.

    Args:
        config: static configuration.
        n_blocks: number of blocks; the rollout advances ``n_blocks * config.rebuild_every`` steps.
        checkpoint: wrap blocks and steps in ``jax.checkpoint`` (for reverse-mode memory).
        observe: optional ``observe(state, params) -> pytree`` evaluated after every block; the
            results are stacked along a leading axis of length ``n_blocks`` (None if not given).
    """
    k = config.rebuild_every

    def one_step(state, params):
        return advance(state, params, config)

    if checkpoint:
        one_step = jax.checkpoint(one_step, prevent_cse=False)

    def block(state, params):
        state = refresh(state, config)
        state, _ = jax.lax.scan(lambda s, _: (one_step(s, params), None), state, None, length=k)
        return state

    if checkpoint:
        block = jax.checkpoint(block, prevent_cse=False)

    def run(state: State, params: Params):
        def body(s, _):
            s = block(s, params)
            return s, (observe(s, params) if observe is not None else None)

        return jax.lax.scan(body, state, None, length=n_blocks)

    return run


def rollout(config: Config, state: State, params: Params, n_blocks: int, *, checkpoint: bool = True,
            observe=None):
    """Functional form of ``make_rollout(config, n_blocks, ...)(state, params)``."""
    return make_rollout(config, n_blocks, checkpoint=checkpoint, observe=observe)(state, params)
