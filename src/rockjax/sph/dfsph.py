"""The divergence-free incompressible scheme (``sph.schemes.DFSPH``; Bender & Koschier 2015, 2017).

Densities by summation, ``rho_i / rho0 = sum_j V_j W_ij`` over fluid, wall and block particles
(``V_j = Particles.vol / lattice_sum``: a filled lattice is at rest density), and a pressure
``kappa`` [m^2/s^2] (``p / rho0``) per fluid particle chosen each step by two solves, so that the
velocities leave the density at rho0 (the *density solve*) and carry no compression (the
*divergence solve*). One step (time t -> t + dt), all on the geometry at t:

1. ``rho_i`` and the DFSPH factor ``1 / S_i``, ``S_i = |G_i + (w - 1) B_i|^2 + sum_j |V_j grad W_ij|^2``
   (``G_i = sum_j V_j grad W_ij`` over all neighbours, ``B_i`` its wall and block part, fluid j in
   the last sum, ``w`` the solve's wall weight below), the diagonal of the solves' operator;
2. divergence solve on ``v(t)``: residual ``dt D_i``, ``D_i = sum_j V_j (v_i - v_j) . grad W_ij`` (the
   rate of the density ratio; rows with fewer than ``min_neighbours`` neighbours are left alone:
   at a free surface a missing neighbour is not compression);
3. non-pressure accelerations (gravity, the viscous term ``DFSPH.viscosity``): ``v* = v + dt a_np``;
4. density solve on ``v*``: residual ``rho_i / rho0 + dt D_i(v*) - 1``;
5. ``x(t + dt) = x + dt v`` (plus the particle shift of ``DFSPH.shifting``, ``sph.shifting``).

The pressure acts as ``a_i = -sum_j V_j (kappa_i + kappa_j) grad W_ij`` over fluid j and
``-sum_b V_b (kappa_i + kappa_b) grad W_ib`` over wall and block particles b; momentum-conserving
between fluid particles, and the pair term on a block particle is the force the block gets back
(``advance(..., bodies=)``). The wall particle's ``kappa_b`` (``wall_kappa``):

* density solve, ``DFSPH.wall_pressure = "extrapolated"`` (default): the row's own pressure
  continued to the wall particle with the hydrostatic difference, ``max(kappa_i - g . (x_i - x_b),
  0)``, as Adami et al. (2012) extrapolate a wall's pressure, and the wall terms of the solve's
  ``D`` weighted twice (``w = 2``: the adjoint of these pressure terms, a wall standing for mirrored
  water moving the other way), so ``D(a(kappa))`` stays symmetric and a solve a projection (with
  ``D`` weighted once the water at rest kept moving: rms 0.28 m/s with water's viscosity). A uniform
  pressure then pushes no row (``G_i = 0`` in a full kernel), a hydrostatic column on the lattice
  is balanced in every row (``a_z = 1.02 g``, the kernel's discrete gradient moment), and a tank
  at rest carries rho0 g d within about 1 % on time average;
* ``"akinci"`` (Akinci et al. 2012, SPlisHSPlasH's): ``kappa_b = 0``, ``w = 1``, also symmetric;
  but a wall then pushes with half the pressure of the water it stands for: on the lattice the
  bottom row of a hydrostatic column is pulled into its floor at 4.3 g, the time-mean pressures of
  a tank at rest come out 4-16 % high, and that water still moves 1.5-2x faster after 1 s;
* divergence solve: always Akinci's (a velocity projection, no hydrostatic balance to hold).

Block particles take gravity's difference only (not their own acceleration's).

Each solve is projected Jacobi on the total pressure (as IISPH clamps its pressures):
``kappa_i <- max(kappa_i + relaxation r_i / (dt^2 S_i), 0)`` with the signed residual ``r``, so
the pressure can fall as well as rise, and is never negative (a free surface pulls nothing). The
relaxation must stay below ``2 / lambda_max`` of ``diag(1/S) D a``: lambda_max = 4.2 for Wendland
C2 at h = 1.3 dx (2.8 for the cubic spline at h = dx), so the default is 0.4; SPlisHSPlasH's
increments (``max(r, 0)`` at relaxation 1, restarted at half the last pressure) hide that
divergence by never lowering a pressure. A solve stops when the mean ``|r|`` over the fluid rows
that carry pressure or are compressed is at or below its tolerance (after ``min_iterations``, the
divergence solve's ``min_divergence_iterations``), or
at ``max_iterations``; each starts from ``warm_start`` times the previous step's pressure
(``Particles.solver``).

Loops: ``DFSPH(iterations=None)`` runs each solve as a ``lax.while_loop`` until converged (the
forward default: a run pays for the sweeps it needs). ``DFSPH(iterations=n)`` runs exactly n sweeps
per solve in a ``lax.fori_loop`` (a fixed trip count, each step costs n sweeps). Every sweep runs,
also after the tolerance is met: a finish masked on the residual switches the sweep count with the
parameters, and the result jumps (measured: the secants of a dam break's energy in h at 1e-3 and
1e-4 disagreed 2x).

Gradients (``DFSPH.gradient``):

* ``"unrolled"`` (default): reverse mode through the n fixed sweeps (``iterations=n`` required; a
  ``while_loop`` has no reverse mode). The exact derivative of what the forward computed, solved
  or not; memory grows with n.
* ``"implicit"``: at a solve's result the rows A it drives with a positive pressure satisfy
  ``r_A(kappa, theta) = 0`` (``theta``: the step's geometry and velocities), so by the implicit
  function theorem the cotangents need one adjoint solve ``J_AA^T mu = kbar_A`` (``J = dr/dkappa``),
  run as ``adjoint_iterations`` Jacobi sweeps with the forward's step (``_implicit_bwd``), whatever
  the forward's loop (fixed or ``while_loop``); memory does not grow with the sweeps. It is the
  derivative of the *converged* solve: at the default tolerance (1e-3) it is off by as much as the
  forward is from convergence (RESULTS.md, "DFSPH gradients": 3-33 % on the tests' dam break), so
  use it with a tight tolerance (1e-8: within 1e-4 of the secants).

The time step carries no gradient: ``Config.dt`` is static, chosen on the host from the velocity
CFL (``DFSPH.stable_dt``); a step whose fastest particle moves more than ``0.5 h`` sets
``Status.UNSTABLE_DT``, and a solve ending above its tolerance at ``max_iterations`` sets
``Status.SOLVER_NOT_CONVERGED`` (the driver stops with the step and the advice).

Water at rest against the peer's, and the speed of a step against SPlisHSPlasH's: RESULTS.md, "DFSPH".
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..types import Config, Kind, NeighbourList, Params, Particles
from . import halo
from .neighbours import neighbour_kind, pairs, take, wrap_positions

__all__ = ["Geometry", "geometry", "lattice_sum", "divergence", "pressure_acceleration", "advance", "prime",
           "SOLVER_COLUMNS"]

#: Columns of ``Particles.solver`` [N, 6] (fluid rows; zero on walls): the density solve's
#: pressure kappa [m^2/s^2], the divergence solve's, the last density residual of the step, the last
#: divergence residual (``dt D``), and the sweeps each solve took (every row holds the same count).
SOLVER_COLUMNS = ("kappa_density", "kappa_divergence", "density_error", "divergence_error",
                  "iterations_density", "iterations_divergence")

#: Lattice offsets (in spacings) of ``lattice_sum``: every kernel here has support 2h, and h/dx
#: up to 3 is covered.
_LATTICE_REACH = 6


def lattice_sum(vol, h, kernel):
    """``sum_n dx^3 W(|n| dx, h)`` over the cubic lattice of spacing ``dx = vol^(1/3)`` (n in Z^3):
    the density ratio that ``sum_j V_j W_ij`` gives inside a filled lattice (1.0095 for Wendland C2
    at h = 1.3 dx, not 1). ``geometry`` divides the volumes by it, so water at rest on its lattice
    is at rest density (as SPlisHSPlasH sets a particle's volume to 0.8 (2 r)^3 for its kernel);
    without it the density solve expanded the water by ~1 %."""
    dx = jnp.cbrt(vol)
    n = jnp.arange(-_LATTICE_REACH, _LATTICE_REACH + 1, dtype=jnp.asarray(vol).dtype)
    r = dx * jnp.sqrt(n[:, None, None] ** 2 + n[None, :, None] ** 2 + n[None, None, :] ** 2)
    return vol * jnp.sum(kernel.w(r, h))


@functools.lru_cache(maxsize=64)
def jacobi_lambda_max(kernel, h_over_dx: float, *, grid: int = 24) -> float:
    """Largest eigenvalue of the Jacobi operator ``diag(1/S) D a`` in the bulk of a cubic lattice
    (host, numpy): with ``g(r) = grad W(r)`` over the lattice offsets ``r`` and the diagonal
    ``S = sum_r |g(r)|^2``, a pressure wave ``exp(i q . x)`` is scaled by
    ``lambda(q) = |sum_r sin(q . r) g(r)|^2 / S``; the maximum over ``q`` in [0, pi / dx]^3 (a
    ``grid``-point search per axis). The sweeps diverge for a relaxation above ``2 / lambda_max``:
    4.20 for Wendland C2 at h = 1.3 dx and 2.82 for the cubic spline at h = dx (as measured on the
    solves), 7.47 for the cubic spline at h = 1.5 dx. Walls and free surfaces remove neighbours and
    lower it; the bulk bounds it."""
    import numpy as np

    R = int(np.ceil(2.0 * h_over_dx))
    n = np.arange(-R, R + 1, dtype=float)
    off = np.stack(np.meshgrid(n, n, n, indexing="ij"), -1).reshape(-1, 3)
    r = np.linalg.norm(off, axis=1)
    keep = (r > 0) & (r < 2.0 * h_over_dx)
    off, r = off[keep], r[keep]
    g = np.asarray(kernel.f(r, h_over_dx), float)[:, None] * off  # grad W at unit spacing (its scale cancels)
    S = float(np.sum(g * g))
    q = np.linspace(0.0, np.pi, grid + 1)
    Q = np.stack(np.meshgrid(q, q, q, indexing="ij"), -1).reshape(-1, 3)
    best = 0.0
    for chunk in np.array_split(Q, max(1, len(Q) // 4096)):
        v = np.sin(chunk @ off.T) @ g  # [q, 3]
        best = max(best, float(np.max(np.sum(v * v, axis=1))) / S)
    return best


def _volumes(vol, h, kernel):
    """The sums' volumes [N] m^3: ``vol / lattice_sum`` of the first particle's volume."""
    return vol / lattice_sum(jax.lax.stop_gradient(vol[0]), h, kernel)


class Geometry(NamedTuple):
    """What a step's sums share, on the positions at the start of the step (fluid rows, [nf, K]).

    ``idx``: the list; ``gw``: three arrays ``V_j grad_i W_ij`` [1/m]; ``fluid_j``: the pair is
    real and j is fluid; ``pair``: the pair is real; ``rho``: [nf] density ratio ``rho / rho0``;
    ``factor``: [nf] ``1 / S_i`` [m^2] (0 where the sums vanish) for wall weight 1, ``wall_factor``
    for wall weight 2 (``_WALL_WEIGHT``); ``count``: [nf] neighbours; ``rise``: [nf, K] ``_rise`` on
    the wall and block pairs (0 elsewhere); ``width``: ``soft_width`` [m^2/s^2].
    """

    idx: jax.Array
    gw: tuple
    fluid_j: jax.Array
    pair: jax.Array
    rho: jax.Array
    factor: jax.Array
    count: jax.Array
    wall_factor: jax.Array
    rise: jax.Array
    width: jax.Array


def geometry(x, kind, vol, nbrs: NeighbourList, params: Params, config: Config, *, pr=None) -> Geometry:
    """``Geometry`` of the fluid rows at positions ``x`` [N, 3] (step 1 of the module docstring);
    ``pr``: their ``neighbours.Pairs`` if already computed."""
    h = params.fluid.h
    kernel = config.scheme.kernel
    vol = _volumes(vol, h, kernel)
    pr = pairs(x, kind, nbrs.idx, config) if pr is None else pr
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
    total = [jnp.sum(g, axis=1) for g in gw]
    fluid_sq = jnp.sum(jnp.where(fluid_j, sum(g * g for g in gw), 0.0), axis=1)
    walls = [jnp.sum(jnp.where(wall_j, g, 0.0), axis=1) for g in gw]
    factors = []
    for weight in (1.0, 2.0):  # the wall terms' weight in the solve's operator (``divergence``)
        s = sum((t + (weight - 1.0) * w) ** 2 for t, w in zip(total, walls)) + fluid_sq
        ok = fluid_row & (s > 1e-9 / h**2)
        factors.append(jnp.where(ok, 1.0 / jnp.where(ok, s, 1.0), 0.0))
    rise = jnp.where(wall_j, _rise(params, pr.d), 0.0)
    return Geometry(idx=pr.idx, gw=gw, fluid_j=fluid_j, pair=pair, rho=rho, factor=factors[0], count=jnp.sum(pair, axis=1),
                    wall_factor=factors[1], rise=rise, width=soft_width(params))


def _gather_rows(values, idx):
    """``values`` [nf] of the fluid rows at the list's columns ``idx`` (0 for wall columns)."""
    nf = values.shape[0]
    return take(jnp.concatenate([values, jnp.zeros((1,), values.dtype)]), jnp.minimum(idx, nf))


def divergence(geo: Geometry, v, wall_weight: float = 1.0):
    """``D_i = sum_j V_j (v_i - v_j) . grad_i W_ij`` [1/s] of the fluid rows ([nf]) for velocities
    ``v`` [N, 3] (wall and block particles at their own velocities), the wall and block terms
    weighted by ``wall_weight`` (2: the adjoint of the extrapolated wall pressure's terms)."""
    nf = geo.idx.shape[0]
    out = 0.0
    wall = None if wall_weight == 1.0 else geo.pair & ~geo.fluid_j
    for a in range(3):
        va = v[:, a]
        g = geo.gw[a] if wall is None else jnp.where(wall, wall_weight * geo.gw[a], geo.gw[a])
        out = out + jnp.sum(g * (va[:nf, None] - take(va, geo.idx)), axis=1)
    return out


#: The weight of the wall and block terms in a density solve's ``D`` per wall model: the adjoint
#: of the model's wall pressure terms, so ``D(a(kappa))`` is symmetric (module docstring).
_WALL_WEIGHT = {"akinci": 1.0, "extrapolated": 2.0}


def _rise(params: Params, d):
    """``-g . (x_i - x_b)`` [m^2/s^2] for pair separations ``d`` (three arrays ``x_i - x_b``): the
    hydrostatic pressure over density gained from the row to the wall particle."""
    return -sum(params.gravity[a] * d[a] for a in range(3))


def wall_kappa(kappa_rows, rise, model: str, width):
    """The pressure ``kappa_b`` [m^2/s^2] a wall or block particle carries in its pair with a fluid
    row: ``"extrapolated"``: the row's own pressure continued to the wall particle with the
    hydrostatic difference ``rise = -g . (x_i - x_b)`` over the pair (as Adami et al. 2012
    extrapolate a wall's pressure; ``g`` the gravity vector), never negative: ``max(kappa_i + rise,
    0)`` rounded over ``|kappa_i + rise| < width`` [m^2/s^2] (C1, ``_soft_max``: a wall particle above
    a free surface pulls nothing, without a kink in the gradient); ``"akinci"``: 0, the wall term
    then being ``-V_b kappa_i grad W`` alone (Akinci et al. 2012, SPlisHSPlasH's).
    ``kappa_rows`` [nf, 1] or [M] broadcasts against ``rise``."""
    if model == "extrapolated":
        return _soft_max(kappa_rows + rise, width)
    return jnp.zeros_like(rise)


def _soft_max(x, width):
    """``max(x, 0)`` with the corner replaced by the parabola ``(x + w)^2 / 4w`` on ``|x| < w`` (C1)."""
    return jnp.where(x >= width, x, jnp.where(x <= -width, 0.0, (x + width) ** 2 / (4.0 * width)))


def soft_width(params: Params):
    """The rounding of ``wall_kappa``'s clamp [m^2/s^2]: a tenth of the hydrostatic difference over
    one smoothing length, ``0.1 |g| h``."""
    return 0.1 * jnp.linalg.norm(params.gravity) * params.fluid.h


def pressure_acceleration(geo: Geometry, kappa, model: str = "akinci"):
    """``-sum_j V_j (kappa_i + kappa_j) grad W_ij`` over fluid j and ``-sum_b V_b (kappa_i + kappa_b)
    grad W_ib`` over wall and block particles b [nf, 3] m/s^2 for ``kappa`` [nf] m^2/s^2 of the fluid
    rows, ``kappa_b`` by the wall ``model`` (``wall_kappa``)."""
    ki = kappa[:, None]
    other = jnp.where(geo.fluid_j, _gather_rows(kappa, geo.idx), wall_kappa(ki, geo.rise, model, geo.width))
    coef = jnp.where(geo.pair, ki + other, 0.0)
    return -jnp.stack([jnp.sum(coef * g, axis=1) for g in geo.gw], axis=1)


class _Solve(NamedTuple):
    v: jax.Array  # [N, 3]
    kappa: jax.Array  # [nf]
    error: jax.Array  # [] mean |residual| at the last sweep
    row_error: jax.Array  # [nf]
    iterations: jax.Array  # [] int32


class _Options(NamedTuple):
    """A solve's static settings (``_solve``); ``residual(geo, v)`` [nf] is a pure function of its
    arguments (no traced value closed over), as the implicit reverse mode re-evaluates it."""

    residual: object
    tolerance: float
    min_iterations: int
    max_iterations: int
    fixed: int | None
    relaxation: float
    dt: float
    model: str
    adjoint_iterations: int


def _velocity(geo: Geometry, v_base, kappa, fluid_row, dt, model: str):
    """The velocities [N, 3] after the pressure ``kappa`` [nf] acts for ``dt`` on ``v_base``
    (not additive in ``kappa``: ``wall_kappa`` clamps)."""
    nf = geo.idx.shape[0]
    a = pressure_acceleration(geo, kappa, model)
    return halo.sync(v_base.at[:nf].add(jnp.where(fluid_row[:, None], dt * a, 0.0)))


def _step_size(geo: Geometry, o: _Options):
    """The Jacobi step [nf] ``relaxation / (dt^2 S_i)`` of the solve's operator (``Geometry``)."""
    return o.relaxation * (geo.factor if _WALL_WEIGHT[o.model] == 1.0 else geo.wall_factor) / o.dt**2


def _iterate(o: _Options, geo: Geometry, v, kappa0, fluid_row, solved) -> _Solve:
    """Projected Jacobi (module docstring) from the warm start ``kappa0`` [nf] (applied first);
    ``o.fixed``: the sweeps of the differentiable form (None: while_loop). ``solved`` [nf]: the fluid
    rows whose residual the solve drives (the others keep the warm start's pressure)."""
    nf = geo.idx.shape[0]
    counted = halo.owned(fluid_row)  # the rows whose residuals this device adds to the mean
    n_fluid = jnp.maximum(halo.total(jnp.sum(counted)), 1)
    step_size = _step_size(geo, o)

    v_base = v

    def sweep(v, kappa):
        r = jnp.where(solved, o.residual(geo, v), 0.0)
        new = halo.sync(jnp.where(fluid_row, jnp.maximum(kappa + step_size * r, 0.0), 0.0))
        e = jnp.where((new > 0) | (r > 0), jnp.abs(r), 0.0)
        mine = e if counted is fluid_row else jnp.where(counted, e, 0.0)  # (e is 0 off the fluid rows)
        err = halo.total(jnp.sum(mine)) / n_fluid
        return _velocity(geo, v_base, new, fluid_row, o.dt, o.model), new, err, e

    v = _velocity(geo, v_base, kappa0, fluid_row, o.dt, o.model)
    inf = jnp.asarray(jnp.inf, v.dtype)
    init = (jnp.zeros((), jnp.int32), v, kappa0, inf, jnp.zeros((nf,), v.dtype))
    if o.fixed is None:
        def cond(c):
            it, _, _, err, _ = c
            return (it < o.min_iterations) | ((err > o.tolerance) & (it < o.max_iterations))

        def body(c):
            it, v, kappa, _, _ = c
            return (it + 1,) + sweep(v, kappa)

        return _finish(jax.lax.while_loop(cond, body, init))

    def body(_, c):  # every sweep runs: a sweep count that switched with the parameters would make the
        # result jump (a masked finish did: the secants of the dam break's energy in h disagreed 2x)
        it, v, kappa, _, _ = c
        return (it + 1,) + sweep(v, kappa)

    return _finish(jax.lax.fori_loop(0, o.fixed, body, init))


@functools.partial(jax.custom_vjp, nondiff_argnums=(0,))
def _implicit(o: _Options, geo: Geometry, v, kappa0, fluid_row, solved) -> _Solve:
    """``_iterate`` whose reverse mode is the implicit function theorem at its result (module
    docstring, "Gradients")."""
    return _iterate(o, geo, v, kappa0, fluid_row, solved)


def _implicit_fwd(o, geo, v, kappa0, fluid_row, solved):
    out = _iterate(o, geo, v, kappa0, fluid_row, solved)
    return out, (geo, v, kappa0, out.kappa, fluid_row, solved)


def _implicit_bwd(o: _Options, res, ct: _Solve):
    """Cotangents of ``(geo, v, kappa0)`` from those of the solve's ``v`` and ``kappa`` (its error
    diagnostics carry none). On the rows the solve drives with a positive pressure (the active set
    A) the result satisfies ``r_A(kappa, theta) = 0``, ``theta = (geo, v)``; the adjoint
    ``mu`` solves ``J_AA^T mu = kbar_A`` (``J = dr / dkappa``, ``kbar`` the pressure's cotangent plus
    what the velocity sends back to it) by ``adjoint_iterations`` Jacobi sweeps of the forward's
    step (``J^T`` has the spectrum of ``J``), and ``theta`` gets ``vbar dV/dtheta - mu dr/dtheta``.
    Rows outside A keep their pressure at 0 (clamped) or, where the solve drives no residual, at
    the warm start, which then gets their cotangent (theirs and, as a parameter of the rows in A,
    ``-mu dr/dkappa``)."""
    geo, v_base, kappa0, kappa, fluid_row, solved = res

    def velocity(k, g, vb):
        return _velocity(g, vb, k, fluid_row, o.dt, o.model)

    def residual(k, g, vb):
        return jnp.where(solved, o.residual(g, velocity(k, g, vb)), 0.0)

    _, pull_v = jax.vjp(velocity, kappa, geo, v_base)
    k_v, g_v, vb_v = pull_v(ct.v)
    kbar = ct.kappa + k_v
    step = _step_size(geo, o)
    drives = solved & (step > 0)  # a row without neighbours (step 0) keeps its warm start too
    active = drives & (kappa > 0)
    b = jnp.where(active, kbar, 0.0)
    _, pull_r = jax.vjp(residual, kappa, geo, v_base)
    step = jnp.where(active, step, 0.0)

    def sweep(_, mu):
        return halo.sync(mu + step * (pull_r(mu)[0] - b))

    mu = jax.lax.fori_loop(0, o.adjoint_iterations, sweep, -step * b)
    k_r, g_r, vb_r = pull_r(mu)
    g_bar = jax.tree_util.tree_map(lambda p, q: p if p.dtype == jax.dtypes.float0 else p - q, g_v, g_r)
    # rows that keep the warm start's pressure: a parameter of the others' equations as well
    warm = fluid_row & ~drives & (kappa0 > 0)
    return g_bar, vb_v - vb_r, jnp.where(warm, kbar - k_r, 0.0), None, None


_implicit.defvjp(_implicit_fwd, _implicit_bwd)


@functools.partial(jax.custom_vjp, nondiff_argnums=(0,))
def _forward_only(o: _Options, geo: Geometry, v, kappa0, fluid_row, solved) -> _Solve:
    """``_iterate`` in its ``while_loop`` form, whose reverse mode is a clear error."""
    return _iterate(o, geo, v, kappa0, fluid_row, solved)


def _forward_only_fwd(o, geo, v, kappa0, fluid_row, solved):
    return _iterate(o, geo, v, kappa0, fluid_row, solved), None


def _forward_only_bwd(o, res, ct):
    raise ValueError("DFSPH: reverse-mode AD through a solve run to its tolerance (iterations=None) with "
                     "gradient='unrolled'; set DFSPH(iterations=n) (a fixed sweep count) or DFSPH(gradient='implicit')")


_forward_only.defvjp(_forward_only_fwd, _forward_only_bwd)


def _solve(geo: Geometry, v, kappa0, residual, fluid_row, solved, *, implicit: bool, **options) -> _Solve:
    """One solve (``_iterate``) for the signed ``residual(geo, v)`` [nf] on the rows ``solved``;
    ``implicit``: reverse mode by the implicit function theorem (``_implicit``) instead of through
    the sweeps."""
    o = _Options(residual=residual, **options)
    if implicit:
        return _implicit(o, geo, v, kappa0, fluid_row, solved)
    return (_forward_only if o.fixed is None else _iterate)(o, geo, v, kappa0, fluid_row, solved)


def _finish(carry) -> _Solve:
    it, v, kappa, err, e = carry
    return _Solve(v=v, kappa=kappa, error=err, row_error=e, iterations=it)


def _non_pressure_acceleration(pr, x, v, rho, vol, kind, nbrs, params: Params, config: Config):
    """Gravity plus the scheme's viscous term [nf, 3] m/s^2 (``sph.viscosity``, pressures zero) over
    the fluid rows' pairs ``pr``."""
    from . import wcsph

    scheme = config.scheme
    f = params.fluid
    nf = config.n_fluid
    fluid_row = kind[:nf] == Kind.FLUID
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


def _divergence_residual(geo: Geometry, v, *, dt: float):
    """The divergence solve's residual [nf]: ``dt D_i(v)`` (``advance`` drives it only on rows with
    at least ``min_neighbours`` neighbours: a free surface's missing neighbours are not compression)."""
    return dt * divergence(geo, v)


def _density_residual(geo: Geometry, v, *, dt: float, weight: float):
    """The density solve's residual [nf]: ``rho_i / rho0 + dt D_i(v) - 1``, the wall terms of ``D``
    weighted by ``weight`` (``_WALL_WEIGHT``)."""
    return geo.rho + dt * divergence(geo, v, weight) - 1.0


def _solver_array(P: Particles, config: Config):
    """``P.solver``, or the scheme's empty record for a state made without one (a scene built for
    another scheme and given ``Config.replace(scheme=DFSPH())``)."""
    return P.solver if P.solver is not None else config.scheme.initial_solver(P.x.shape[0], P.x.dtype)


def _densities(P: Particles, geo: Geometry, params: Params, nf: int):
    """``Particles.rho`` [N] with the fluid rows' summed densities (walls as they were)."""
    fluid_row = P.kind[:nf] == Kind.FLUID
    return P.rho.at[:nf].set(jnp.where(fluid_row, params.fluid.rho0 * geo.rho, P.rho[:nf]))


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """Fill the summed densities and an empty ``Particles.solver`` (the first step solves from zero)."""
    geo = geometry(P.x, P.kind, P.vol, nbrs, params, config)
    return P.replace(rho=_densities(P, geo, params, config.n_fluid), solver=_solver_array(P, config))


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
    pr = pairs(P.x, kind, nbrs.idx, config)  # the step's one pair geometry
    geo = geometry(P.x, kind, P.vol, nbrs, params, config, pr=pr)
    rho = _densities(P, geo, params, nf)
    loop = dict(max_iterations=scheme.max_iterations, fixed=scheme.iterations, relaxation=scheme.relaxation, dt=dt,
                adjoint_iterations=scheme.adjoint_iterations, implicit=scheme.gradient == "implicit")

    v0 = P.v
    v = v0
    zeros = jnp.zeros((nf,), v.dtype)
    sv = _Solve(v=v, kappa=zeros, error=jnp.zeros((), v.dtype), row_error=zeros, iterations=jnp.zeros((), jnp.int32))
    if scheme.divergence_solve:
        sv = _solve(geo, v, scheme.warm_start * solver[:nf, 1], functools.partial(_divergence_residual, dt=dt),
                    fluid_row, fluid_row & (geo.count >= scheme.min_neighbours), tolerance=scheme.divergence_tolerance,
                    min_iterations=scheme.min_divergence_iterations, model="akinci", **loop)
        v = sv.v

    a_np = _non_pressure_acceleration(pr, P.x, v, rho, P.vol, kind, nbrs, params, config)
    v_visc = v
    v = v.at[:nf].add(dt * a_np)
    sd = _solve(geo, v, scheme.warm_start * solver[:nf, 0], functools.partial(
                _density_residual, dt=dt, weight=_WALL_WEIGHT[scheme.wall_pressure]), fluid_row, fluid_row,
                tolerance=scheme.tolerance, min_iterations=scheme.min_iterations, model=scheme.wall_pressure, **loop)
    v = jnp.where(fluid[:, None], sd.v, P.v)
    drift = dt * v
    if scheme.shifting.active:  # ``sph.shifting``: on the step's start (x, v), with the drift
        drift = drift + scheme.shifting.displacement(P, nbrs, params, config)
    x_new = wrap_positions(jnp.where(fluid[:, None], P.x + drift, P.x), config.grid)
    kappa = sd.kappa + sv.kappa
    n = P.x.shape[0]
    pad = lambda c: jnp.concatenate([c, jnp.zeros((n - nf,), c.dtype)])  # noqa: E731
    cols = [sd.kappa, sv.kappa, sd.row_error, sv.row_error,
            jnp.full((nf,), sd.iterations, v.dtype), jnp.full((nf,), sv.iterations, v.dtype)]
    P_new = P.replace(x=x_new, v=v, a=jnp.where(fluid[:, None], (v - v0) / dt, 0.0), rho=rho,
                      p=P.p.at[:nf].set(jnp.where(fluid_row, f.rho0 * kappa, 0.0)), drho_dt=jnp.zeros_like(P.rho),
                      solver=jnp.stack([pad(c) for c in cols], axis=1))
    if not bodies:
        return P_new
    return P_new, _body_pair_forces(P, sd.kappa, sv.kappa, v_visc, rho, nbrs, bodies, params, config)


def _body_pair_forces(P, kappa_density, kappa_divergence, v, rho, nbrs, bodies, params: Params, config: Config):
    """Per (fluid row, block particle) pair of the list: the force on the fluid particle from the
    block particle over the step: pressure ``-m_i V_b (kappa_i + kappa_b) grad W_ib`` of each solve's
    pressure with its wall model (what the solves applied, ``pressure_acceleration``,
    ``wall_kappa``) plus the viscous pair term (``wcsph.wall_pair_forces`` with zero
    pressure), with ``v`` the velocities the viscous term saw."""
    from . import wcsph
    from .walls import wall_pair_geometry

    f = params.fluid
    bp = wall_pair_geometry(P.x, nbrs, config.grid, bodies=config.has_body_pairs)
    body_j = take(P.body, bp.col)
    on = bp.valid & (take(P.kind, bp.row) == Kind.FLUID) & jnp.isin(body_j, jnp.asarray(bodies, body_j.dtype))
    F = jnp.where(on, config.scheme.kernel.f(bp.r, f.h), 0.0)
    vol = _volumes(P.vol, f.h, config.scheme.kernel)
    model = config.scheme.wall_pressure
    rise = _rise(params, bp.d)
    row = jnp.minimum(bp.row, kappa_density.shape[0] - 1)
    kappa = 0.0
    for k, m in ((kappa_density, model), (kappa_divergence, "akinci")):
        ki = take(k, row)
        kappa = kappa + ki + wall_kappa(ki, rise, m, soft_width(params))
    coef = -(f.rho0 * take(P.vol, bp.row)) * take(vol, bp.col) * kappa * F
    visc = wcsph.wall_pair_forces(bp, on, v, rho, jnp.zeros_like(P.p), P.vol, params, config)
    return bp.row, bp.col, tuple(coef * bp.d[a] + visc[a] for a in range(3)), P.x
