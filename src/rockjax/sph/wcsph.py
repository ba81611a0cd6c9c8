"""The accurate weakly compressible scheme (``sph.schemes.WCSPH``, the default).

* continuity equation ``drho_i/dt = rho_i sum_j V_j (v_i - v_j) . grad W_ij`` plus delta-SPH
  density diffusion over fluid pairs (Molteni & Colagrossi 2009; Fourtakas et al. 2019 subtract
  its hydrostatic part so a tank at rest stays at rest -- here taken about each pair's mean
  density, ``sph.diffusion.hydrostatic_pair_difference``; Antuono et al. 2010 subtract its linear part, from
  renormalised density gradients, so any linear density field -- the discrete hydrostatic one
  included -- is left alone);
* Tait equation of state;
* momentum-conserving pressure gradient ``-sum_j m_j (p_i + p_j)/(rho_i rho_j) grad W_ij``;
* Monaghan artificial viscosity or a laminar (Morris / Lo & Shao) term;
* velocity Verlet (kick-drift-kick) with one force evaluation per step; the density is advanced
  like the positions, with the mid-step velocities (``advance``); an optional particle shift
  (``sph.shifting``) joins the drift.

Speed: ``prime`` and the public sums compute the pair geometry, the kernel-gradient factor and the
neighbour kinds once (``PairTerms``) and share them. A step's two passes (continuity, momentum)
are pair functions (``_continuity_pair``, ``_momentum_pair``) summed over the rows by
``sph.pair_sum``, whose reverse mode ``Tuning.adjoint`` chooses (JAX's, or a gather-only VJP).

All physical constants come from ``Params`` so gradients reach them.
"""

from __future__ import annotations

from typing import NamedTuple, Optional

import jax
import jax.numpy as jnp

from ..types import Config, Kind, NeighbourList, Params, Particles
from . import pullbacks
from .eos import tait_density, tait_pressure
from .neighbours import Pairs, Rows, neighbour_kind, pairs, safe_norm, scan_rows, take, transpose_sum, wall_sum, wrap_positions
from .pair_sum import gathered, pair_sum, with_pullback
from .walls import adami_finish, adami_sums, adami_terms, wall_pair_geometry

__all__ = ["PairTerms", "pair_terms", "density_rate", "density_gradient", "acceleration", "pressure", "advance",
           "prime", "momentum_extra", "wall_pair_forces"]


class PairTerms(NamedTuple):
    """Per-pair quantities of the fluid rows shared by every sum of one step.

    ``pr``: the ``Pairs`` geometry; ``F``: [n_fluid, K] kernel-gradient factor ``(dW/dr)/r``
    [1/m^5], zero off ``pr.mask`` (``grad_i W_ij = F (x_i - x_j)``); ``kind_j``: [n_fluid, K]
    neighbour ``Kind`` codes.
    """

    pr: Pairs
    F: jax.Array
    kind_j: jax.Array


def pair_terms(pr: Pairs, kind, params: Params, config: Config) -> PairTerms:
    """``PairTerms`` for pairs ``pr`` and particle kinds [N]."""
    F = jnp.where(pr.mask, config.scheme.kernel.f(pr.r, params.fluid.h), 0.0)
    return PairTerms(pr=pr, F=F, kind_j=neighbour_kind(pr.idx, config))


def _antuono(config: Config) -> bool:
    """Whether the scheme's diffusion reads the renormalised density gradient (``sph.diffusion.Antuono``)."""
    return config.scheme.diffusion.renormalised_gradient


def _terms(pr: Pairs, kind, params, config, terms: Optional[PairTerms]) -> PairTerms:
    return pair_terms(pr, kind, params, config) if terms is None else terms


#: ``det C`` range over which the renormalised gradient is faded out (weight 1 above, 0 below):
#: ``C = I`` inside the fluid, det 1/8 at a flat free surface, less at free edges and corners and
#: for splashing particles with a few neighbours. There the Antuono term falls back smoothly to
#: Molteni's (gradient 0, which only dissipates). Chosen on the stress suite's column and
#: ``test_energy``'s impact: a hard switch to the uncorrected gradient let the impact raise the
#: energy twice as much; fading from higher up left the water at rest losing energy steadily.
RENORMALISATION_DET_RANGE = (0.02, 0.06)


