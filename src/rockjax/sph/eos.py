"""Equations of state: Tait (WCSPH) and the seed's linear law p = k (rho - rho0) (seed Eq 17).

The Tait law is evaluated as ``B * expm1(gamma * log1p((rho - rho0) / rho0))`` so that float32
keeps the small density excess instead of cancelling ``(rho/rho0)^gamma - 1``.
"""

from __future__ import annotations

import jax.numpy as jnp

__all__ = ["tait_pressure", "tait_density", "hydrostatic_power", "linear_pressure", "linear_density"]


def tait_pressure(rho, rho0, c0, gamma):
    """Tait: ``p = rho0 c0^2 / gamma ((rho/rho0)^gamma - 1)`` [Pa]."""
    B = rho0 * c0**2 / gamma
    return B * jnp.expm1(gamma * jnp.log1p((rho - rho0) / rho0))


def tait_density(p, rho0, c0, gamma):
    """Inverse Tait law [kg/m^3]; pressures below -B/2 are treated as -B/2 (never NaN)."""
    B = rho0 * c0**2 / gamma
    ratio = jnp.maximum(p / B, -0.5)
    return rho0 * jnp.exp(jnp.log1p(ratio) / gamma)


def hydrostatic_power(e, gamma):
    """``(1 + e)^(2 - gamma)`` as a 3-term series in ``e = rho / rho0 - 1`` (relative error
    ``35 |e|^3`` for gamma = 7): the Tait ``rho / c(rho)^2`` relative to its rest value, used by
    ``wcsph.hydrostatic_pair_difference``."""
    s = 2.0 - gamma
    return 1.0 + s * e * (1.0 + 0.5 * (s - 1.0) * e * (1.0 + (s - 2.0) / 3.0 * e))


def linear_pressure(rho, rho0, c0):
    """Seed Eq 17 with the gas constant k = c0^2: ``p = c0^2 (rho - rho0)`` [Pa]."""
    return c0**2 * (rho - rho0)


def linear_density(p, rho0, c0):
    """Inverse of ``linear_pressure``."""
    return rho0 + p / c0**2
