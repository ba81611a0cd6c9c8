"""Observables computed from a state (jittable): surge front, energies, pressure probes.

Hard maxima here are for reporting; differentiable objectives use smooth versions
(``smooth_max``: log-sum-exp with a stated temperature).
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.scipy.special import logsumexp

from .sph.eos import tait_pressure
from .sph.kernels import kernel_pair
from .sph.neighbours import min_image
from .types import Config, Kind, Params, Scheme, State

__all__ = ["surge_front", "smooth_max", "energies", "probe_pressure", "fluid_mass"]


def smooth_max(values, weights_mask, temperature):
    """``temperature * log(sum exp(values / temperature))`` over masked entries (>= the hard max)."""
    z = jnp.where(weights_mask, values / temperature, -jnp.inf)
    return temperature * logsumexp(z)


def surge_front(state: State, *, z_below: float, x_origin: float = 0.0) -> jnp.ndarray:
    """Largest x [m] of fluid particles lower than ``z_below`` [m], measured from ``x_origin``."""
    P = state.particles
    m = (P.kind == Kind.FLUID) & (P.x[:, 2] < z_below)
    return jnp.max(jnp.where(m, P.x[:, 0], -jnp.inf)) - x_origin


def fluid_mass(state: State, params: Params) -> jnp.ndarray:
    """Total fluid mass [kg] (particle masses rho0 * vol are constant)."""
    P = state.particles
    return jnp.sum(jnp.where(P.kind == Kind.FLUID, params.fluid.rho0 * P.vol, 0.0))


def energies(state: State, params: Params, config: Config) -> dict:
    """Kinetic, potential (relative to z = 0) and elastic (compression) energy of the fluid [J].

    The elastic energy is ``sum m_i e(rho_i)`` with ``e = int p / rho^2 d rho`` of the scheme's
    equation of state; kinetic + potential + elastic is conserved by the inviscid equations.
    """
    P = state.particles
    f = params.fluid
    fluid = P.kind == Kind.FLUID
    m = jnp.where(fluid, f.rho0 * P.vol, 0.0)
    kinetic = 0.5 * jnp.sum(m * jnp.sum(P.v * P.v, -1))
    potential = -jnp.sum(m * (P.x @ params.gravity))
    rho = P.rho
    if config.scheme == Scheme.WCSPH:
        g = config.gamma
        B = f.rho0 * f.c0**2 / g
        # e(rho) = B/(g-1) [ (rho/rho0)^(g-1) - 1 ] / rho0 ... integral of p/rho^2 from rho0
        e = B / rho * (jnp.power(rho / f.rho0, g) / (g - 1.0) + 1.0) - B / f.rho0 * (g / (g - 1.0))
    else:
        c2 = f.c0**2
        e = c2 * (jnp.log(rho / f.rho0) + f.rho0 / rho - 1.0)
    elastic = jnp.sum(m * e)
    return {"kinetic": kinetic, "potential": potential, "elastic": elastic, "total": kinetic + potential + elastic}


def probe_pressure(state: State, params: Params, config: Config, points) -> jnp.ndarray:
    """Shepard-interpolated fluid pressure [Pa] at probe points [M, 3] (brute force over particles)."""
    P = state.particles
    w_fn, _ = kernel_pair(config.kernel)
    d = [min_image(points[:, None, a] - P.x[None, :, a], a, config.grid) for a in range(3)]
    r = jnp.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    fluid = P.kind == Kind.FLUID
    w = jnp.where(fluid[None, :], w_fn(r, params.fluid.h), 0.0) * P.vol[None, :]
    p = P.p if config.scheme == Scheme.SEED else tait_pressure(P.rho, params.fluid.rho0, params.fluid.c0, config.gamma)
    return jnp.sum(w * p[None, :], 1) / jnp.maximum(jnp.sum(w, 1), 1e-30)