def _renormalised_terms(d, w, drho):
    """Per-pair terms [R, K] of the renormalised gradient's sums: ``b`` (3: ``w drho x_ji``) and ``C``
    (6: ``w x_ji (x) x_ji``, upper triangle row by row), ``x_ji = -d`` (``_renormalised_gradient``)."""
    wd = w * drho
    b = tuple(-(wd * d[a]) for a in range(3))
    c = tuple(w * d[a] * d[bb] for a in range(3) for bb in range(a, 3))
    return b + c


def _renormalised_solve(sums):
    """``s C^-1 b`` per row [R, 3] from the nine summed ``_renormalised_terms`` ([R] each)."""
    b = sums[:3]
    c00, c01, c02, c11, c12, c22 = sums[3:]
    a00 = c11 * c22 - c12 * c12
    a01 = c02 * c12 - c01 * c22
    a02 = c01 * c12 - c02 * c11
    a11 = c00 * c22 - c02 * c02
    a12 = c01 * c02 - c00 * c12
    a22 = c00 * c11 - c01 * c01
    det = c00 * a00 + c01 * a01 + c02 * a02
    lo, hi = RENORMALISATION_DET_RANGE
    ok = det > lo
    scale = jnp.where(ok, jnp.clip((det - lo) / (hi - lo), 0.0, 1.0) / jnp.where(ok, det, 1.0), 0.0)
    return jnp.stack([(a00 * b[0] + a01 * b[1] + a02 * b[2]) * scale,
                      (a01 * b[0] + a11 * b[1] + a12 * b[2]) * scale,
                      (a02 * b[0] + a12 * b[1] + a22 * b[2]) * scale], axis=1)


def _renormalised_gradient(d, w, drho):
    """``s C^-1 b`` per row, ``b = sum_k w drho x_ji``, ``C = sum_k w x_ji (x) x_ji`` (``x_ji = -d``): [R, 3].

    ``d``: three [R, K] arrays ``x_i - x_j``; ``w`` [R, K] the pair weights ``V_j (-F_ij) >= 0``
    (zero off the pairs that count); ``drho`` [R, K] ``rho_j - rho_i``. ``s`` fades the estimate
    out where ``C`` is poorly conditioned (``RENORMALISATION_DET_RANGE``).
    """
    return _renormalised_solve(tuple(jnp.sum(t, axis=1) for t in _renormalised_terms(d, w, drho)))


def _density_gradient_rows(pr: Pairs, t: PairTerms, rho, vol, params: Params):
    """Renormalised density gradient of a block of rows over their fluid neighbours: [R, 3] kg/m^4.

    ``g_i = C_i^-1 b_i`` with ``b_i = sum_j V_j (rho_j - rho_i) (-F_ij) x_ji`` and
    ``C_i = sum_j V_j (-F_ij) x_ji (x) x_ji`` (Randles & Libersky 1996; the ``L`` of Antuono et al.
    2010): exact for a linear density field wherever ``det C`` exceeds the top of
    ``RENORMALISATION_DET_RANGE`` (inside, at flat free surfaces and walls); faded to 0 below it.
    """
    f = params.fluid
    rho_j = take(rho, pr.idx)
    w = jnp.where(t.kind_j == Kind.FLUID, (-f.rho0) * take(vol, pr.idx) / rho_j * t.F, 0.0)  # V_j (-F) >= 0
    return _renormalised_gradient(pr.d, w, rho_j - pr.rows.of(rho)[:, None])


def density_gradient(pr: Pairs, rho, vol, kind, params: Params, config: Config, *,
                     terms: Optional[PairTerms] = None):
    """Renormalised density gradient [N, 3] kg/m^4 of the fluid rows (zero on walls): see
    ``_density_gradient_rows``. Used by ``sph.diffusion.Antuono``."""
    t = _terms(pr, kind, params, config, terms)
    g = _density_gradient_rows(pr, t, rho, vol, params)
    return jnp.concatenate([g, jnp.zeros((config.n_wall, 3), g.dtype)])


