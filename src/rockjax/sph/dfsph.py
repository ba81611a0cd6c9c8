"""The divergence-free incompressible scheme (``sph.schemes.DFSPH``; Bender & Koschier 2015, 2017).

Densities by summation, ``rho_i / rho0 = sum_j V_j W_ij`` (``V_j = Particles.vol``, the reference
volume; wall and block particles count with their volumes, the Akinci et al. 2012 boundary), and a
pressure ``kappa`` [m^2/s^2] (``p / rho0``) per fluid particle chosen each step by two Jacobi
solves so that the velocity field leaves the density at rho0 (the *density solve*) and carries
no compression (the *divergence solve*). One step (time t -> t + dt), all on the geometry at t:

1. ``rho_i`` and the DFSPH factor ``1 / S_i``, ``S_i = |sum_j V_j grad W_ij|^2 + sum_j |V_j grad W_ij|^2``
   (fluid j in the second sum);
2. divergence solve on ``v(t)``: ``kappa_i = max(D_i, 0) / (dt S_i)``, ``D_i = sum_j V_j (v_i - v_j) . grad W_ij``
   (the rate of the density ratio; particles with fewer than ``min_neighbours`` neighbours are
   left alone: at the free surface a missing neighbour is not compression);
3. non-pressure accelerations (gravity, the viscous term ``DFSPH.viscosity``):
   ``v* = v + dt a_np``;
4. density solve on ``v*``: ``kappa_i = max(rho*_i - 1, 0) / (dt^2 S_i)``,
   ``rho*_i = rho_i / rho0 + dt D_i(v*)``;
5. ``x(t + dt) = x + dt v``.

Each Jacobi sweep applies ``v_i -= dt sum_j V_j (kappa_i + kappa_j) grad W_ij`` over fluid j and
``dt V_b kappa_i grad W_ib`` over wall/block particles b (the pressure mirrored onto the wall):
momentum-conserving between fluid particles, and the pair term on a block particle is the force the
block gets back (``advance(..., bodies=)``). A solve stops when the mean error over the fluid
particles is at or below its tolerance (after ``min_iterations``), or at ``max_iterations``;
each starts from the previous step's total kappa (warm start; ``Particles.solver``).

Loops: ``DFSPH(iterations=None)`` runs each solve as a ``lax.while_loop`` until converged (the
forward default: a run pays for the sweeps it needs); reverse-mode AD cannot go through it.
``DFSPH(iterations=n)`` runs exactly n sweeps per solve in a ``lax.fori_loop`` with the updates
masked once converged (a fixed trip count: differentiable, each step costs n sweeps).

The time step carries no gradient: ``Config.dt`` is static, chosen on the host from the velocity
CFL (``DFSPH.stable_dt``); a step whose fastest particle moves more than ``0.5 h`` sets
``Status.UNSTABLE_DT``, and a solve ending above its tolerance at ``max_iterations`` sets
``Status.SOLVER_NOT_CONVERGED`` (the driver stops with the step and the advice).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..types import Config, Kind, NeighbourList, Params, Particles
from .neighbours import neighbour_kind, pairs, take, wrap_positions

__all__ = ["Geometry", "geometry", "divergence", "pressure_acceleration", "advance", "prime", "SOLVER_COLUMNS"]

#: Columns of ``Particles.solver`` [N, 6] (fluid rows; zero on walls): the density solve's total
#: kappa [m^2/s^2], the divergence solve's total kappa, the last density error of the step
#: (``max(rho* - 1, 0)``, before the last sweep), the last divergence error (``dt max(D, 0)``), and
#: the sweeps each solve took (every row holds the same count).
SOLVER_COLUMNS = ("kappa_density", "kappa_divergence", "density_error", "divergence_error",
                  "iterations_density", "iterations_divergence")


class Geometry(NamedTuple):
    """What a step's sums share, on the positions at the start of the step (fluid rows, [nf, K]).

    ``idx``: the list; ``gw``: three arrays ``V_j grad_i W_ij`` [1/m]; ``fluid_j``: the pair is
    real and j is fluid; ``pair``: the pair is real; ``rho``: [nf] density ratio ``rho / rho0``;
    ``factor``: [nf] ``1 / S_i`` [m^2] (0 where the sums vanish); ``count``: [nf] neighbours;
    ``wall_support``: [nf, 3] m/s^2, the hydrostatic part of the mirrored wall pressure
    (``pressure_acceleration``): ``-sum_b V_b (g . (x_b - x_i)) grad W_ib``.
    """

    idx: jax.Array
    gw: tuple
    fluid_j: jax.Array
    pair: jax.Array
    rho: jax.Array
    factor: jax.Array
    count: jax.Array
    wall_support: jax.Array


#: Lattice offsets (in spacings) of ``lattice_sum``: every kernel here has support 2h, and h/dx
#: up to 3 is covered.
_LATTICE_REACH = 6


def lattice_sum(vol, h, kernel):
    """``sum_n dx^3 W(|n| dx, h)`` over the cubic lattice of spacing ``dx = vol^(1/3)`` (n in Z^3):
    the density ratio that ``sum_j V_j W_ij`` gives inside a filled lattice (1.0095 for Wendland C2
    at h = 1.3 dx, not 1). ``geometry`` divides the volumes by it, so water at rest on its lattice
    is at rest density (as SPlisHSPlasH sets a particle's volume to 0.8 (2 r)^3 for its kernel)."""
    dx = jnp.cbrt(vol)
    n = jnp.arange(-_LATTICE_REACH, _LATTICE_REACH + 1, dtype=jnp.asarray(vol).dtype)
    r = dx * jnp.sqrt(n[:, None, None] ** 2 + n[None, :, None] ** 2 + n[None, None, :] ** 2)
    return vol * jnp.sum(kernel.w(r, h))


def geometry(x, kind, vol, nbrs: NeighbourList, params: Params, config: Config) -> Geometry:
    """``Geometry`` of the fluid rows at positions ``x`` [N, 3] (steps 1 of the module docstring).
    The volumes are ``vol / lattice_sum`` of the first fluid row's volume."""
    h = params.fluid.h
    kernel = config.scheme.kernel
    vol = vol / lattice_sum(jax.lax.stop_gradient(vol[0]), h, kernel)
    pr = pairs(x, kind, nbrs.idx, config)
    fluid_row = kind[: config.n_fluid] == Kind.FLUID
    pair = pr.mask & fluid_row[:, None]
    V_j = take(vol, pr.idx)
    F = jnp.where(pair, kernel.f(pr.r, h), 0.0)
    W = jnp.where(pair, kernel.w(pr.r, h), 0.0)
    gw = tuple(V_j * F * pr.d[a] for a in range(3))
    fluid_j = pair & (neighbour_kind(pr.idx, config) == Kind.FLUID)
    self_w = vol[: config.n_fluid] * kernel.w(jnp.zeros((), x.dtype), h)
    rho = jnp.where(fluid_row, self_w + jnp.sum(V_j * W, axis=1), 1.0)
    wall_j = pair & ~fluid_j
    s = sum(jnp.sum(g, axis=1) * (jnp.sum(g, axis=1) + jnp.sum(jnp.where(wall_j, g, 0.0), axis=1)) for g in gw)
    s = s + jnp.sum(jnp.where(fluid_j, sum(g * g for g in gw), 0.0), axis=1)
    ok = fluid_row & (s > 1e-9 / h**2)
    factor = jnp.where(ok, 1.0 / jnp.where(ok, s, 1.0), 0.0)
    g_d = sum(params.gravity[a] * pr.d[a] for a in range(3))  # g . (x_i - x_b)
    support = jnp.stack([jnp.sum(jnp.where(wall_j, g_d * g, 0.0), axis=1) for g in gw], axis=1)
    return Geometry(idx=pr.idx, gw=gw, fluid_j=fluid_j, pair=pair, rho=rho, factor=factor,
                    count=jnp.sum(pair, axis=1), wall_support=support)


def divergence(geo: Geometry, v):
    """``D_i = sum_j V_j (v_i - v_j) . grad_i W_ij`` [1/s] of the fluid rows ([nf]) for velocities
    ``v`` [N, 3] (wall and block particles at their own velocities)."""
    nf = geo.idx.shape[0]
    out = 0.0
    for a in range(3):
        va = v[:, a]
        out = out + jnp.sum(geo.gw[a] * (va[:nf, None] - take(va, geo.idx)), axis=1)
    return out


def pressure_acceleration(geo: Geometry, kappa):
    """``-sum_j V_j (kappa_i + kappa_j) grad W_ij`` over fluid j and wall/block particles b, whose
    ``kappa_b`` is mirrored from the fluid particle: ``kappa_b = kappa_i + g . (x_b - x_i)`` (Adami et
    al. 2012's wall pressure, pair by pair); [nf, 3] m/s^2 for ``kappa`` [nf] m^2/s^2 of the fluid
    rows, without the constant hydrostatic part ``Geometry.wall_support`` (added once per step).
    With the mirror's hydrostatic part a wall holds the water next to it: mirroring ``kappa_i`` alone
    (or Akinci's single ``kappa_i``) left the water along the walls sinking in a tank at rest."""
    k_j = take(jnp.concatenate([kappa, jnp.zeros((1,), kappa.dtype)]), jnp.minimum(geo.idx, kappa.shape[0]))
    coef = jnp.where(geo.pair, kappa[:, None] + jnp.where(geo.fluid_j, k_j, kappa[:, None]), 0.0)
    return -jnp.stack([jnp.sum(coef * g, axis=1) for g in geo.gw], axis=1)


class _Solve(NamedTuple):
    v: jax.Array  # [N, 3]
    kappa: jax.Array  # [nf] total
    error: jax.Array  # [] mean error at the last sweep
    row_error: jax.Array  # [nf]
    iterations: jax.Array  # [] int32


def _jacobi(geo: Geometry, v, kappa0, error_fn, scale, fluid_row, *, tolerance: float, min_iterations: int,
            max_iterations: int, fixed: int | None, dt, relaxation=1.0) -> _Solve:
    """Jacobi sweeps ``kappa_i = e_i(v) factor_i scale``, ``v += dt a_p(kappa)`` from the warm
    start ``kappa0`` (applied first), where ``e = error_fn(v)`` [nf] >= 0; stops as the module
    docstring says. ``fixed``: the number of sweeps of the differentiable form (None: while_loop)."""
    nf = geo.idx.shape[0]
    n_fluid = jnp.maximum(jnp.sum(fluid_row), 1)

    def kick(v, kappa):
        a = pressure_acceleration(geo, kappa)
        return v.at[:nf].add(jnp.where(fluid_row[:, None], dt * a, 0.0))

    def sweep(v, kappa):
        e = jnp.where(fluid_row, error_fn(v), 0.0)
        err = jnp.sum(e) / n_fluid
        k = e * geo.factor * scale * relaxation
        return kick(v, k), kappa + k, err, e

    kappa0 = jnp.where(error_fn(v) > 0, kappa0, 0.0)  # warm-start only the rows still in error
    v = kick(v, kappa0)
    zero = jnp.zeros((), v.dtype)
    if fixed is None:
        def cond(c):
            it, _, _, err, _ = c
            return (it < min_iterations) | ((err > tolerance) & (it < max_iterations))

        def body(c):
            it, v, kappa, _, _ = c
            v, kappa, err, e = sweep(v, kappa)
            return it + 1, v, kappa, err, e

        init = (jnp.zeros((), jnp.int32), v, kappa0, jnp.asarray(jnp.inf, v.dtype), jnp.zeros((nf,), v.dtype))
        it, v, kappa, err, e = jax.lax.while_loop(cond, body, init)
        return _Solve(v, kappa, err, e, it)

    def body(_, c):
        it, v, kappa, err, e_last = c
        go = (it < min_iterations) | (err > tolerance)
        v2, kappa2, err2, e2 = sweep(v, kappa)
        pick = lambda new, old: jnp.where(go, new, old)  # noqa: E731
        return (it + go.astype(jnp.int32), pick(v2, v), pick(kappa2, kappa), pick(err2, err), pick(e2, e_last))

    init = (jnp.zeros((), jnp.int32), v, kappa0, jnp.asarray(jnp.inf, v.dtype) + zero, jnp.zeros((nf,), v.dtype))
    it, v, kappa, err, e = jax.lax.fori_loop(0, fixed, body, init)
    return _Solve(v, kappa, err, e, it)


def _non_pressure_acceleration(x, v, rho, vol, kind, nbrs, params: Params, config: Config):
    """Gravity plus the scheme's viscous term [nf, 3] m/s^2 (``sph.viscosity``; pressures zero)."""
    from . import wcsph

    scheme = config.scheme
    f = params.fluid
    nf = config.n_fluid
    fluid_row = kind[:nf] == Kind.FLUID
    if scheme.viscosity is None:
        return jnp.where(fluid_row[:, None], params.gravity, 0.0)
    pr = pairs(x, kind, nbrs.idx, config)
    F = jnp.where(pr.mask, scheme.kernel.f(pr.r, f.h), 0.0)
    fluid_j = neighbour_kind(pr.idx, config) == Kind.FLUID
    extra = scheme.viscosity.values(x, v, rho, vol, kind, nbrs, params, config)
    ri = {k: a[:nf, None] for k, a in extra.items()}
    cj = {k: take(a, pr.idx) for k, a in extra.items()}
    vij = tuple(v[:nf, a][:, None] - take(v[:, a], pr.idx) for a in range(3))
    zero = jnp.zeros((), v.dtype)
    cf, lam, e = wcsph._pair_force_factors(f.rho0 * take(vol, pr.idx), rho[:nf, None], take(rho, pr.idx), zero, zero,
                                           vij, pr.d, pr.r2, F, fluid_j, params, config, ri, cj)
    acc = wcsph._combine(cf, lam, e, pr.d, vij)
    acc = jnp.stack([jnp.sum(jnp.where(pr.mask, c, 0.0), axis=1) for c in acc], axis=1) + params.gravity
    return jnp.where(fluid_row[:, None], acc, 0.0)


def _solver_array(P: Particles, config: Config):
    if P.solver is not None:
        return P.solver
    return jnp.zeros((P.x.shape[0], len(SOLVER_COLUMNS)), P.x.dtype)


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """Fill the summed densities and an empty ``Particles.solver`` (the first step solves from zero)."""
    geo = geometry(P.x, P.kind, P.vol, nbrs, params, config)
    f = params.fluid
    nf = config.n_fluid
    rho = P.rho.at[:nf].set(jnp.where(P.kind[:nf] == Kind.FLUID, f.rho0 * geo.rho, P.rho[:nf]))
    return P.replace(rho=rho, solver=_solver_array(P, config))


def advance(P: Particles, nbrs: NeighbourList, params: Params, config: Config, *, bodies: tuple[int, ...] = ()):
    """One DFSPH step of length ``config.dt`` (module docstring). Returns the new ``Particles``; with
    ``bodies`` ``(Particles, (row [M], col [M], force, x_row))``: over the (fluid, block particle)
    pairs of the list, the force [N] on fluid particle ``row`` from block particle ``col`` over the
    step (the two solves' pressure and the viscous term), three [M] components, zero for other
    pairs, and the rows' positions at which it acted (the start of the step)."""
    scheme = config.scheme
    dt = config.dt
    f = params.fluid
    nf = config.n_fluid
    kind = P.kind
    fluid = kind == Kind.FLUID
    fluid_row = fluid[:nf]
    solver = _solver_array(P, config)
    geo = geometry(P.x, kind, P.vol, nbrs, params, config)
    rho_full = P.rho.at[:nf].set(jnp.where(fluid_row, f.rho0 * geo.rho, P.rho[:nf]))
    loop = dict(min_iterations=scheme.min_iterations, max_iterations=scheme.max_iterations,
                fixed=scheme.iterations, dt=dt, relaxation=scheme.relaxation)

    v0 = P.v
    v = v0
    kv_total = jnp.zeros((nf,), v.dtype)
    err_v, e_v, it_v = jnp.zeros((), v.dtype), jnp.zeros((nf,), v.dtype), jnp.zeros((), jnp.int32)
    if scheme.divergence_solve:
        few = geo.count < scheme.min_neighbours

        def div_error(v):
            return jnp.where(few, 0.0, jnp.maximum(divergence(geo, v), 0.0)) * dt

        sv = _jacobi(geo, v, scheme.warm_start * solver[:nf, 1], div_error, 1.0 / dt**2, fluid_row,
                     tolerance=scheme.divergence_tolerance, **loop)
        v, kv_total, err_v, e_v, it_v = sv.v, sv.kappa, sv.error, sv.row_error, sv.iterations

    a_np = _non_pressure_acceleration(P.x, v, rho_full, P.vol, kind, nbrs, params, config)
    v_visc = v
    v = v.at[:nf].add(dt * jnp.where(fluid_row[:, None], a_np + geo.wall_support, 0.0))

    def density_error(v):
        return jnp.maximum(geo.rho + dt * divergence(geo, v) - 1.0, 0.0)

    sd = _jacobi(geo, v, scheme.warm_start * solver[:nf, 0], density_error, 1.0 / dt**2, fluid_row,
                 tolerance=scheme.tolerance, **loop)
    v = jnp.where(fluid[:, None], sd.v, P.v)
    x_new = wrap_positions(jnp.where(fluid[:, None], P.x + dt * v, P.x), config.grid)
    kappa = sd.kappa + kv_total
    a = jnp.where(fluid[:, None], (v - v0) / dt, 0.0)
    p = P.p.at[:nf].set(jnp.where(fluid_row, f.rho0 * kappa, 0.0))
    n = P.x.shape[0]
    pad = lambda c: jnp.concatenate([c, jnp.zeros((n - nf,), c.dtype)])  # noqa: E731
    cols = [sd.kappa, kv_total, sd.row_error, e_v,
            jnp.full((nf,), sd.iterations, v.dtype), jnp.full((nf,), it_v, v.dtype)]
    new_solver = jnp.stack([pad(c) for c in cols], axis=1)
    P_new = P.replace(x=x_new, v=v, a=a, rho=rho_full, p=p, drho_dt=jnp.zeros_like(P.rho), solver=new_solver)
    if not bodies:
        return P_new
    return P_new, _body_pair_forces(P, geo, kappa, a_np, v_visc, rho_full, nbrs, bodies, params, config)


def _body_pair_forces(P, geo: Geometry, kappa, a_np, v, rho, nbrs, bodies, params: Params, config: Config):
    """Per (fluid row, block particle) pair of the list: the force on the fluid particle from the
    block particle over the step: pressure ``-m_i V_b (kappa_i + kappa_b) grad W_ib`` (the mirrored
    pressure the solves applied, ``pressure_acceleration``) plus the viscous pair term (``wcsph.wall_pair_forces`` with zero pressure)."""
    from . import wcsph
    from .walls import wall_pair_geometry

    f = params.fluid
    bp = wall_pair_geometry(P.x, nbrs, config.grid, bodies=config.has_body_pairs)
    body_j = take(P.body, bp.col)
    on = bp.valid & (take(P.kind, bp.row) == Kind.FLUID) & jnp.isin(body_j, jnp.asarray(bodies, body_j.dtype))
    F = jnp.where(on, config.scheme.kernel.f(bp.r, f.h), 0.0)
    m_i = f.rho0 * take(P.vol, bp.row)
    k_i = take(jnp.concatenate([kappa, jnp.zeros((1,), kappa.dtype)]), jnp.minimum(bp.row, kappa.shape[0]))
    g_d = sum(params.gravity[a] * bp.d[a] for a in range(3))
    vol = P.vol / lattice_sum(jax.lax.stop_gradient(P.vol[0]), f.h, config.scheme.kernel)
    coef = -m_i * take(vol, bp.col) * (2.0 * k_i - g_d) * F
    force = [coef * bp.d[a] for a in range(3)]
    if config.scheme.viscosity is not None:
        zeros = jnp.zeros_like(P.p)
        visc = wcsph.wall_pair_forces(bp, on, v, rho, zeros, P.vol, params, config)
        force = [force[a] + visc[a] for a in range(3)]
    return bp.row, bp.col, tuple(force), P.x
