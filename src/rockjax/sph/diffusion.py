"""Density-diffusion (delta-SPH) terms of the WCSPH continuity equation, one class each
(``WCSPH(diffusion=...)``).

Each adds ``-2 delta h c0 V_j psi_ij F_ij`` to the continuity sum of fluid pair (i, j)
(``F = (dW/dr) / r``; ``delta`` from ``Params.fluid``), with ``psi_ij`` the density difference the
term diffuses, returned by ``difference``: Molteni & Colagrossi's ``rho_j - rho_i``, less its
hydrostatic part (Fourtakas et al. 2019) or its linear part (Antuono et al. 2010). A term that needs
the renormalised density gradient sets ``renormalised_gradient`` (the momentum pass computes it
from its own gathers, ``wcsph.advance``).

To add a diffusion: subclass ``DensityDiffusion`` here as a frozen dataclass with a ``name``.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

from .eos import hydrostatic_power
from .terms import Term

__all__ = ["DensityDiffusion", "NoDiffusion", "Molteni", "Fourtakas", "FourtakasSurface", "Antuono",
           "hydrostatic_pair_difference", "hydrostatic_density_difference"]

_G = ("g0", "g1", "g2")


class DensityDiffusion(Term):
    """Base of the density-diffusion terms. ``active``: the term adds anything;
    ``renormalised_gradient``: ``difference`` reads the rows' renormalised density gradients
    ``g0``-``g2`` [kg/m^4] from ``ri`` / ``cj``."""

    family = "diffusion"
    active: ClassVar[bool] = True
    renormalised_gradient: ClassVar[bool] = False

    def difference(self, ri, cj, d, rho_i, rho_j, params, gamma):
        """``psi_ij`` [kg/m^3] of the pairs (``d``: three arrays ``x_i - x_j``)."""
        raise NotImplementedError


def hydrostatic_density_difference(g_dx, params, gamma):
    """Fourtakas et al. (2019) hydrostatic density difference ``rho0 ((1 + rho0 g_dx / B)^(1/gamma) - 1)``
    (``FourtakasSurface``): the Tait density at a height difference from the surface.

    ``g_dx`` [m^2/s^2] is ``g . (x_j - x_i)``. Evaluated as the 4th-order Taylor series in
    ``a = rho0 g_dx / B`` (no transcendental per pair; the exact form cost ~40 % of the continuity
    sum). The truncation error relative to the leading term is below ``0.15 a^4``; with
    c0 >= 10 v_max and neighbours within 2h, |a| < 0.01 in every built-in scene (error < 2e-9).
    Not odd in ``g_dx`` (an even part ``(1 - gamma) a / 2`` of the leading term): the pair (j, i)
    does not get minus the pair (i, j)'s value, see ``hydrostatic_pair_difference``.
    """
    f = params.fluid
    B = f.rho0 * f.c0**2 / gamma
    a = f.rho0 * g_dx / B
    s = 1.0 / gamma
    c1, c2 = s, s * (s - 1.0) / 2.0
    c3 = c2 * (s - 2.0) / 3.0
    c4 = c3 * (s - 3.0) / 4.0
    return f.rho0 * a * (c1 + a * (c2 + a * (c3 + a * c4)))


def hydrostatic_pair_difference(g_dx, rho_i, rho_j, params, gamma):
    """Hydrostatic density difference of a pair about its mean density (``Fourtakas``):
    ``g_dx rho_m / c(rho_m)^2 = rho0 (g_dx / c0^2) (rho_m / rho0)^(2 - gamma)``, ``rho_m = (rho_i + rho_j) / 2``.

    ``g_dx`` [m^2/s^2] is ``g . (x_j - x_i)``; ``rho_i``, ``rho_j`` kg/m^3 (any shapes that broadcast).
    The hydrostatic pressure difference over the pair, ``rho_m g_dx``, turned into a density
    difference with the Tait sound speed at the pair's own density: a central difference, exact to
    third order in the height difference at any depth, and odd in the pair (the pair (j, i) gets
    exactly minus the pair (i, j)'s value), so the diffusion, like Molteni's, moves density between
    the two particles and creates none. Fourtakas et al.'s own form (``hydrostatic_density_difference``,
    from the surface's density) has an even part, which made the diffusion a net density source in a
    tank at rest (RESULTS.md, "energy creep"). The power is a 3-term series in ``e = rho_m / rho0 - 1``
    (|e| < 0.01 with c0 >= 10 v_max: relative error 35 |e|^3 < 4e-5).
    """
    f = params.fluid
    e = 0.5 * (rho_i + rho_j) / f.rho0 - 1.0
    return f.rho0 * g_dx / f.c0**2 * hydrostatic_power(e, gamma)


def _g_dx(d, params):
    g = params.gravity
    return -(d[0] * g[0] + d[1] * g[1] + d[2] * g[2])


@dataclasses.dataclass(frozen=True)
class NoDiffusion(DensityDiffusion):
    """No density diffusion (with no artificial viscosity either, the pressure noise is undamped:
    the host warns)."""

    name = "none"
    active = False


@dataclasses.dataclass(frozen=True)
class Molteni(DensityDiffusion):
    """Molteni & Colagrossi (2009): ``psi = rho_j - rho_i``."""

    name = "molteni"

    def difference(self, ri, cj, d, rho_i, rho_j, params, gamma):
        return rho_j - rho_i


@dataclasses.dataclass(frozen=True)
class Fourtakas(DensityDiffusion):
    """Fourtakas et al. (2019), the default: Molteni less the hydrostatic part of each pair's
    density difference, taken about the pair's mean density (``hydrostatic_pair_difference``:
    odd in the pair, so the term only moves density). Has a hand-derived pullback
    (``sph.pullbacks.continuity``)."""

    name = "fourtakas"

    def difference(self, ri, cj, d, rho_i, rho_j, params, gamma):
        return (rho_j - rho_i) - hydrostatic_pair_difference(_g_dx(d, params), rho_i, rho_j, params, gamma)


@dataclasses.dataclass(frozen=True)
class FourtakasSurface(DensityDiffusion):
    """Fourtakas et al.'s own hydrostatic difference, from the surface's density
    (``hydrostatic_density_difference``; not odd in the pair): kept for comparisons, it lets a
    column at rest creep (RESULTS.md, "energy creep")."""

    name = "fourtakas_surface"

    def difference(self, ri, cj, d, rho_i, rho_j, params, gamma):
        return (rho_j - rho_i) - hydrostatic_density_difference(_g_dx(d, params), params, gamma)


@dataclasses.dataclass(frozen=True)
class Antuono(DensityDiffusion):
    """Antuono et al. (2010) consistent delta-SPH: Molteni less the linear part of the density
    difference, ``psi = (rho_j - rho_i) - (g_i + g_j) / 2 . x_ji`` with renormalised density
    gradients ``g`` (``wcsph.density_gradient``; faded to Molteni's term where the renormalisation
    is ill-conditioned). The lowest drift at rest; costs ~27 % more per step (RESULTS.md)."""

    name = "antuono"
    renormalised_gradient = True

    def difference(self, ri, cj, d, rho_i, rho_j, params, gamma):
        # minus the linear part: (rho_j - rho_i) - (g_i + g_j) / 2 . x_ji, with x_ji = -d
        return (rho_j - rho_i) + 0.5 * sum((ri[_G[a]] + cj[_G[a]]) * d[a] for a in range(3))
