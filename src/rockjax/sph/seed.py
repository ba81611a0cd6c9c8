"""The seed paper's scheme (``SeedScheme``; Mikola & Sitar 2013, section 6.2).

* density by summation with the poly6 kernel (seed Eq 12, 13);
* linear equation of state ``p = k (rho - rho0)`` with ``k = c0^2`` (seed Eq 17);
* symmetrised pressure force with the spiky kernel (seed Eq 14, 15);
* viscosity force with the viscosity kernel's Laplacian (seed Eq 18, 19), ``mu = rho0 nu``;
* repulsive boundary force at walls (seed Eq 22, here per wall particle, see below);
* symplectic Euler (seed Eq 21).

Deviations from the printed paper, each needed to make the scheme run a free-surface flow, and
each measured on the 2D Martin & Moyce dam break at a/dx = 10 (``experiments/dam_break_2d.py``;
front RMS error, unshifted; as printed the scheme gives 0.40):

1. Signs. The paper prints ``(p_i - p_j)`` in Eq 14 and ``(v_i - v_j)`` in Eq 18. As printed,
   Eq 14 is not antisymmetric in (i, j), so it would not conserve momentum (the paper says it is
   chosen "because it guarantees the symmetry of forces"), and Eq 18 would amplify velocity
   differences instead of damping them. We use the forms of Mueller et al. (2003), which the
   paper cites: ``(p_i + p_j) / (2 rho_j)`` and ``(v_j - v_i)``.
2. Pressure clamp ``p = max(k (rho - rho0), 0)``. Summation density is short of ``rho0`` within
   one kernel radius of a free surface (missing neighbours), so Eq 17 gives tension there, the
   surface clumps and pulls fluid through walls (tensile instability). Clamping the summation
   pressure at zero is the usual cure (Mueller et al. 2003's successors; SPlisHSPlasH's WCSPH
   clamps the density at rho0 the same way). Without it: 0.33; with it (and 3.): 0.05.
3. Discrete kernel normalisation. On a cubic lattice the poly6 sum ``sum_j dx^3 W_ij`` is not 1
   (0.9933 at h = 1.3 dx, 1.0022 at 1.5 dx), so the at-rest lattice would sit at 0.7 % below
   rho0, i.e. under a tension of 0.0067 rho0 c0^2, several times the hydrostatic pressure of a
   small tank. The summed density is divided by the lattice sum ``lattice_sum(h, dx)``: the
   particles of an undisturbed lattice (walls included) have exactly rho0. Equivalent to choosing
   the particle mass so that the initial lattice is at rest density, as summation codes do.
4. Walls. The paper models walls as rigid blocks that repel fluid particles with the penalty
   force of Eq 22. Here fixed walls are lattice particles (DESIGN "Walls"): they contribute to the
   density sum (so the fluid near a wall has full support), carry the Adami et al. (2012)
   extrapolated pressure (``sph.walls.Adami``; clamped at zero, so they only push), and in
   addition repel with Eq 22 applied to each fluid-wall particle pair closer than ``dx`` (the
   spacing at which a fluid lattice rests on a wall):
   ``a_i += (K_S (dx - r) - K_D v_n)_+ n`` with ``n`` the unit vector from the wall particle to
   the fluid particle and ``v_n`` the normal relative velocity. The pressure clamp (2.) leaves a
   thin film (the dam-break tip) with ``p = 0``, so without the penalty nothing but viscosity
   keeps it off the floor: measured 0.11 dx below the floor surface at nu = 1e-3 m^2/s and 0.7
   dx (through the first wall layer) at nu = 1e-4; with it, the lowest particle stays 0.29 dx
   above the surface in both. The constants are not free parameters: per unit fluid mass
   ``K_S = (c0 / h)^2`` [1/s^2] and ``K_D = c0 / h`` [1/s] (damping ratio 1/2), so the
   spring's period is resolved by ``2 pi / cfl`` (25) time steps, and a particle approaching at
   the largest speed the scheme is built for (c0 / 10) is stopped within ~0.1 h. Gradients reach
   them through ``c0`` and ``h``.

An option, not the paper's (``SeedScheme(gradient=Poly6Gradient())``): the pressure force with
the gradient of the poly6 kernel that sums the density (normalised alike) instead of the spiky one.
With the spiky gradient the force is not the gradient of the scheme's elastic energy (``energies``),
and the water never comes to rest (the stress suite's collapsed column keeps a kinetic energy of
~2e-2 m g 2a); with the poly6 gradient it settles, and its 2D dam-break front is as good. The kernels
are the cause, not the paper's form ``(p_i + p_j) / (2 rho_j)``: the energy-conserving form
``p_i / rho_i^2 + p_j / rho_j^2`` wanders as much with the spiky gradient and settles with the poly6
one (RESULTS.md, "seed scheme at rest"; ``experiments/seed_rest.py``).

Pressure scale: Mueller's symmetrised force ``(p_i + p_j) / 2`` (Eq 14) is half the SPH estimate of
the pressure gradient, so the scheme's ``p`` at rest is about twice the hydrostatic pressure (a still
tank: 2.0-2.1 times with the spiky gradient, 1.5-1.9 with poly6; ``experiments/seed_rest.py
--hydrostatic``) and its sound speed c0 / sqrt(2): the forces (and a block's loads, taken from them)
carry p / 2. ``energies`` keeps the elastic energy of ``p`` itself (noticed, not changed: the
energy the scheme approximately conserves has half that elastic term).

The paper's viscosity (Eq 18) is the only dissipation; the scene builders default the seed
scheme to ``nu = 1e-3 m^2/s`` (its Reynolds number in the test dam break is ~100, which the front
speed tolerates: 0.07 front error vs 0.05 at nu = 1e-4, where the run is noisier).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..types import Config, Kind, NeighbourList, Params, Particles
from .eos import linear_density, linear_pressure
from .kernels import SUPPORT_FACTOR, poly6, viscosity_laplacian
from .neighbours import Pairs, pairs, transpose_sum, wrap_positions
from .walls import adami_pressure

__all__ = ["density", "pressure", "pressure_coefficient", "forces", "body_accelerations", "advance", "prime", "lattice_sum", "wall_constants",
           "wall_repulsion", "energies", "LATTICE_REACH"]

#: ``lattice_sum`` covers lattice offsets up to this many spacings per axis: valid for 2h <= 8 dx.
LATTICE_REACH = 8
_OFF = np.arange(-LATTICE_REACH, LATTICE_REACH + 1)
_LATTICE_R2 = (np.stack(np.meshgrid(_OFF, _OFF, _OFF, indexing="ij"), -1).reshape(-1, 3) ** 2).sum(-1)


def lattice_sum(h, dx):
    """``sum_j dx^3 W_poly6(|x_j|, h)`` over the cubic lattice of spacing ``dx`` [m] (dimensionless).

    The discrete normalisation of the poly6 kernel (1 for a continuum); valid for
    ``SUPPORT_FACTOR * h <= LATTICE_REACH * dx``. Differentiable in ``h`` and ``dx``.
    """
    r = jnp.sqrt(jnp.asarray(_LATTICE_R2, jnp.result_type(h, dx))) * dx
    return dx**3 * jnp.sum(poly6(r, h))


def _spacing(vol):
    """Particle spacing dx [m] from the reference volumes [N] m^3 (uniform lattice)."""
    return jnp.cbrt(jnp.max(vol))


def wall_constants(params: Params):
    """``(K_S [1/s^2], K_D [1/s])`` of the wall repulsion (seed Eq 22 per unit fluid mass)."""
    f = params.fluid
    return (f.c0 / f.h) ** 2, f.c0 / f.h


def density(pr: Pairs, rho, vol, kind, params: Params, config: Config):
    """Summation density (seed Eq 12) [N] kg/m^3, normalised by ``lattice_sum`` (deviation 3).

    Fluid rows sum over fluid and wall neighbours; Adami walls keep ``rho`` (their density follows
    their pressure); dynamic walls sum over their fluid neighbours and are clamped at rho0.
    """
    f = params.fluid
    nf = config.n_fluid
    m = f.rho0 * vol
    norm = lattice_sum(f.h, _spacing(vol))
    w = jnp.where(pr.mask, poly6(pr.r, f.h), 0.0)
    self_term = m * poly6(jnp.zeros((), rho.dtype), f.h)
    rho_f = (self_term[:nf] + jnp.sum(m[pr.idx] * w, axis=1)) / norm
    rho_f = jnp.where(kind[:nf] == Kind.FLUID, rho_f, rho[:nf])
    rho_w = rho[nf:]
    if config.n_wall and config.scheme.walls.dynamic:
        use = (kind[:nf, None] == Kind.FLUID) & (kind[pr.idx] == Kind.WALL)
        summed = transpose_sum(jnp.where(use, m[:nf, None] * w, 0.0), pr.idx, config.n_particles)[nf:]
        rho_w = jnp.maximum((self_term[nf:] + summed) / norm, f.rho0)
    return jnp.concatenate([rho_f, rho_w])


def pressure(pr: Pairs, rho, kind, params: Params, config: Config):
    """Pressures [N] Pa: ``max(c0^2 (rho - rho0), 0)`` (Eq 17, clamped: deviation 2) and densities [N].

    Adami walls get the extrapolated pressure and the density the linear law gives for it.
    """
    f = params.fluid
    p = jnp.maximum(linear_pressure(rho, f.rho0, f.c0), 0.0)
    if not config.scheme.walls.dynamic:
        p = adami_pressure(pr, p, rho, kind, params.gravity, f.h, poly6, config)
        rho = jnp.where(kind == Kind.WALL, linear_density(p, f.rho0, f.c0), rho)
    return p, rho


def wall_repulsion(pr: Pairs, v, vol, kind, params: Params, config: Config):
    """Seed Eq 22 per fluid-wall particle pair closer than dx: acceleration [n_fluid, 3] m/s^2."""
    nf = config.n_fluid
    idx, d = pr.idx, pr.d
    wall = pr.mask & (pr.r > 0) & (kind[idx] == Kind.WALL) & (kind[:nf, None] == Kind.FLUID)
    r0 = _spacing(vol)
    wall = wall & (pr.r < r0)
    r = jnp.where(wall, pr.r, 1.0)
    n = [jnp.where(wall, d[a] / r, 0.0) for a in range(3)]
    vn = sum((v[:nf, a, None] - v[:, a][idx]) * n[a] for a in range(3))
    ks, kd = wall_constants(params)
    mag = jnp.where(wall, jnp.maximum(ks * (r0 - r) - kd * vn, 0.0), 0.0)
    return jnp.stack([jnp.sum(mag * n[a], axis=1) for a in range(3)], 1)


def energies(P: Particles, nbrs: NeighbourList, params: Params, config: Config) -> dict:
    """Energies [J] of the seed scheme's fluid at the positions of ``P`` (density re-summed there).

    ``kinetic``, ``potential`` (``-m g . x``), ``elastic`` = ``sum m e(rho)`` with
    ``e = int_rho0^rho p / rho^2 = c0^2 (ln(rho/rho0) + rho0/rho - 1)`` for ``rho > rho0`` and 0
    below (the clamped law), ``wall`` = the potential of the Eq 22 springs ``sum m K_S (dx - r)^2 / 2``,
    and ``total``. The inviscid scheme conserves it only approximately: Mueller's symmetrised
    pressure force is not the gradient of this energy (with ``Poly6Gradient`` it is close to
    half the elastic part's, see "Pressure scale" above; with the paper's spiky gradient it is not
    proportional to it); viscosity and the wall damping dissipate.
    """
    f = params.fluid
    nf = config.n_fluid
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    rho = density(pr, P.rho, P.vol, P.kind, params, config)
    fluid = P.kind == Kind.FLUID
    m = jnp.where(fluid, f.rho0 * P.vol, 0.0)
    kinetic = 0.5 * jnp.sum(m * jnp.sum(P.v * P.v, -1))
    potential = -jnp.sum(m * (P.x @ params.gravity))
    ratio = jnp.maximum(rho, f.rho0) / f.rho0
    elastic = jnp.sum(m * f.c0**2 * (jnp.log(ratio) + 1.0 / ratio - 1.0))
    wall = jnp.zeros((), kinetic.dtype)
    if config.n_wall:
        r0 = _spacing(P.vol)
        near = pr.mask & (pr.r > 0) & (pr.r < r0) & (P.kind[pr.idx] == Kind.WALL) & fluid[:nf, None]
        ks, _ = wall_constants(params)
        wall = jnp.sum(m[:nf, None] * jnp.where(near, 0.5 * ks * (r0 - pr.r) ** 2, 0.0))
    return {"kinetic": kinetic, "potential": potential, "elastic": elastic, "wall": wall,
            "total": kinetic + potential + elastic + wall}


def pressure_coefficient(m_j, p_i, p_j, rho_i, rho_j):
    """Seed Eq 14's pair coefficient [R, K]: the pressure force density on i is ``coefficient x
    (dW/dr / r) x (x_i - x_j)``, Mueller's symmetrised ``-m_j (p_i + p_j) / (2 rho_j)`` (``forces``
    divides by ``rho_i``). A module-level function so that an experiment can swap the form
    (``experiments/seed_rest.py``)."""
    del rho_i
    return -m_j * (p_i + p_j) / (2.0 * rho_j)


def forces(pr: Pairs, v, rho, p, vol, kind, params: Params, config: Config):
    """Acceleration [N, 3] m/s^2: (pressure + viscosity force) / rho + g + wall repulsion (Eq 14, 18, 20, 22)."""
    f = params.fluid
    nf = config.n_fluid
    idx, d = pr.idx, pr.d
    pair = pr.mask & (pr.r > 0)
    r = jnp.where(pair, pr.r, SUPPORT_FACTOR * f.h)
    gradient = config.scheme.gradient
    F = jnp.where(pair, gradient.f(r, f.h), 0.0)
    if gradient.normalised:  # the density's kernel, normalised as the density
        F = F / lattice_sum(f.h, _spacing(vol))
    m_j = f.rho0 * vol[idx]
    rho_j = rho[idx]
    cp = pressure_coefficient(m_j, p[:nf, None], p[idx], rho[:nf, None], rho_j) * F
    cv = f.rho0 * f.nu * m_j / rho_j * jnp.where(pair, viscosity_laplacian(pr.r, f.h), 0.0)
    acc = jnp.stack([jnp.sum(cp * d[a] + cv * (v[:, a][idx] - v[:nf, a, None]), axis=1) for a in range(3)], 1)
    acc = acc / rho[:nf, None] + params.gravity
    if config.n_wall:
        acc = acc + wall_repulsion(pr, v, vol, kind, params, config)
    acc = jnp.where((kind[:nf] == Kind.FLUID)[:, None], acc, 0.0)
    return jnp.concatenate([acc, jnp.zeros((config.n_wall, 3), acc.dtype)])


def body_accelerations(pr: Pairs, P: Particles, bodies: tuple[int, ...], params: Params, config: Config):
    """The part of each fluid particle's acceleration (``forces``) due to the particles carried by
    each block in ``bodies`` (``P.body``; boundary-particle coupling): [n_fluid, len(bodies), 3]
    m/s^2 -- pressure, viscosity and the Eq 22 repulsion of those pairs only, with the densities and
    pressures of ``P``. Its reaction is the block's load (``coupling.boundary_particles``)."""
    nf = config.n_fluid
    body_j = P.body[pr.idx]
    out = []
    for b in bodies:
        only_b = pr._replace(mask=pr.mask & (body_j == b))
        out.append(forces(only_b, P.v, P.rho, P.p, P.vol, P.kind, params, config)[:nf] - params.gravity)
    fluid = (P.kind[:nf] == Kind.FLUID)[:, None, None]
    return jnp.where(fluid, jnp.stack(out, axis=1), 0.0)