def pressure(pr: Pairs, rho, kind, params: Params, config: Config, *, terms: Optional[PairTerms] = None):
    """Pressures [N] Pa (Tait for fluid; walls per ``config.scheme.walls``) and densities [N].

    Wall densities are replaced by the density the EOS gives for the wall pressure (Adami) or
    clamped at rho0 (dynamic boundary particles, as DualSPHysics does).
    """
    f = params.fluid
    p = tait_pressure(rho, f.rho0, f.c0, config.scheme.gamma)
    sums = None
    if not config.scheme.walls.dynamic and config.n_wall:
        w_fn = config.scheme.kernel.w
        kind_j = None if terms is None else terms.kind_j
        rows = pr.rows
        sums = transpose_sum(adami_terms(pr, rows.of(p), rows.of(rho), kind, params.gravity, f.h, w_fn,
                                         kind_j=kind_j), pr.idx, config.n_particles)
    return _wall_pressure(p, rho, kind, sums, params, config)


def _wall_pressure(p, rho, kind, adami_sums, params: Params, config: Config):
    """Replace the walls' pressure and density (``pressure``), given the summed ``adami_terms``."""
    f = params.fluid
    wall = kind == Kind.WALL
    gamma = config.scheme.gamma
    if not config.scheme.walls.dynamic:
        if adami_sums is None:
            return p, rho
        p = adami_finish(adami_sums, p, kind, config)
        return p, jnp.where(wall, tait_density(p, f.rho0, f.c0, gamma), rho)
    rho = jnp.where(wall, jnp.maximum(rho, f.rho0), rho)
    return jnp.where(wall, tait_pressure(rho, f.rho0, f.c0, gamma), p), rho


def _diffusion_pairs(kind_j, rho_j, params: Params, config: Config):
    """Which pairs [R, K] the density diffusion runs over: the fluid pairs (``kind_j`` the
    neighbours' kinds, ``rho_j`` their densities; the signature lets experiments try others).

    Not the wet Adami wall pairs too (DualSPHysics' "full" Fourtakas variant): at rest they helped
    little, and in the stress suite's 20 m/s block impact they let water through the tank's walls
    (``experiments/energy_creep.py --variants``; docs/notes.md).
    """
    return kind_j == Kind.FLUID


_V = ("v0", "v1", "v2")
_G = ("g0", "g1", "g2")


def _kernel_factor(d, mask, params: Params, config: Config):
    """``(r2 [m^2], F [1/m^5])`` of pairs with separations ``d`` (three arrays): ``F = (dW/dr)/r``, zero off ``mask``."""
    r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    return r2, jnp.where(mask, config.scheme.kernel.f(safe_norm(r2), params.fluid.h), 0.0)


@with_pullback(pullbacks.continuity)
def _continuity_pair(ri, cj, d, params: Params, mask, fluid_j, config: Config):
    """The continuity term of pair (i, j) [R, K] kg/m^3/s: ``rho_i V_j (v_i - v_j) . grad W_ij`` plus the
    density diffusion (a ``sph.pair_sum`` pair function).

    ``ri``: the rows' ``rho`` and velocity components ``v0``-``v2`` (``g0``-``g2``, the
    renormalised density gradient, with ``sph.diffusion.Antuono``); ``cj``: the same of the
    neighbours plus ``vol``; ``d``: ``x_i - x_j``; ``mask``: real pairs; ``fluid_j``: fluid neighbours.
    """
    f = params.fluid
    _, F = _kernel_factor(d, mask, params, config)
    rho_i, rho_j = ri["rho"], cj["rho"]
    V_j = f.rho0 * cj["vol"] / rho_j  # neighbour volumes m^3
    vr = sum((ri[_V[a]] - cj[_V[a]]) * d[a] for a in range(3))
    drho = rho_i * V_j * vr * F
    dd = config.scheme.diffusion
    if dd.active:
        diff = dd.difference(ri, cj, d, rho_i, rho_j, params, config.scheme.gamma)
        kind_j = jnp.where(fluid_j, jnp.int32(Kind.FLUID), jnp.int32(Kind.WALL))
        use = _diffusion_pairs(kind_j, rho_j, params, config)
        drho = drho + jnp.where(use, (-2.0 * f.delta * f.h * f.c0) * V_j * diff * F, 0.0)
    return (drho,)


