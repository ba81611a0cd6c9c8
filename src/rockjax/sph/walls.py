"""Wall particles: the generalised wall condition of Adami, Hu & Adams (2012).

Fixed wall particles take a pressure extrapolated from the fluid around them,
``p_w = (sum_f p_f W_wf + g . sum_f rho_f (x_w - x_f) W_wf) / sum_f W_wf``, and the density that the
equation of state gives for it. The fluid then sees the walls as ordinary neighbours in its
continuity and momentum sums, which keeps it out of the walls at any speed the pressure can
resist. Wall pressure is clamped at zero (walls push, never pull); a wall particle with no fluid
neighbour has zero pressure. Walls have no neighbour rows: the sums over their fluid neighbours
are transposes of the fluid rows (``transpose_sum``), numerator and denominator in one pass.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..types import Config, Kind
from .neighbours import Pairs, take, transpose_sum

__all__ = ["adami_pressure"]


def adami_pressure(pr: Pairs, p, rho, kind, gravity, h, w_fn, config: Config, *, kind_j=None):
    """Extrapolated wall pressure.

    Args:
        pr: pair geometry of the fluid rows; p, rho: [N] pressures Pa and densities kg/m^3;
        kind: [N]; gravity: [3] m/s^2 (walls are at rest, so g - a_w = g); h: smoothing length m;
        w_fn: kernel W(r, h); kind_j: optional [n_fluid, K] ``kind[pr.idx]`` if already gathered.

    Returns:
        [N] pressures: the extrapolated value on wall particles, ``p`` elsewhere.
    """
    if config.n_wall == 0:
        return p
    nf = config.n_fluid
    n = config.n_particles
    kind_j = take(kind, pr.idx) if kind_j is None else kind_j
    use = pr.mask & (kind[:nf, None] == Kind.FLUID) & (kind_j == Kind.WALL)
    w = jnp.where(use, w_fn(pr.r, h), 0.0)
    g_d = pr.d[0] * gravity[0] + pr.d[1] * gravity[1] + pr.d[2] * gravity[2]  # g . (x_f - x_w)
    both = transpose_sum(jnp.stack([w * (p[:nf, None] - rho[:nf, None] * g_d), w], axis=-1), pr.idx, n)
    num, den = both[:, 0], both[:, 1]
    pw = jnp.where(den > 0, num / jnp.where(den > 0, den, 1.0), 0.0)
    return jnp.where(kind == Kind.WALL, jnp.maximum(pw, 0.0), p)
