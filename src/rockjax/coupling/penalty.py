"""The seed paper's fluid-block coupling: a penalty ("repulsion") force, seed Eq 22.

A fluid particle i within the interaction distance ``r0`` of a block gets

    f_i = m_i (K_S d - K_D v_n) n,      d = r0 - s  > 0,

where ``s`` is the particle's signed distance to the block (negative inside), ``n`` the outward
unit normal of the nearest face and ``v_n = (v_i - v_block(x_i)) . n`` the normal velocity of the
particle relative to the block surface (negative while approaching). ``K_S`` [1/s^2] and
``K_D`` [1/s] are per unit fluid mass (``CouplingParams``), so one value fits every
resolution. Two choices the paper leaves open, made here:

* the signed distance to a convex block is ``max_f (n_f . r - d_f)`` over its faces (exact inside
  and in front of a face, a lower bound near edges and corners), and ``n`` is that face's normal;
* the force never pulls: ``max(K_S d - K_D v_n, 0)`` (a receding particle is not held back).

With ``Coupling.BOUNDARY_INTEGRAL`` the same function adds a semi-analytical wall term (``wall_terms``):
each fluid particle within 2h of a block gets the pressure
force and density rate of the kernel support the block cuts off (Kulasegaram et al. 2004, Ferrand
et al. 2013), so the block carries the water's pressure instead of a spring's; the penalty then only
guards (``r0 = dx / 4``, ``scenes.coupled.coupling_params``).

The block gets the equal and opposite force and its torque about the centroid, so the momentum
exchanged is exactly zero (the test checks it to round-off). Only blocks that move (dynamic or
prescribed) couple; fixed geometry is met by the fluid as wall particles (with boundary particles
and ``Config.guard_fixed``, ``guard_fixed`` also keeps it out of fixed blocks, within dx/4).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from ..blocks.laws import smooth_ramp, smoothstep, smoothstep_integral
from ..blocks.rotation import quat_matrix, safe_norm, tied_max
from ..sph.kernels import plane_integrals
from ..types import Config, CouplingState, Kind, Params, Particles
from .base import CouplingMethod

__all__ = ["Penalty", "BoundaryIntegral", "accelerations", "apply", "load", "coupled_blocks", "fixed_blocks",
           "guard_fixed", "wall_terms"]


@dataclasses.dataclass(frozen=True)
class Penalty(CouplingMethod):
    """The seed's coupling (``Coupling.PENALTY``, seed Eq 22; module docstring): after the fluid's
    step the fluid within ``CouplingParams.interaction_distance`` of a moving block is kicked by
    the penalty force, and the block takes the reaction in its next step."""

    name = "penalty"
    #: smooth onset (issue 44), a fraction of ``interaction_distance`` r0: the spring ``K_S d``
    #: becomes ``K_S d_s S(d / d_s)`` (C2; ``K_S (d - d_s/2)`` beyond ``d_s = onset r0``) and the
    #: dashpot is scaled by ``smoothstep(d / d_s)``, so a particle entering the layer starts from
    #: zero force instead of ``-K_D v_n``; the no-pull ``max(., 0)`` is rounded over ``K_S d_s / 4``.
    #: 0 (default): the seed's law as written.
    onset: float = 0.0
    #: smooth nearest face, a fraction of r0: the signed distance is ``tau logsumexp(s_f / tau)``
    #: and the normal the softmax-weighted mean of the faces' normals (``tau = face_blend r0``),
    #: so the force turns continuously round a block's edges instead of switching faces there
    #: (the same as the nearest face wherever one face leads by a few tau). 0: the nearest face.
    face_blend: float = 0.0

    def __post_init__(self):
        for nm in ("onset", "face_blend"):
            v = getattr(self, nm)
            if not (isinstance(v, (int, float)) and 0.0 <= v < float("inf")):
                raise ValueError(f"{type(self).__name__}: {nm} must be a finite number >= 0 (a fraction of the "
                                 f"interaction distance; got {v!r})")

    def exchange(self, state, params, config, *, kick: bool):
        if kick:
            P, loads = apply(state.particles, state.blocks, params, config)
            return state.replace(particles=P, coupling=loads)
        return state.replace(coupling=load(state.particles, state.blocks, params, config))


@dataclasses.dataclass(frozen=True)
class BoundaryIntegral(Penalty):
    """The semi-analytical wall term for block faces (``Coupling.BOUNDARY_INTEGRAL``, experimental;
    ``wall_terms``) with the penalty as a guard within dx/4: WCSPH only (it is written for the
    continuity equation). It does not converge for bodies in still water (RESULTS.md, "held box")."""

    name = "boundary_integral"
    wall_term = True
    needs_continuity = True


def _is_fixed(motion) -> bool:
    return getattr(motion, "name", str(motion)) == "FIXED"


def coupled_blocks(config: Config) -> tuple[int, ...]:
    """Indices of the blocks that exchange forces with the water (those that are not FIXED)."""
    return tuple(i for i, m in enumerate(config.blocks.motion) if not _is_fixed(m))


def fixed_blocks(config: Config) -> tuple[int, ...]:
    """Indices of the FIXED blocks (met by the fluid as wall particles; guarded by ``guard_fixed``)."""
    return tuple(i for i, m in enumerate(config.blocks.motion) if _is_fixed(m))


def _min_image(r, config: Config):
    """Minimum-image separations ``r`` [..., 3] along the grid's periodic axes (as given without any)."""
    if config.grid is None or not any(config.grid.periodic):
        return r
    L = jnp.asarray(config.grid.lengths, r.dtype)
    return jnp.where(jnp.asarray(config.grid.periodic), r - L * jnp.round(r / L), r)


