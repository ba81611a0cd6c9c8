"""The accurate weakly compressible scheme (``Scheme.WCSPH``, the default).

* continuity equation ``drho_i/dt = rho_i sum_j V_j (v_i - v_j) . grad W_ij`` plus delta-SPH
  density diffusion (Molteni & Colagrossi 2009; Fourtakas et al. 2019 subtract its hydrostatic
  part so a tank at rest stays at rest);
* Tait equation of state;
* momentum-conserving pressure gradient ``-sum_j m_j (p_i + p_j)/(rho_i rho_j) grad W_ij``;
* Monaghan artificial viscosity or a laminar (Morris / Lo & Shao) term;
* velocity Verlet (kick-drift-kick) with one force evaluation per step; the density is advanced
  like the positions, with the mid-step velocities (``advance``).

All physical constants come from ``Params`` so gradients reach them.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..types import Config, DensityDiffusion, Kind, NeighbourList, Params, Particles, Viscosity, WallModel
from .eos import tait_density, tait_pressure
from .kernels import kernel_pair
from .neighbours import Pairs, pairs, transpose_sum, wrap_positions
from .walls import adami_pressure

__all__ = ["density_rate", "acceleration", "pressure", "advance", "prime"]


def pressure(pr: Pairs, rho, kind, params: Params, config: Config):
    """Pressures [N] Pa (Tait for fluid; walls per ``config.wall_model``) and densities [N].

    Wall densities are replaced by the density the EOS gives for the wall pressure (Adami) or
    clamped at rho0 (dynamic boundary particles, as DualSPHysics does).
    """
    f = params.fluid
    p = tait_pressure(rho, f.rho0, f.c0, config.gamma)
    wall = kind == Kind.WALL
    if config.wall_model == WallModel.ADAMI:
        w_fn, _ = kernel_pair(config.kernel)
        p = adami_pressure(pr, p, rho, kind, params.gravity, f.h, w_fn, config)
        rho = jnp.where(wall, tait_density(p, f.rho0, f.c0, config.gamma), rho)
    else:
        rho = jnp.where(wall, jnp.maximum(rho, f.rho0), rho)
        p = jnp.where(wall, tait_pressure(rho, f.rho0, f.c0, config.gamma), p)
    return p, rho


def density_rate(pr: Pairs, v, rho, vol, kind, params: Params, config: Config):
    """Continuity equation with delta-SPH diffusion: drho/dt [N] kg/m^3/s (fluid and dynamic walls)."""
    f = params.fluid
    h = f.h
    nf = config.n_fluid
    idx, d = pr.idx, pr.d
    _, f_fn = kernel_pair(config.kernel)
    kind_j = kind[idx]
    F = jnp.where(pr.mask, f_fn(pr.r, h), 0.0)  # grad_i W_ij = F d
    rho_i = rho[:nf, None]
    rho_j = rho[idx]
    V_j = f.rho0 * vol[idx] / rho_j
    vij = tuple(v[:nf, a, None] - v[:, a][idx] for a in range(3))
    vr = vij[0] * d[0] + vij[1] * d[1] + vij[2] * d[2]
    drho = rho_i * V_j * vr * F
    if config.density_diffusion != DensityDiffusion.NONE:
        diff = rho_j - rho_i
        if config.density_diffusion == DensityDiffusion.FOURTAKAS:
            B = f.rho0 * f.c0**2 / config.gamma
            g_dx = -(d[0] * params.gravity[0] + d[1] * params.gravity[1] + d[2] * params.gravity[2])
            diff = diff - f.rho0 * jnp.expm1(jnp.log1p(f.rho0 * g_dx / B) / config.gamma)
        drho = drho + jnp.where(kind_j == Kind.FLUID, f.delta * h * f.c0 * V_j * (-2.0 * diff * F), 0.0)
    fluid = kind[:nf] == Kind.FLUID
    drho_f = jnp.where(fluid, jnp.sum(drho, axis=1), 0.0)
    nw = config.n_wall
    drho_w = jnp.zeros((nw,), rho.dtype)
    if nw and config.wall_model == WallModel.DYNAMIC:
        # wall j: rho_j sum_i V_i (v_j - v_i) . grad_j W_ji = rho_j sum_i V_i (v_ij . x_ij) F_ij
        V_i = f.rho0 * vol[:nf, None] / rho_i
        use = pr.mask & fluid[:, None] & (kind_j == Kind.WALL)
        drho_w = rho[nf:] * transpose_sum(jnp.where(use, V_i * vr * F, 0.0), idx, config.n_particles)[nf:]
    return jnp.concatenate([drho_f, drho_w])


def acceleration(pr: Pairs, v, rho, p, vol, kind, params: Params, config: Config):
    """Pressure gradient + viscosity + gravity: acceleration [N, 3] m/s^2 (zero off the fluid)."""
    f = params.fluid
    h = f.h
    nf = config.n_fluid
    idx, d, r2 = pr.idx, pr.d, pr.r2
    _, f_fn = kernel_pair(config.kernel)
    F = jnp.where(pr.mask, f_fn(pr.r, h), 0.0)
    rho_i = rho[:nf, None]
    rho_j = rho[idx]
    m_j = f.rho0 * vol[idx]
    vij = tuple(v[:nf, a, None] - v[:, a][idx] for a in range(3))
    coef = -m_j * (p[:nf, None] + p[idx]) / (rho_i * rho_j)
    eta2 = 0.01 * h * h
    if config.viscosity == Viscosity.ARTIFICIAL:
        vr = vij[0] * d[0] + vij[1] * d[1] + vij[2] * d[2]
        mu = h * vr / (r2 + eta2)
        pi_ij = jnp.where(vr < 0, -f.alpha * f.c0 * mu / (0.5 * (rho_i + rho_j)), 0.0)
        cf = (coef - m_j * pi_ij) * F
        acc = [jnp.sum(cf * d[a], axis=1) for a in range(3)]
    else:
        cf = coef * F
        lam = m_j * 4.0 * f.nu * (F * r2) / ((rho_i + rho_j) * (r2 + eta2))
        acc = [jnp.sum(cf * d[a] + lam * vij[a], axis=1) for a in range(3)]
    fluid = kind[:nf] == Kind.FLUID
    acc_f = jnp.where(fluid[:, None], jnp.stack(acc, axis=1) + params.gravity, 0.0)
    return jnp.concatenate([acc_f, jnp.zeros((config.n_wall, 3), acc_f.dtype)])


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """Fill ``a``, ``drho_dt`` and ``p`` for the current positions (before the first step)."""
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    p, rho = pressure(pr, P.rho, P.kind, params, config)
    drho_dt = density_rate(pr, P.v, rho, P.vol, P.kind, params, config)
    a = acceleration(pr, P.v, rho, p, P.vol, P.kind, params, config)
    return P.replace(a=a, drho_dt=drho_dt, p=p, rho=rho)


def advance(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """One step of length ``config.dt``: velocity Verlet for (x, v), density staggered like x.

    ``v+ = v + dt/2 a``; ``x' = x + dt v+``; ``rho' = rho + dt Drho(x', v+)``;
    ``a' = a(x', v+, rho')``; ``v' = v+ + dt/2 a'``. Density and position are advanced with the
    same mid-step velocities, so the pressure is never half a step behind the positions (a lag
    that was measured to make the scheme unstable at Courant 0.25).
    """
    dt = config.dt
    fluid = P.kind == Kind.FLUID
    evolving = fluid | ((P.kind == Kind.WALL) & (config.wall_model == WallModel.DYNAMIC))
    v_half = jnp.where(fluid[:, None], P.v + 0.5 * dt * P.a, P.v)
    x_new = wrap_positions(jnp.where(fluid[:, None], P.x + dt * v_half, P.x), config.grid)
    pr = pairs(x_new, P.kind, nbrs.idx, config)
    drho_dt = density_rate(pr, v_half, P.rho, P.vol, P.kind, params, config)
    rho_new = jnp.where(evolving, P.rho + dt * drho_dt, P.rho)
    p, rho_new = pressure(pr, rho_new, P.kind, params, config)
    a = acceleration(pr, v_half, rho_new, p, P.vol, P.kind, params, config)
    v_new = jnp.where(fluid[:, None], v_half + 0.5 * dt * a, v_half)
    return P.replace(x=x_new, v=v_new, a=a, rho=rho_new, drho_dt=drho_dt, p=p)