def _continuity_values(v, rho, vol, grad_rho, config: Config):
    """``(row values, column values)`` of ``_continuity_pair``: dicts of [N] arrays."""
    rows = {"rho": rho, **{_V[a]: v[:, a] for a in range(3)}}
    if _antuono(config):
        rows.update({_G[a]: grad_rho[:, a] for a in range(3)})
    return rows, dict(rows, vol=vol)


def _continuity_rows(pr: Pairs, t: PairTerms, v, rho, vol, kind, params: Params, config: Config, *,
                     wall_terms: bool = True, grad_rho=None):
    """Continuity sums of a block of rows: ``(drho/dt [R], wall terms [R, K] or None)``.

    ``grad_rho`` [N, 3]: the renormalised density gradients (``density_gradient``), needed by
    ``sph.diffusion.Antuono`` only.

    The wall terms ``V_i (v_ij . x_ij) F_ij`` on fluid-to-wall pairs (dynamic walls only, and
    only if ``wall_terms``), summed onto the walls by ``transpose_sum`` and multiplied by the wall
    density, give the walls' rate.
    """
    f = params.fluid
    rows = pr.rows
    ri, cj = gathered(pr, *_continuity_values(v, rho, vol, grad_rho, config), config)
    (drho,) = _continuity_pair(ri, cj, pr.d, params, pr.mask, t.kind_j == Kind.FLUID, config)
    fluid = rows.of(kind) == Kind.FLUID
    wall_out = None
    if wall_terms and config.n_wall and config.scheme.walls.dynamic:
        # wall j: rho_j sum_i V_i (v_j - v_i) . grad_j W_ji = rho_j sum_i V_i (v_ij . x_ij) F_ij
        vr = sum((ri[_V[a]] - cj[_V[a]]) * pr.d[a] for a in range(3))
        V_i = f.rho0 * rows.of(vol) / rows.of(rho)
        use = pr.mask & fluid[:, None] & (t.kind_j == Kind.WALL)
        wall_out = jnp.where(use, V_i[:, None] * vr * t.F, 0.0)
    return jnp.where(fluid, jnp.sum(drho, axis=1), 0.0), wall_out


def density_rate(pr: Pairs, v, rho, vol, kind, params: Params, config: Config, *,
                 terms: Optional[PairTerms] = None):
    """Continuity equation with delta-SPH diffusion: drho/dt [N] kg/m^3/s (fluid and dynamic walls)."""
    t = _terms(pr, kind, params, config, terms)
    g = density_gradient(pr, rho, vol, kind, params, config, terms=t) if _antuono(config) else None
    drho_f, wall_terms = _continuity_rows(pr, t, v, rho, vol, kind, params, config, grad_rho=g)
    nf = config.n_fluid
    drho_w = jnp.zeros((config.n_wall,), rho.dtype)
    if wall_terms is not None:
        drho_w = rho[nf:] * transpose_sum(wall_terms, pr.idx, config.n_particles)[nf:]
    return jnp.concatenate([drho_f, drho_w])