def accelerations(P: Particles, blocks, params: Params, config: Config):
    """``(acc, r, idx)`` of ``_exchange``: the penalty (and wall-term) accelerations, lever arms and
    coupled block indices."""
    return _exchange(P, blocks, params, config)[:3]


def _exchange(P: Particles, blocks, params: Params, config: Config):
    """Penalty accelerations of the fluid and the per-pair data for the block reaction.

    Args:
        P: particles (fluid segment first); blocks: ``BlockState``; params: needs ``coupling``.

    Returns:
        ``acc`` [n_fluid, Bc, 3] m/s^2, acceleration of fluid particle i due to coupled block b;
        ``r`` [n_fluid, Bc, 3] m, the lever arm x_i - X_b; ``idx`` the coupled block indices;
        ``drho`` [n_fluid] kg/m^3/s, with ``Coupling.BOUNDARY_INTEGRAL`` the density rate the
        continuity sum misses inside the blocks (``wall_terms``), else None.

    Per block, the nearest face is found by a static loop over the faces on [n_fluid] arrays
    (signed distance and face index), then its world normal is gathered from an [F, 3] table:
    on the CPU this is several times faster than [n_fluid, Bc, F] einsums with an argmax gather,
    or a face loop carrying the normal's components (XLA fuses that chain into every component of
    the consumers).
    """
    idx = coupled_blocks(config)
    nf = config.n_fluid
    cp = params.coupling
    method = config.coupling_method
    onset, face_blend = getattr(method, "onset", 0.0), getattr(method, "face_blend", 0.0)
    x = P.x[:nf]
    v = P.v[:nf]
    fluid = P.kind[:nf] == Kind.FLUID
    R_all = quat_matrix(blocks.q[jnp.asarray(idx, jnp.int32)])  # [Bc, 3, 3]
    n_faces = blocks.shape.face_normal.shape[1]
    acc, lever = [], []
    drho = jnp.zeros((nf,), x.dtype) if config.coupling_method.wall_term else None
    for k, b in enumerate(idx):
        r = _min_image(x - blocks.x[b], config)  # [nf, 3]
        normals = blocks.shape.face_normal[b] @ R_all[k].T  # [F, 3] world frame
        offsets, fmask = blocks.shape.face_offset[b], blocks.shape.face_mask[b]
        s = jnp.full((nf,), -jnp.inf, x.dtype)  # signed distance to the block
        face = jnp.zeros((nf,), jnp.int32)
        s_faces = []  # every face's signed distance (the wall term of BOUNDARY_INTEGRAL needs them all)
        for f in range(n_faces):  # the nearest face: the largest signed distance (the first on ties)
            s_f = r[:, 0] * normals[f, 0] + r[:, 1] * normals[f, 1] + r[:, 2] * normals[f, 2] - offsets[f]
            s_faces.append(s_f)
            better = fmask[f] & (s_f > s)
            s = jnp.where(better, s_f, s)
            face = jnp.where(better, f, face)
        if face_blend > 0:  # a soft maximum over the faces (smooth round the edges)
            tau = face_blend * cp.interaction_distance
            # masked faces get a constant -inf after the division (-inf / tau would carry a NaN tangent)
            S = jnp.where(fmask[None, :], jnp.stack(s_faces, axis=1) / tau, -jnp.inf)  # [nf, F]
            s = tau * jax.nn.logsumexp(S, axis=1)
            n = jax.nn.softmax(S, axis=1) @ normals
            n = n / safe_norm(n)[:, None]
        else:
            n = normals[face]  # [nf, 3]
        v_surf = blocks.v[b] + jnp.cross(blocks.omega[b], r)
        vn = jnp.sum((v - v_surf) * n, axis=-1)
        d = cp.interaction_distance - s
        if onset > 0:
            ds = onset * cp.interaction_distance
            t = d / ds
            spring = cp.penalty_stiffness * ds * smoothstep_integral(t)
            w = smoothstep(t)  # the no-pull corner's width is ramped in too: zero force at d = 0
            mag = smooth_ramp(spring - cp.penalty_damping * vn * w, 0.25 * cp.penalty_stiffness * ds * w)
            mag = jnp.where(fluid & (d > 0), mag, 0.0)
        else:
            mag = cp.penalty_stiffness * d - cp.penalty_damping * vn
            mag = jnp.where(fluid & (d > 0), jnp.maximum(mag, 0.0), 0.0)
        a = mag[:, None] * n
        if drho is not None:
            a_w, drho_w = wall_terms(P, jnp.stack(s_faces, axis=1), v - v_surf, normals, fmask, params, config)
            a = a + jnp.where(fluid[:, None], a_w, 0.0)
            drho = drho + jnp.where(fluid, drho_w, 0.0)
        acc.append(a)
        lever.append(r)
    return jnp.stack(acc, axis=1), jnp.stack(lever, axis=1), idx, drho


