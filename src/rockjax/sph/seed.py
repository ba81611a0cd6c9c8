"""The seed paper's scheme (``Scheme.SEED``; Mikola & Sitar 2013, section 6.2).

* density by summation with the poly6 kernel (seed Eq 12, 13);
* linear equation of state ``p = k (rho - rho0)`` with ``k = c0^2`` (seed Eq 17);
* symmetrised pressure force with the spiky kernel (seed Eq 14, 15);
* viscosity force with the viscosity kernel's Laplacian (seed Eq 18, 19), ``mu = rho0 nu``;
* symplectic Euler (seed Eq 21).

Two signs differ from the printed text, which has ``(p_i - p_j)`` in Eq 14 and ``(v_i - v_j)``
in Eq 18. As printed, Eq 14 is not antisymmetric in (i, j), so it would not conserve momentum
(the paper says it is chosen "because it guarantees the symmetry of forces"), and Eq 18 would
amplify velocity differences instead of damping them. We use the forms of Mueller et al. (2003),
which the paper cites: ``(p_i + p_j) / (2 rho_j)`` and ``(v_j - v_i)``.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..types import Config, Kind, NeighbourList, Params, Particles, WallModel
from .eos import linear_density, linear_pressure
from .kernels import poly6, spiky_f, viscosity_laplacian
from .neighbours import Pairs, pairs, transpose_sum, wrap_positions
from .walls import adami_pressure

__all__ = ["density", "forces", "advance", "prime"]


def density(pr: Pairs, rho, vol, kind, params: Params, config: Config):
    """Summation density (seed Eq 12) [N] for fluid rows (and dynamic walls); walls keep ``rho``."""
    f = params.fluid
    nf = config.n_fluid
    m = f.rho0 * vol
    w = jnp.where(pr.mask, poly6(pr.r, f.h), 0.0)
    self_term = m * poly6(jnp.zeros((), rho.dtype), f.h)
    rho_f = self_term[:nf] + jnp.sum(m[pr.idx] * w, axis=1)
    rho_f = jnp.where(kind[:nf] == Kind.FLUID, rho_f, rho[:nf])
    rho_w = rho[nf:]
    if config.n_wall and config.wall_model == WallModel.DYNAMIC:
        use = (kind[:nf, None] == Kind.FLUID) & (kind[pr.idx] == Kind.WALL)
        summed = transpose_sum(jnp.where(use, m[:nf, None] * w, 0.0), pr.idx, config.n_particles)[nf:]
        rho_w = jnp.maximum(self_term[nf:] + summed, f.rho0)
    return jnp.concatenate([rho_f, rho_w])


def _pressure(pr: Pairs, rho, kind, params: Params, config: Config):
    f = params.fluid
    p = linear_pressure(rho, f.rho0, f.c0)
    if config.wall_model == WallModel.ADAMI:
        p = adami_pressure(pr, p, rho, kind, params.gravity, f.h, poly6, config)
        rho = jnp.where(kind == Kind.WALL, linear_density(p, f.rho0, f.c0), rho)
    return p, rho


def forces(pr: Pairs, v, rho, p, vol, kind, params: Params, config: Config):
    """Acceleration [N, 3] m/s^2: (pressure + viscosity force) / rho + g (seed Eq 14, 18, 20)."""
    f = params.fluid
    nf = config.n_fluid
    idx, d = pr.idx, pr.d
    pair = pr.mask & (pr.r > 0)
    F = jnp.where(pair, spiky_f(jnp.where(pair, pr.r, f.h), f.h), 0.0)
    m_j = f.rho0 * vol[idx]
    rho_j = rho[idx]
    cp = -m_j * (p[:nf, None] + p[idx]) / (2.0 * rho_j) * F
    cv = f.rho0 * f.nu * m_j / rho_j * jnp.where(pair, viscosity_laplacian(pr.r, f.h), 0.0)
    acc = jnp.stack([jnp.sum(cp * d[a] + cv * (v[:, a][idx] - v[:nf, a, None]), axis=1) for a in range(3)], 1)
    acc = acc / rho[:nf, None] + params.gravity
    acc = jnp.where((kind[:nf] == Kind.FLUID)[:, None], acc, 0.0)
    return jnp.concatenate([acc, jnp.zeros((config.n_wall, 3), acc.dtype)])


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """Fill density, pressure and acceleration for the current positions."""
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    rho = density(pr, P.rho, P.vol, P.kind, params, config)
    p, rho = _pressure(pr, rho, P.kind, params, config)
    a = forces(pr, P.v, rho, p, P.vol, P.kind, params, config)
    return P.replace(rho=rho, p=p, a=a, drho_dt=jnp.zeros_like(rho))


def advance(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """One symplectic-Euler step (seed Eq 21): v += dt a(x); x += dt v."""
    P = prime(P, nbrs, params, config)
    fluid = (P.kind == Kind.FLUID)[:, None]
    v_new = jnp.where(fluid, P.v + config.dt * P.a, P.v)
    x_new = wrap_positions(jnp.where(fluid, P.x + config.dt * v_new, P.x), config.grid)
    return P.replace(x=x_new, v=v_new)