def _pair_force_factors(m_j, rho_i, rho_j, p_i, p_j, vij, d, r2, F, fluid_j, params: Params, config: Config,
                        ri=None, cj=None):
    """Per-pair momentum factors ``(cf, lam, e)``: the acceleration of i due to j is
    ``cf d + lam v_ij + e`` (``lam``, ``e`` None where the viscous term has no such part;
    ``sph.viscosity``). Arrays of any one shape (the [R, K] rows of a pass, or the flat [M]
    wall-pair list); ``vij``, ``d``: three such arrays (``v_i - v_j``, ``x_i - x_j``); ``fluid_j``:
    True where j is fluid (else the viscous factor is ``wall_viscosity``: walls and blocks);
    ``ri``, ``cj``: the pair's value dicts, for a viscous term's own fields (``momentum_extra``)."""
    coef = -m_j * (p_i + p_j) / (rho_i * rho_j)
    q, lam, e = config.scheme.viscosity.pair(m_j, rho_i, rho_j, vij, d, r2, F, fluid_j, params, ri, cj)
    return (coef * F if q is None else (coef - q) * F), lam, e


@with_pullback(pullbacks.momentum)
def _momentum_pair(ri, cj, d, params: Params, mask, fluid_j, config: Config):
    """The acceleration of i due to j [R, K] m/s^2, three components: pressure gradient and viscosity
    (``_pair_force_factors``; a ``sph.pair_sum`` pair function). ``ri``: the rows' ``rho``, ``p``
    and ``v0``-``v2``; ``cj``: the same of the neighbours plus ``vol``; as ``_continuity_pair``."""
    r2, F = _kernel_factor(d, mask, params, config)
    m_j = params.fluid.rho0 * cj["vol"]
    vij = tuple(ri[_V[a]] - cj[_V[a]] for a in range(3))
    cf, lam, e = _pair_force_factors(m_j, ri["rho"], cj["rho"], ri["p"], cj["p"], vij, d, r2, F, fluid_j, params,
                                     config, ri, cj)
    return _combine(cf, lam, e, d, vij)


def _combine(cf, lam, e, d, vij):
    """The three components ``cf d + lam v_ij + e`` of a pair's acceleration (``_pair_force_factors``)."""
    if lam is None:
        out = tuple(cf * d[a] for a in range(3))
    else:
        out = tuple(cf * d[a] + lam * vij[a] for a in range(3))
    return out if e is None else tuple(out[a] + e[a] for a in range(3))


def _momentum_gradient_pair(ri, cj, d, params: Params, mask, fluid_j, config: Config):
    """``_momentum_pair`` and then the nine ``_renormalised_terms`` of the density gradient over the
    fluid neighbours (``_density_gradient_rows``), from the same gathers."""
    _, F = _kernel_factor(d, mask, params, config)
    w = jnp.where(fluid_j, -(params.fluid.rho0 * cj["vol"] / cj["rho"]) * F, 0.0)  # V_j (-F) >= 0
    return (_momentum_pair(ri, cj, d, params, mask, fluid_j, config)
            + _renormalised_terms(d, w, cj["rho"] - ri["rho"]))


def _momentum_values(v, rho, p, vol, extra=None):
    """``(row values, column values)`` of ``_momentum_pair``: dicts of [N] arrays (with the
    viscous term's own fields ``extra``, ``momentum_extra``)."""
    rows = {"rho": rho, "p": p, **{_V[a]: v[:, a] for a in range(3)}, **(extra or {})}
    return rows, dict(rows, vol=vol)


def viscous_velocity(x, v, kind, nbrs, params: Params, config: Config):
    """Velocities [N, 3] m/s the momentum pass uses (``v``, or with walls that mirror it, e.g.
    ``Adami(no_slip=True)``, the walls' mirrored velocities: ``sph.walls``)."""
    walls = config.scheme.walls
    if not (config.n_wall and walls.mirrors_velocity):
        return v
    return walls.viscous_velocity(v, kind, wall_pair_geometry(x, nbrs, config.grid), params, config)


def momentum_extra(x, v, rho, vol, kind, nbrs, params: Params, config: Config) -> dict:
    """The viscous term's own per-particle fields for a momentum pass at these positions, velocities
    and densities (``sph.viscosity.Viscosity.values``; empty for most terms)."""
    return config.scheme.viscosity.values(x, v, rho, vol, kind, nbrs, params, config)