def wall_terms(P: Particles, s, v_rel, normals, fmask, params: Params, config: Config):
    """``Coupling.BOUNDARY_INTEGRAL``: what a fluid particle's WCSPH sums miss where one block cuts
    its kernel support (semi-analytical wall: Kulasegaram et al. 2004, Ferrand et al. 2013).

    Args: ``s`` [n_fluid, F] m, each particle's signed distance to each face plane (positive in
    front); ``v_rel`` [n_fluid, 3] m/s, the particle's velocity relative to the block surface; the
    block's world face ``normals`` [F, 3] and ``fmask`` [F].

    Returns ``(acc [n_fluid, 3] m/s^2, drho [n_fluid] kg/m^3/s)``. By the divergence theorem the
    missing kernel gradient is ``int_block grad_x W dy = -sum_f n_f P_f``, ``P_f`` the kernel's
    integral over face f, taken as ``A(|s_f|)`` (the infinite plane's, ``sph.kernels.plane_integrals``)
    times the share of the kernel's footprint inside the face polygon: the product over the other
    faces g of ``1 - G(e_fg)`` (``G(-e)`` for e < 0), ``e_fg`` the in-plane distance from the foot
    point to the line where face f's plane meets g's (the polygon is plane f cut by the others).
    With the pressure behind a face continued hydrostatically from the particle
    (``p_f = p_i - rho_i s_f g.n_f`` at its foot point), the missing part of
    ``-sum_j V_j (p_i + p_j) grad W_ij / rho_i`` is

        a_i = sum_f (p_i + p_f) / rho_i P_f n_f - g G_b,

    ``G_b`` the kernel's volume fraction inside the block (the product of the faces' half-space
    fractions), and the missing part of the continuity sum, the surface velocity standing for the
    missing neighbours', ``-rho_i sum_f P_f v_rel . n_f``. Summed over a still water column the
    reactions give a face its hydrostatic pressure per unit area (the ``g G`` part cancels the
    ``rho g s`` excess of ``p_i``) wherever the first water layer sits. Not included: the block's
    acceleration in the continued pressure.
    """
    nf = config.n_fluid
    area_fn = plane_integrals(config.scheme.kernel)
    h = params.fluid.h
    dt = s.dtype
    on = fmask[None, :]
    # in-plane distance from face f's foot point to its edge with face g: (s_f cos - s_g) / sin
    cos = jnp.clip(normals @ normals.T, -1.0, 1.0)  # [F, F]
    sin2 = 1.0 - cos**2
    cut = (sin2 > 1e-12) & fmask[:, None] & fmask[None, :] & ~jnp.eye(cos.shape[0], dtype=bool)
    sin = jnp.sqrt(jnp.where(cut, sin2, 1.0))  # parallel faces never cut each other (and no NaN gradient)
    e = (s[:, :, None] * cos[None] - s[:, None, :]) / sin[None]  # [nf, F, G]
    g_e = area_fn(jnp.abs(e), h)[1]
    inside = jnp.where(cut[None], jnp.where(e >= 0, 1.0 - g_e, g_e), 1.0)
    area, beyond = area_fn(jnp.abs(s), h)
    face_int = jnp.where(on, area * jnp.prod(inside, axis=2), 0.0)  # P_f [nf, F] 1/m
    frac = jnp.where(on, jnp.where(s >= 0, beyond, 1.0 - beyond), 1.0)  # kernel share behind each plane
    p, rho = P.p[:nf], P.rho[:nf]
    g = params.gravity.astype(dt)
    p_face = p[:, None] - rho[:, None] * s * (normals @ g)[None, :]  # [nf, F]
    acc = ((p[:, None] + p_face) / rho[:, None] * face_int) @ normals - jnp.prod(frac, axis=1)[:, None] * g
    drho = -rho * jnp.sum(face_int * (v_rel @ normals.T), axis=1)
    return acc, drho


