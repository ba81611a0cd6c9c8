"""Viscous terms of the WCSPH momentum equation, one class each (``WCSPH(viscosity=...)``).

A viscous term adds to the acceleration of fluid particle i due to its neighbour j
(``wcsph._pair_force_factors``)::

    a_ij = (c_ij - q_ij) F_ij x_ij + lam_ij v_ij + e_ij

with ``c_ij = -m_j (p_i + p_j) / (rho_i rho_j)`` the pressure term, ``F = (dW/dr) / r``,
``x_ij = x_i - x_j``, ``v_ij = v_i - v_j``. A term returns ``(q, lam, e)`` from ``pair`` (None for
a part it does not have). A term that needs per-particle fields of its own (a stress tensor from
the velocity gradient) computes them in ``values``, before the momentum pass, and reads them back
from the pair's ``ri`` / ``cj`` dicts. Constants come from ``Params.fluid`` (``alpha``, ``nu``,
``wall_viscosity``), so gradients reach them; model constants (the Smagorinsky constant) are fields.

To add a viscosity: subclass ``Viscosity`` here as a frozen dataclass with a ``name``; it is then
a choice of ``WCSPH`` and of scene files (``viscosity = "name"``) with no other edit.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import jax.numpy as jnp

from .neighbours import safe_norm
from .terms import Term

__all__ = ["Viscosity", "Artificial", "Laminar", "LaminarSPS"]


class Viscosity(Term):
    """Base of the viscous terms. ``uses_nu``: the term uses ``Params.fluid.nu``, so the time step
    obeys the viscous limit ``dt <= 0.125 h^2 / nu`` (host) / ``0.25 h^2 / nu`` (in-jit check)."""

    family = "viscosity"
    uses_nu: ClassVar[bool] = False
    #: ``values`` sums over the list with ``pair_sum``, whose reverse pass reads the flat (fluid,
    #: wall) pair list (``FluidScheme.uses_wall_pairs``).
    uses_wall_pairs: ClassVar[bool] = False

    def values(self, x, v, rho, vol, kind, nbrs, params, config) -> dict:
        """Per-particle fields [N] this term's ``pair`` reads as ``ri[key]`` / ``cj[key]``, computed
        from positions x [N, 3] m, velocities v [N, 3] m/s, densities, volumes and the list
        (before the momentum pass). Default: none."""
        return {}

    def pair(self, m_j, rho_i, rho_j, vij, d, r2, F, fluid_j, params, ri, cj):
        """``(q, lam, e)`` of the pairs (arrays of one shape, [R, K] or [M]; ``vij``, ``d``: three
        arrays each; ``fluid_j`` True where j is fluid, else the factor ``wall_viscosity`` applies)."""
        raise NotImplementedError


def _eta2(h):
    return 0.01 * h * h


@dataclasses.dataclass(frozen=True)
class Artificial(Viscosity):
    """Monaghan (1992) artificial viscosity, coefficient ``Params.fluid.alpha``: on approaching
    pairs ``Pi_ij = -2 alpha c0 mu_ij / (rho_i + rho_j)``, ``mu_ij = h v_ij . x_ij / (r^2 + 0.01 h^2)``
    (``q = m_j Pi_ij``). Has a hand-derived pullback (``sph.pullbacks.momentum``, sharp switch only).

    ``approach_band`` [-]: the switch "approaching pairs only" is a kink in the forward map (Pi is
    continuous at ``v_ij . x_ij = 0`` but its slope jumps). A band > 0 turns it on smoothly: Pi is
    multiplied by the cubic smoothstep of ``-mu_ij / (band c0)`` from -1 to 1 (C1 in ``mu``, so
    ``Pi`` is C2; exactly Monaghan's beyond ``|mu_ij| >= band c0``, half of it at ``mu = 0``), for
    gradients over long horizons (issue 44). 0 (default): the sharp switch.
    """

    name = "artificial"
    approach_band: float = 0.0

    def pair(self, m_j, rho_i, rho_j, vij, d, r2, F, fluid_j, params, ri, cj):
        f = params.fluid
        h = f.h
        eta2 = _eta2(h)
        visc = jnp.where(fluid_j, 1.0, f.wall_viscosity)
        vr = vij[0] * d[0] + vij[1] * d[1] + vij[2] * d[2]
        mu = h * vr / (r2 + eta2)
        if self.approach_band > 0:
            u = jnp.clip(0.5 - 0.5 * mu / (self.approach_band * f.c0), 0.0, 1.0)
            pi_ij = (u * u * (3.0 - 2.0 * u)) * (-2.0 * f.alpha * f.c0) * visc * mu / (rho_i + rho_j)
        else:
            pi_ij = jnp.where(vr < 0, (-2.0 * f.alpha * f.c0) * visc * mu / (rho_i + rho_j), 0.0)
        return m_j * pi_ij, None, None


def _laminar(m_j, rho_i, rho_j, r2, F, fluid_j, params):
    f = params.fluid
    eta2 = _eta2(f.h)
    visc = jnp.where(fluid_j, 1.0, f.wall_viscosity)
    return m_j * 4.0 * f.nu * visc * (F * r2) / ((rho_i + rho_j) * (r2 + eta2))


@dataclasses.dataclass(frozen=True)
class Laminar(Viscosity):
    """Laminar viscosity of Morris et al. (1997) / Lo & Shao (2002), kinematic viscosity
    ``Params.fluid.nu`` [m^2/s]: ``lam = 4 nu m_j (x_ij . grad W_ij) / ((rho_i + rho_j)(r^2 + 0.01 h^2))``."""

    name = "laminar"
    uses_nu = True

    def pair(self, m_j, rho_i, rho_j, vij, d, r2, F, fluid_j, params, ri, cj):
        return None, _laminar(m_j, rho_i, rho_j, r2, F, fluid_j, params), None


_TAU = ("tau_xx", "tau_yy", "tau_zz", "tau_xy", "tau_xz", "tau_yz")
_AB = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _velocity_gradient_pair(ri, cj, d, params, mask, fluid_j, config):
    """The six strain-rate sums of pair (i, j) [R, K] (a ``pair_sum`` pair function):
    ``V_j (v_j - v_i)_a (grad_i W_ij)_b`` for ``ab`` = xx, yy, zz, and the symmetric sums
    ``(..)_ab + (..)_ba`` for xy, xz, yz (so that ``S_ab = g_ab / 2`` off the diagonal)."""
    r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    F = jnp.where(mask, config.scheme.kernel.f(safe_norm(r2), params.fluid.h), 0.0)
    w = params.fluid.rho0 * cj["vol"] / cj["rho"] * F  # V_j F
    dv = tuple(cj[k] - ri[k] for k in ("v0", "v1", "v2"))
    out = []
    for a, b in _AB:
        out.append(w * dv[a] * d[b] if a == b else w * (dv[a] * d[b] + dv[b] * d[a]))
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class LaminarSPS(Viscosity):
    """Laminar viscosity (``Laminar``) plus the sub-particle-scale (SPS) turbulence stress of
    Dalrymple & Rogers (2006), as DualSPHysics uses for breaking waves: a Smagorinsky eddy
    viscosity ``nu_t = (C_s dx)^2 |S|``, ``|S| = sqrt(2 S_ab S_ab)``, and the stress per unit mass

        tau_ab / rho = 2 nu_t S_ab - (2/3) nu_t (div v) delta_ab - (2/3) C_I dx^2 |S|^2 delta_ab,

    added as ``a_i += sum_j m_j (tau_i / rho_i^2 + tau_j / rho_j^2) . grad_i W_ij``. ``S`` comes
    from the SPH velocity gradient ``sum_j V_j (v_j - v_i) (x) grad_i W_ij`` over all neighbours,
    in a pass of its own before the momentum pass (``values``; walls carry no stress); ``dx`` is
    each particle's spacing ``vol^(1/3)``.

    Fields: ``smagorinsky`` (C_s, 0.12) and ``blin`` (C_I, 0.0066), the constants of Dalrymple &
    Rogers (2006) and DualSPHysics. With both 0 the term is ``Laminar`` exactly.
    """

    name = "sps"
    uses_nu = True
    uses_wall_pairs = True
    smagorinsky: float = 0.12
    blin: float = 0.0066

    def __post_init__(self):
        if not (self.smagorinsky >= 0 and self.blin >= 0):
            raise ValueError(f"LaminarSPS: smagorinsky and blin must be >= 0 (got {self.smagorinsky}, {self.blin})")

    def values(self, x, v, rho, vol, kind, nbrs, params, config) -> dict:
        from ..types import Kind
        from .pair_sum import pair_sum

        nf = config.n_fluid
        vals = {"rho": rho, "vol": vol, "v0": v[:, 0], "v1": v[:, 1], "v2": v[:, 2]}
        g = pair_sum(_velocity_gradient_pair, x, vals, vals, params, nbrs, kind, config)
        gxx, gyy, gzz, gxy, gxz, gyz = g
        s2 = 2.0 * (gxx * gxx + gyy * gyy + gzz * gzz) + gxy * gxy + gxz * gxz + gyz * gyz  # |S|^2
        dx2 = jnp.cbrt(vol[:nf]) ** 2
        s = jnp.sqrt(jnp.where(s2 > 0, s2, 1.0))
        nu_t = jnp.where(s2 > 0, self.smagorinsky**2 * dx2 * s, 0.0)
        iso = -(2.0 / 3.0) * (nu_t * (gxx + gyy + gzz) + self.blin * dx2 * s2)
        inv_rho = 1.0 / rho[:nf]  # (tau / rho) / rho, as the pair term needs
        fluid = kind[:nf] == Kind.FLUID
        taus = (2.0 * nu_t * gxx + iso, 2.0 * nu_t * gyy + iso, 2.0 * nu_t * gzz + iso,
                nu_t * gxy, nu_t * gxz, nu_t * gyz)
        pad = jnp.zeros((config.n_wall,), rho.dtype)
        return {k: jnp.concatenate([jnp.where(fluid, t * inv_rho, 0.0), pad]) for k, t in zip(_TAU, taus)}

    def pair(self, m_j, rho_i, rho_j, vij, d, r2, F, fluid_j, params, ri, cj):
        t = {k: ri[k] + cj[k] for k in _TAU}
        txx, tyy, tzz, txy, txz, tyz = (t[k] for k in _TAU)
        mF = m_j * F
        e = (mF * (txx * d[0] + txy * d[1] + txz * d[2]),
             mF * (txy * d[0] + tyy * d[1] + tyz * d[2]),
             mF * (txz * d[0] + tyz * d[1] + tzz * d[2]))
        return None, _laminar(m_j, rho_i, rho_j, r2, F, fluid_j, params), e