def _momentum_finish(sums, fluid, params: Params, gradient: bool):
    """Acceleration [R, 3] (gravity added, zero off the ``fluid`` rows) from the summed pair
    terms, and with ``gradient`` the renormalised density gradient [R, 3] last."""
    acc = jnp.where(fluid[:, None], jnp.stack(sums[:3], axis=1) + params.gravity, 0.0)
    return (acc, _renormalised_solve(sums[3:])) if gradient else acc


def _acceleration_rows(pr: Pairs, t: PairTerms, v, rho, p, vol, kind, params: Params, config: Config, *,
                       gradient: bool = False, extra=None):
    """Momentum sums of a block of rows: acceleration [R, 3] m/s^2 (gravity included; zero off the fluid).

    With ``gradient`` also returns the rows' renormalised density gradient [R, 3] last
    (``_density_gradient_rows``, from the pass's own gathers).
    """
    ri, cj = gathered(pr, *_momentum_values(v, rho, p, vol, extra), config)
    fn = _momentum_gradient_pair if gradient else _momentum_pair
    out = fn(ri, cj, pr.d, params, pr.mask, t.kind_j == Kind.FLUID, config)
    return _momentum_finish(tuple(jnp.sum(o, axis=1) for o in out), pr.rows.of(kind) == Kind.FLUID, params, gradient)


def wall_pair_forces(wp, on, v, rho, p, vol, params: Params, config: Config, extra=None):
    """Force on the fluid particle ``wp.row`` from the wall particle ``wp.col`` of each flat wall
    pair (``sph.walls.WallPairs``), zero where not ``on`` [M]: three [M] components N,
    ``m_i (cf d + lam v_ij)``, the very pair term the momentum pass sums (``_pair_force_factors``).
    The boundary-particle coupling sums it over the pairs with block particles
    (``coupling.boundary_particles.from_pair_forces``) instead of a masked second sum over every
    slot of the rows. The per-pair factors are materialised once (``optimization_barrier``):
    fused into each of the six sums of the loads they were recomputed, 2x slower."""
    f = params.fluid
    i, j = wp.row, wp.col
    r2 = wp.d[0] * wp.d[0] + wp.d[1] * wp.d[1] + wp.d[2] * wp.d[2]
    F = jnp.where(on, config.scheme.kernel.f(wp.r, f.h), 0.0)
    vij = tuple(take(v[:, a], i) - take(v[:, a], j) for a in range(3))
    extra = extra or {}
    ri, cj = {k: take(a, i) for k, a in extra.items()}, {k: take(a, j) for k, a in extra.items()}
    cf, lam, e = _pair_force_factors(f.rho0 * take(vol, j), take(rho, i), take(rho, j), take(p, i), take(p, j), vij,
                                     wp.d, r2, F, False, params, config, ri, cj)
    m_i = jnp.where(on, f.rho0 * take(vol, i), 0.0)
    if e is not None:
        e = tuple(m_i * c for c in e)
    if lam is None:
        cf = jax.lax.optimization_barrier(m_i * cf)
        return _combine(cf, None, e, wp.d, vij)
    cf, lam = jax.lax.optimization_barrier((m_i * cf, m_i * lam))
    return _combine(cf, lam, e, wp.d, vij)


def acceleration(pr: Pairs, v, rho, p, vol, kind, params: Params, config: Config, *,
                 terms: Optional[PairTerms] = None, extra=None):
    """Pressure gradient + viscosity + gravity: acceleration [N, 3] m/s^2 (zero off the fluid).
    ``extra``: the viscous term's own fields (``momentum_extra``), where it has any."""
    t = _terms(pr, kind, params, config, terms)
    acc_f = _acceleration_rows(pr, t, v, rho, p, vol, kind, params, config, extra=extra)
    return jnp.concatenate([acc_f, jnp.zeros((config.n_wall, 3), acc_f.dtype)])


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> Particles:
    """Fill ``a``, ``drho_dt`` and ``p`` for the current positions (before the first step)."""
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    t = pair_terms(pr, P.kind, params, config)
    p, rho = pressure(pr, P.rho, P.kind, params, config, terms=t)
    drho_dt = density_rate(pr, P.v, rho, P.vol, P.kind, params, config, terms=t)
    extra = momentum_extra(P.x, P.v, rho, P.vol, P.kind, nbrs, params, config)
    v_m = viscous_velocity(P.x, P.v, P.kind, nbrs, params, config)
    a = acceleration(pr, v_m, rho, p, P.vol, P.kind, params, config, terms=t, extra=extra)
    P = P.replace(a=a, drho_dt=drho_dt, p=p, rho=rho)
    if _antuono(config):
        P = P.replace(grad_rho=density_gradient(pr, rho, P.vol, P.kind, params, config, terms=t))
    return P


