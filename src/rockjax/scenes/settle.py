"""Settling a scene's water before the run: the start transient of a particle lattice removed.

Scenes are filled with water on a cubic lattice at hydrostatic density. That lattice is not the
discrete equilibrium next to sloping walls (and, at small h / dx, anywhere): in the first second it
slumps and sends small waves along a flume. A wave-flume run measures them with the paddle's waves
(``experiments/piston_transfer.py``: 2.0 mm at the paddle frequency, 4 depths down a 0.3 m deep
flume, against 34 mm waves; 0.14 mm after ``settle(scene, t_settle=3.0)``). ``settle`` runs the
scene with the blocks held and a strong artificial viscosity, then returns it with the relaxed
water, its Params unchanged and the clock at zero.
"""

from __future__ import annotations

import math
from typing import Optional

import jax.numpy as jnp

from .base import Scene

__all__ = ["settle"]


def settle(scene: Scene, *, t_settle: float, alpha: float = 1.0,
           progress: Optional[bool] = False) -> Scene:
    """Relax the water of ``scene`` for ``t_settle`` seconds and restart the clock.

    The water runs under gravity with the artificial viscosity ``alpha`` (``FluidParams.alpha``;
    1.0 damps a 0.3 m deep flume's waves with an e-folding time of ~1 s at dx = 0.03 m) and every
    block held still: PRESCRIBED blocks (the piston) with a zero stroke, FIXED blocks as they are.
    The returned scene has the settled particles (and the neighbour list, possibly regrown
    capacities), ``step = 0``, a clear status and the original Params, so its run starts from
    water at rest on the same geometry.

    Args:
        scene: a scene with water and no DYNAMIC blocks (a moving block would not be held).
        t_settle: s, how long to relax (a few sloshing periods of the water body).
        alpha: artificial viscosity during the settling (> 0).
        progress: show the driver's progress bar (None: when stderr is a terminal, as ``simulate``).
    Raises:
        ValueError: no water, DYNAMIC blocks, or a non-positive ``t_settle`` / ``alpha``.
    """
    from ..blocks import Motion
    from ..driver import simulate

    if not (isinstance(t_settle, (int, float)) and math.isfinite(t_settle) and t_settle > 0):
        raise ValueError(f"settle: t_settle must be a positive time in seconds (got {t_settle!r})")
    if not (isinstance(alpha, (int, float)) and math.isfinite(alpha) and alpha > 0):
        raise ValueError(f"settle: alpha must be a positive artificial viscosity (got {alpha!r})")
    config, params = scene.config, scene.params
    if not config.has_particles or config.n_fluid == 0:
        raise ValueError(f"settle: scene {scene.name!r} has no water to settle")
    if config.blocks is not None:
        dyn = [i for i, m in enumerate(config.blocks.motion) if m == Motion.DYNAMIC]
        if dyn:
            raise ValueError(f"settle: scene {scene.name!r} has DYNAMIC blocks {dyn}, which settle cannot hold "
                             "still; settle the water in a scene built without them (or with them FIXED)")
    held = params.replace(fluid=params.fluid.replace(alpha=jnp.asarray(alpha, params.fluid.alpha.dtype)))
    if params.blocks is not None:
        held = held.replace(blocks=params.blocks.replace(stroke=jnp.zeros_like(params.blocks.stroke)))
    res = simulate(scene.replace(params=held), t_end=float(t_settle), keep_frames=False, progress=progress)
    s = res.state
    state = s.replace(step=jnp.zeros_like(s.step), status=jnp.zeros_like(s.status))
    return scene.replace(config=res.scene.config, state=state)