def _reaction(P: Particles, acc, r, idx, params: Params, config: Config, n_blocks: int) -> CouplingState:
    """Minus the sums of the penalty forces on the fluid and their moments, per coupled block
    (reduced as [n_fluid] component arrays: a reduction over the long axis of an [n_fluid, Bc, 3]
    array was ~10x slower on CPU)."""
    m = params.fluid.rho0 * P.vol[: config.n_fluid]
    if P.owned is not None:  # a decomposed scene: halo copies' reactions are counted by their owners
        m = jnp.where(P.owned[: config.n_fluid], m, 0.0)
    force, torque = [], []
    for k in range(len(idx)):
        f = [m * acc[:, k, j] for j in range(3)]  # force on the fluid [N]
        rk = [r[:, k, j] for j in range(3)]
        force.append(jnp.stack([-jnp.sum(f[j]) for j in range(3)]))
        torque.append(jnp.stack([-jnp.sum(rk[1] * f[2] - rk[2] * f[1]), -jnp.sum(rk[2] * f[0] - rk[0] * f[2]),
                                 -jnp.sum(rk[0] * f[1] - rk[1] * f[0])]))
    sel = jnp.asarray(idx, jnp.int32)
    zero = jnp.zeros((n_blocks, 3), acc.dtype)
    return CouplingState(force=zero.at[sel].set(jnp.stack(force)), torque=zero.at[sel].set(jnp.stack(torque)))