def prime(P: Particles, nbrs: NeighbourList, params: Params, config: Config, *, bodies: tuple[int, ...] = ()):
    """Fill density, pressure and acceleration for the current positions; with ``bodies`` also
    return ``body_accelerations`` for them: ``(Particles, [n_fluid, len(bodies), 3])``."""
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    rho = density(pr, P.rho, P.vol, P.kind, params, config)
    p, rho = pressure(pr, rho, P.kind, params, config)
    a = forces(pr, P.v, rho, p, P.vol, P.kind, params, config)
    P = P.replace(rho=rho, p=p, a=a, drho_dt=jnp.zeros_like(rho))
    return (P, body_accelerations(pr, P, bodies, params, config)) if bodies else P


def advance(P: Particles, nbrs: NeighbourList, params: Params, config: Config, *, bodies: tuple[int, ...] = ()):
    """One symplectic-Euler step (seed Eq 21): v += dt a(x); x += dt v.

    With ``bodies`` (blocks carrying boundary particles) returns ``(Particles, acc_bodies)``, the
    part of the acceleration of this step due to each block's particles (``body_accelerations``)."""
    out = prime(P, nbrs, params, config, bodies=bodies)
    P = out[0] if bodies else out
    fluid = (P.kind == Kind.FLUID)[:, None]
    v_new = jnp.where(fluid, P.v + config.dt * P.a, P.v)
    x_new = wrap_positions(jnp.where(fluid, P.x + config.dt * v_new, P.x), config.grid)
    P = P.replace(x=x_new, v=v_new)
    return (P, out[1]) if bodies else P
