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

import dataclasses
from typing import ClassVar, NamedTuple, Optional

import jax
import jax.numpy as jnp

from ..types import Config, Kind
from .neighbours import Pairs, min_image, safe_norm, take, transpose_sum, wall_sum
from .terms import Term

__all__ = ["WallModel", "Adami", "DynamicWalls", "adami_pressure", "adami_terms", "adami_finish", "smooth_max0", "WallPairs", "wall_pair_geometry", "adami_sums"]


class WallPairs(NamedTuple):
    """Geometry of the flat (fluid row, wall) pair list (``NeighbourList.wall_row`` / ``wall_col``).

    ``row``, ``col``: [M] indices; ``d``: three [M] arrays ``x_row - x_col`` (minimum image);
    ``r``: [M] m; ``valid``: [M] True for the first ``wall_count`` slots; ``start``: [n_wall + 1]
    each wall's first slot where the list is in wall order (``NeighbourList.wall_start``; None for
    the block sub-list), read by ``neighbours.wall_sum``.
    """

    row: jax.Array
    col: jax.Array
    d: tuple
    r: jax.Array
    valid: jax.Array
    start: Optional[jax.Array] = None


def wall_pair_geometry(x, nbrs, grid, *, bodies: bool = False) -> WallPairs:
    """``WallPairs`` for positions ``x`` [N, 3] and the list ``nbrs`` (a ``NeighbourList``): its
    (fluid, wall) pairs, or with ``bodies`` its sub-list of (fluid, block particle) pairs."""
    if bodies:
        row, col, count = nbrs.body_row, nbrs.body_col, nbrs.body_count
    else:
        row, col, count = nbrs.wall_row, nbrs.wall_col, nbrs.wall_count
    d = tuple(min_image(take(x[:, a], row) - take(x[:, a], col), a, grid) for a in range(3))
    r = safe_norm(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    valid = jnp.arange(row.shape[0]) < count
    return WallPairs(row=row, col=col, d=d, r=r, valid=valid, start=None if bodies else nbrs.wall_start)


def adami_sums(wp: WallPairs, p, rho, gravity, h, w_fn, config: Config):
    """The wall sums of ``adami_terms`` over the flat pair list: [N, 2] (``adami_finish`` takes them).

    ``p``, ``rho``: [>= n_fluid] the fluid rows' pressures Pa and densities kg/m^3.
    """
    w = jnp.where(wp.valid, w_fn(wp.r, h), 0.0)
    g_d = wp.d[0] * gravity[0] + wp.d[1] * gravity[1] + wp.d[2] * gravity[2]  # g . (x_f - x_w)
    vals = jnp.stack([w * (take(p, wp.row) - take(rho, wp.row) * g_d), w], axis=-1)
    return wall_sum(vals, wp, config)


def adami_terms(pr: Pairs, p_rows, rho_rows, kind, gravity, h, w_fn, *, kind_j=None):
    """Each pair's contribution to the wall sums: [R, K, 2] ``(W (p_f - rho_f g . (x_f - x_w)), W)``.

    Args:
        pr: pair geometry of a block of fluid rows; p_rows, rho_rows: [R] the rows' pressures Pa
        and densities kg/m^3; kind: [N]; gravity: [3] m/s^2; h: smoothing length m; w_fn: kernel
        W(r, h); kind_j: optional [R, K] ``kind[pr.idx]`` if already gathered.
    Non-zero only for fluid rows and wall neighbours; summed onto the walls by ``transpose_sum``.
    """
    kind_j = take(kind, pr.idx) if kind_j is None else kind_j
    use = pr.mask & (pr.rows.of(kind)[:, None] == Kind.FLUID) & (kind_j == Kind.WALL)
    w = jnp.where(use, w_fn(pr.r, h), 0.0)
    g_d = pr.d[0] * gravity[0] + pr.d[1] * gravity[1] + pr.d[2] * gravity[2]  # g . (x_f - x_w)
    return jnp.stack([w * (p_rows[:, None] - rho_rows[:, None] * g_d), w], axis=-1)


def smooth_max0(x, width: float):
    """``max(x, 0)`` with the corner rounded over ``|x| < width`` (C2; exact beyond the band).

    Its slope is the cubic smoothstep from 0 at ``x = -width`` to 1 at ``x = width``, so the value
    is ``2 width (u^3 - u^4 / 2)`` with ``u = (x + width) / (2 width)`` inside the band (``3 width
    / 16`` at ``x = 0``). ``width = 0`` (static): the sharp ``max``.
    """
    if width <= 0:
        return jnp.maximum(x, 0.0)
    u = jnp.clip((x + width) / (2.0 * width), 0.0, 1.0)
    inside = 2.0 * width * u**3 * (1.0 - 0.5 * u)
    return jnp.where(x >= width, x, inside)


def adami_finish(sums, p, kind, config: Config):
    """Wall pressures from the summed ``adami_terms`` ``sums`` [N, 2]: [N] (``p`` off the walls).

    Negative extrapolated pressures are floored at 0 (no wall suction), the corner rounded over the
    scheme's ``Adami.floor_band`` [Pa] (``smooth_max0``; sharp for wall models without one).
    """
    num, den = sums[:, 0], sums[:, 1]
    pw = jnp.where(den > 0, num / jnp.where(den > 0, den, 1.0), 0.0)
    band = getattr(config.scheme.walls, "floor_band", 0.0)
    return jnp.where(kind == Kind.WALL, smooth_max0(pw, band), p)


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
    rows = pr.rows
    terms = adami_terms(pr, rows.of(p), rows.of(rho), kind, gravity, h, w_fn, kind_j=kind_j)
    return adami_finish(transpose_sum(terms, pr.idx, config.n_particles), p, kind, config)


class WallModel(Term):
    """How fixed wall particles get their pressure and density (a scheme's ``walls``).

    ``dynamic``: the walls evolve their density by the continuity equation like the fluid and take
    the equation of state's pressure (dynamic boundary particles); otherwise the pressure is
    extrapolated from the fluid (Adami et al. 2012) and the density follows from it.
    ``mirrors_velocity``: the viscous terms see the walls at a velocity of their own
    (``viscous_velocity``) instead of the particles' velocities.
    """

    family = "walls"
    dynamic: ClassVar[bool] = False

    @property
    def mirrors_velocity(self) -> bool:
        return False

    def viscous_velocity(self, v, kind, wp: WallPairs, params, config):
        """Velocities [N, 3] m/s the momentum pass uses for the particles (``v`` unless the walls
        mirror it); ``wp`` the flat (fluid, wall) pairs at the pass's positions."""
        return v


@dataclasses.dataclass(frozen=True)
class Adami(WallModel):
    """The generalised wall condition of Adami, Hu & Adams (2012) (module docstring; the default).

    ``no_slip``: also their no-slip condition (Adami et al. 2012, Eq 22-23): in the momentum pass a
    wall particle moves at ``2 v_w - v~_w``, ``v~_w = sum_f v_f W_wf / sum_f W_wf`` the fluid's
    velocity extrapolated to it, so the viscous terms see a velocity field that vanishes (relative
    to the wall) on the wall surface rather than on the wall particles, and a laminar channel flow
    converges at second order instead of first (``tests/physics/test_poiseuille.py``). Off by
    default: the walls then move at their own velocity, an effective no-slip plane ~0.6 dx behind
    the wall surface.

    ``floor_band`` [Pa]: the extrapolated pressure is floored at 0 (walls never pull the water);
    a band > 0 rounds that corner over +-band (``smooth_max0``, C2, exact beyond it), for gradients
    over long horizons (issue 44: at the free surface wall pressures cross 0 all the time, and the
    sharp floor makes the forward map kinked there). 0 (default): the sharp floor.
    """

    name = "adami"
    no_slip: bool = False
    floor_band: float = 0.0

    @property
    def mirrors_velocity(self) -> bool:
        return self.no_slip

    def viscous_velocity(self, v, kind, wp: WallPairs, params, config):
        if not self.no_slip:
            return v
        w = jnp.where(wp.valid, config.scheme.kernel.w(wp.r, params.fluid.h), 0.0)
        num = wall_sum(w[:, None] * take(v, wp.row), wp, config)
        den = wall_sum(w, wp, config)
        v_fluid = jnp.where((den > 0)[:, None], num / jnp.where(den > 0, den, 1.0)[:, None], v)
        return jnp.where((kind == Kind.WALL)[:, None], 2.0 * v - v_fluid, v)


@dataclasses.dataclass(frozen=True)
class DynamicWalls(WallModel):
    """Dynamic boundary particles (Crespo et al. 2007, as in DualSPHysics): the walls' density
    evolves with the continuity equation, clamped at rho0 from below."""

    name = "dynamic"
    dynamic = True
