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

The block gets the equal and opposite force and its torque about the centroid, so the momentum
exchanged is exactly zero (the test checks it to round-off). Only blocks that move (dynamic or
prescribed) couple; fixed geometry is met by the fluid as wall particles.
"""

from __future__ import annotations

import jax.numpy as jnp

from ..blocks.rotation import quat_matrix
from ..types import Config, CouplingState, Kind, Params, Particles

__all__ = ["accelerations", "apply", "load", "coupled_blocks"]


def coupled_blocks(config: Config) -> tuple[int, ...]:
    """Indices of the blocks that exchange forces with the water (those that are not FIXED)."""
    return tuple(i for i, m in enumerate(config.blocks.motion) if getattr(m, "name", str(m)) != "FIXED")


def accelerations(P: Particles, blocks, params: Params, config: Config):
    """Penalty accelerations of the fluid and the per-pair data for the block reaction.

    Args:
        P: particles (fluid segment first); blocks: ``BlockState``; params: needs ``coupling``.

    Returns:
        ``acc`` [n_fluid, Bc, 3] m/s^2, acceleration of fluid particle i due to coupled block b;
        ``r`` [n_fluid, Bc, 3] m, the lever arm x_i - X_b; ``idx`` the coupled block indices.
    """
    idx = coupled_blocks(config)
    nf = config.n_fluid
    cp = params.coupling
    sel = jnp.asarray(idx, jnp.int32)
    X = blocks.x[sel]  # [Bc, 3]
    R = quat_matrix(blocks.q[sel])  # [Bc, 3, 3]
    V = blocks.v[sel]
    W = blocks.omega[sel]
    normals = blocks.shape.face_normal[sel]  # [Bc, F, 3] body frame
    offsets = blocks.shape.face_offset[sel]  # [Bc, F]
    fmask = blocks.shape.face_mask[sel]
    x = P.x[:nf]
    r = x[:, None, :] - X[None]  # [nf, Bc, 3]
    if config.grid is not None and any(config.grid.periodic):
        L = jnp.asarray(config.grid.lengths, x.dtype)
        per = jnp.asarray(config.grid.periodic)
        r = jnp.where(per, r - L * jnp.round(r / L), r)
    r_body = jnp.einsum("nbk,bkj->nbj", r, R)  # R^T r
    s_f = jnp.einsum("nbj,bfj->nbf", r_body, normals) - offsets[None]
    s_f = jnp.where(fmask[None], s_f, -jnp.inf)
    face = jnp.argmax(s_f, axis=-1)  # [nf, Bc]
    s = jnp.max(s_f, axis=-1)
    n_body = jnp.take_along_axis(normals[None], face[..., None, None], axis=2)[..., 0, :]  # [nf, Bc, 3]
    n = jnp.einsum("bjk,nbk->nbj", R, n_body)
    d = cp.interaction_distance - s
    v_surf = V[None] + jnp.cross(W[None], r)
    vn = jnp.sum((P.v[:nf, None, :] - v_surf) * n, -1)
    mag = cp.penalty_stiffness * d - cp.penalty_damping * vn
    fluid = (P.kind[:nf] == Kind.FLUID)[:, None]
    on = fluid & (d > 0)
    mag = jnp.where(on, jnp.maximum(mag, 0.0), 0.0)
    return mag[..., None] * n, r, idx


def _reaction(P: Particles, acc, r, idx, params: Params, config: Config, n_blocks: int) -> CouplingState:
    m = (params.fluid.rho0 * P.vol[: config.n_fluid])[:, None, None]
    f_on_fluid = m * acc  # [nf, Bc, 3]
    force_c = -jnp.sum(f_on_fluid, axis=0)
    torque_c = -jnp.sum(jnp.cross(r, f_on_fluid), axis=0)
    sel = jnp.asarray(idx, jnp.int32)
    zero = jnp.zeros((n_blocks, 3), acc.dtype)
    return CouplingState(force=zero.at[sel].set(force_c), torque=zero.at[sel].set(torque_c))


def load(P: Particles, blocks, params: Params, config: Config) -> CouplingState:
    """The fluid's load on every block [B, 3] for the current positions (no change to the fluid)."""
    acc, r, idx = accelerations(P, blocks, params, config)
    return _reaction(P, acc, r, idx, params, config, blocks.x.shape[0])


def apply(P: Particles, blocks, params: Params, config: Config):
    """Kick the fluid by ``dt`` times the penalty acceleration; return (particles, load on blocks).

    This is a separate kick after the fluid's kick-drift-kick (operator splitting), so the
    fluid's stored acceleration ``P.a`` stays the SPH one.
    """
    acc, r, idx = accelerations(P, blocks, params, config)
    a = jnp.sum(acc, axis=1)
    nf = config.n_fluid
    v = P.v.at[:nf].add(config.dt * a)
    return P.replace(v=v), _reaction(P, acc, r, idx, params, config, blocks.x.shape[0])