def advance(P: Particles, nbrs: NeighbourList, params: Params, config: Config, *,
            bodies: tuple[int, ...] = ()):
    """One step of length ``config.dt``: velocity Verlet for (x, v), density staggered like x.

    Returns the new ``Particles``; with ``bodies`` (indices of blocks carrying boundary particles,
    ``P.body``) returns ``(Particles, (row [M], col [M], force))``: over the list's
    (fluid, block particle) pairs (``NeighbourList.body_row``; the whole wall-pair list if
    ``config.body_pair_capacity`` is 0), the force on fluid particle ``row`` from the block
    particle ``col`` that the momentum pass summed (``wall_pair_forces``: three [M] components N,
    zero for other pairs);
    ``coupling.boundary_particles.from_pair_forces`` turns it into the loads.

    ``v+ = v + dt/2 a``; ``x' = x + dt v+``; ``rho' = rho + dt Drho(x', v+)``;
    ``a' = a(x', v+, rho')``; ``v' = v+ + dt/2 a'``. Density and position are advanced with the
    same mid-step velocities, so the pressure is never half a step behind the positions (a lag
    that was measured to make the scheme unstable at Courant 0.25).

    ``sph.diffusion.Antuono`` uses ``P.grad_rho``, the renormalised density gradients that the
    previous step's momentum pass computed at (x, rho) -- one drift behind the continuity pass, an
    O(dt) lag in an O(h^2) term -- and the momentum pass computes the next ones from its own
    gathers (no extra pass; an unprimed state without them gets an extra gradient pass).

    Two passes over the rows' pairs (``pair_sum``), each in blocks of ``config.effective_row_tile`` rows (``scan_rows``;
    the pair geometry is recomputed in the second pass rather than stored, since a stored [n, K]
    array costs more memory traffic than its arithmetic): (1) continuity, then each row's new
    density and pressure; (2) the momentum sum. Between them, the walls' sums (Adami pressure or
    dynamic-wall density) run over the flat list of fluid-wall pairs (``NeighbourList.wall_row``,
    ~7 % of the pair slots in the dam break) instead of scattering every slot of every row.
    """
    dt = config.dt
    f = params.fluid
    nf, nw, n = config.n_fluid, config.n_wall, config.n_particles
    kind = P.kind
    fluid = kind == Kind.FLUID
    dynamic_walls = config.scheme.walls.dynamic
    evolving = fluid | ((kind == Kind.WALL) & dynamic_walls)
    v_half = jnp.where(fluid[:, None], P.v + 0.5 * dt * P.a, P.v)
    drift = dt * v_half
    if config.scheme.shifting.active:  # ``sph.shifting``: on the step's start (x, v), with the drift
        drift = drift + config.scheme.shifting.displacement(P, nbrs, params, config)
    x_new = wrap_positions(jnp.where(fluid[:, None], P.x + drift, P.x), config.grid)
    adami = nw > 0 and not dynamic_walls
    dynamic = nw > 0 and dynamic_walls
    w_fn = config.scheme.kernel.w
    gamma = config.scheme.gamma

    grad_rho = P.grad_rho
    if _antuono(config) and grad_rho is None:  # not primed by ``prime``: an extra pass
        def gradient_pass(rows: Rows, own, carry):
            pr = pairs(x_new, kind, nbrs.idx, config, rows=rows)
            return carry, _density_gradient_rows(pr, pair_terms(pr, kind, params, config), P.rho, P.vol, params)

        _, g_f = scan_rows(gradient_pass, nf, config.effective_row_tile, None)
        grad_rho = jnp.concatenate([g_f, jnp.zeros((nw, 3), g_f.dtype)])

    fluid_rows = fluid[:nf]
    (drho_f,) = pair_sum(_continuity_pair, x_new, *_continuity_values(v_half, P.rho, P.vol, grad_rho, config), params,
                         nbrs, kind, config)
    drho_f = jnp.where(fluid_rows, drho_f, 0.0)
    rho_f = jnp.where(evolving[:nf], P.rho[:nf] + dt * drho_f, P.rho[:nf])
    p_f = tait_pressure(rho_f, f.rho0, f.c0, gamma)
    rho_w = P.rho[nf:]
    drho_w = jnp.zeros((nw,), P.rho.dtype)
    if nw:
        wp = wall_pair_geometry(x_new, nbrs, config.grid)
    if dynamic:
        # wall j: rho_j sum_i V_i (v_j - v_i) . grad_j W_ji = rho_j sum_i V_i (v_ij . x_ij) F_ij
        f_fn = config.scheme.kernel.f
        V_i = f.rho0 * take(P.vol, wp.row) / take(P.rho, wp.row)
        vr = sum((take(v_half[:, a], wp.row) - take(v_half[:, a], wp.col)) * wp.d[a] for a in range(3))
        F = jnp.where(wp.valid, f_fn(wp.r, f.h), 0.0)
        drho_w = rho_w * wall_sum(V_i * vr * F, wp, config)[nf:]
        rho_w = jnp.where(evolving[nf:], rho_w + dt * drho_w, rho_w)
    drho_dt = jnp.concatenate([drho_f, drho_w])
    rho_new = jnp.concatenate([rho_f, rho_w])
    p = jnp.concatenate([p_f, tait_pressure(rho_w, f.rho0, f.c0, gamma)])
    sums = adami_sums(wp, p_f, rho_f, params.gravity, f.h, w_fn, config) if adami else None
    p, rho_new = _wall_pressure(p, rho_new, kind, sums, params, config)

    antuono = _antuono(config)

    extra = momentum_extra(x_new, v_half, rho_new, P.vol, kind, nbrs, params, config)
    v_m = v_half
    if nw and config.scheme.walls.mirrors_velocity:
        v_m = config.scheme.walls.viscous_velocity(v_half, kind, wp, params, config)
    m_sums = pair_sum(_momentum_gradient_pair if antuono else _momentum_pair, x_new,
                      *_momentum_values(v_m, rho_new, p, P.vol, extra), params, nbrs, kind, config)
    out = _momentum_finish(m_sums, fluid_rows, params, antuono)
    out = out if isinstance(out, tuple) else (out,)
    a_f = out[0]
    a = jnp.concatenate([a_f, jnp.zeros((nw, 3), a_f.dtype)])
    v_new = jnp.where(fluid[:, None], v_half + 0.5 * dt * a, v_half)
    P = P.replace(x=x_new, v=v_new, a=a, rho=rho_new, drho_dt=drho_dt, p=p)
    if antuono and P.grad_rho is not None:  # for the next step's diffusion (one drift behind it: an O(dt) lag)
        P = P.replace(grad_rho=jnp.concatenate([out[-1], jnp.zeros((nw, 3), a_f.dtype)]))
    if not bodies:
        return P
    bp = wall_pair_geometry(x_new, nbrs, config.grid, bodies=True) if config.has_body_pairs else wp
    body_j = take(P.body, bp.col)
    on = bp.valid & (take(kind, bp.row) == Kind.FLUID) & jnp.isin(body_j, jnp.asarray(bodies, body_j.dtype))
    return P, (bp.row, bp.col, wall_pair_forces(bp, on, v_m, rho_new, p, P.vol, params, config, extra))