def load(P: Particles, blocks, params: Params, config: Config) -> CouplingState:
    """The fluid's load on every block [B, 3] for the current positions (no change to the fluid)."""
    acc, r, idx = accelerations(P, blocks, params, config)
    return _reaction(P, acc, r, idx, params, config, blocks.x.shape[0])


def guard_fixed(P: Particles, blocks, params: Params, config: Config) -> Particles:
    """Kick the fluid by ``dt`` times the penalty acceleration of the FIXED blocks (no reaction:
    fixed blocks take no load), within ``CouplingParams.interaction_distance`` (dx/4 by default);
    the same force as ``accelerations`` (a fixed block's surface is at rest), all fixed blocks in
    one [n_fluid, blocks, faces] evaluation (a little faster than a face loop per block). With boundary particles, ``Config.coupling_guard`` and
    ``Config.guard_fixed`` the step guards fixed blocks too: their
    faces are met by wall particles, which, like a moving block's particles, do not stop a
    particle pressed between them (in the sliding wedge one gets trapped at the toe inside the
    fixed slope). Not with the penalty coupling: there a block landing on a guarded fixed floor is
    held dx/2 + dx/4 above it on a film of water that, without the guard, is pressed into the
    floor's walls (``block_drop``).
    """
    which = fixed_blocks(config)
    if not which:
        return P
    nf, cp = config.n_fluid, params.coupling
    x, v = P.x[:nf], P.v[:nf]
    fixed = jnp.asarray(which, jnp.int32)
    normals = jnp.einsum("bfj,bij->bfi", blocks.shape.face_normal[fixed], quat_matrix(blocks.q[fixed]))  # world
    offsets = jnp.where(blocks.shape.face_mask[fixed], blocks.shape.face_offset[fixed], jnp.inf)
    r = _min_image(x[:, None, :] - blocks.x[fixed][None], config)  # [nf, Bf, 3]
    s_all = jnp.einsum("nbi,bfi->nbf", r, normals) - offsets[None]  # [nf, Bf, F] signed distances
    s = tied_max(s_all, -1)
    n = jnp.take_along_axis(normals[None], jnp.argmax(s_all, axis=-1)[..., None, None], axis=2)[:, :, 0]
    d = cp.interaction_distance - s
    mag = cp.penalty_stiffness * d - cp.penalty_damping * jnp.einsum("ni,nbi->nb", v, n)  # fixed: v_surf = 0
    mag = jnp.where((P.kind[:nf] == Kind.FLUID)[:, None] & (d > 0), jnp.maximum(mag, 0.0), 0.0)
    return P.replace(v=P.v.at[:nf].add(config.dt * jnp.einsum("nb,nbi->ni", mag, n)))


def apply(P: Particles, blocks, params: Params, config: Config):
    """Kick the fluid by ``dt`` times the penalty acceleration; return (particles, load on blocks).

    This is a separate kick after the fluid's kick-drift-kick (operator splitting), so the
    fluid's stored acceleration ``P.a`` stays the SPH one.
    """
    acc, r, idx, drho = _exchange(P, blocks, params, config)
    a = jnp.sum(acc, axis=1)
    nf = config.n_fluid
    out = P.replace(v=P.v.at[:nf].add(config.dt * a))
    if drho is not None:  # the next step's continuity pass starts from this density
        out = out.replace(rho=P.rho.at[:nf].add(config.dt * drho))
    return out, _reaction(P, acc, r, idx, params, config, blocks.x.shape[0])
