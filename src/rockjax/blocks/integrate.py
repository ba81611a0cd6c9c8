"""One explicit central-difference step of the blocks (seed Eq 5-7).

Owns :func:`advance_blocks`.  Leapfrog form of seed Eq 5-6 with a constant dt: the velocities in
the state are mid-step velocities,

    v_{n+1/2} = v_{n-1/2} + dt M^-1 F_n                 (Eq 6-7)
    x_{n+1}   = x_n + dt v_{n+1/2}                      (Eq 5)

and for rotation, with the world inertia ``I_w = R I_b R^T`` and Euler's equations,
``omega_{n+1/2} = omega_{n-1/2} + dt I_w^-1 (T_n - omega x I_w omega)`` (gyroscopic term
explicit) and ``q_{n+1} = exp(dt omega_{n+1/2} / 2) q_n`` renormalised.

FIXED blocks never move and are not integrated (only the DYNAMIC ones are gathered).  PRESCRIBED
blocks follow ``x(t) = x0 + dir S/2 sin(2 pi t / T)`` with ``v = dx/dt`` at the mid-step, orientation
``q0``, or their ``BlockConfig.paths`` entry (``paths``: tables, flaps) scaled by
``S / BlockConfig.path_stroke``: the pose at t + dt, its rate at the mid-step.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from ..types import Status
from .contact import contact_forces
from .model import BlockConfig, BlockParams, BlockState, stable_dt_jax
from .rotation import quat_integrate, quat_matrix

__all__ = ["advance_blocks", "prescribed_motion"]


def prescribed_motion(config: BlockConfig, params: BlockParams, x0, t):
    """Piston positions and velocities at time t (s).

    ``x(t) = x0 + dir S/2 r(t) sin(2 pi t / T)`` with the soft-start factor
    ``r(t) = (1 - cos(pi t / ramp)) / 2`` for ``t < ramp = config.prescribed_ramp`` and 1 after
    (``r = 1`` throughout when ``ramp = 0``); ``v = dx/dt`` exactly (both terms of the product).

    Returns:
      ``(x [B,3] m, v [B,3] m/s)`` for every block (meaningful for PRESCRIBED ones).
    """
    d = jnp.asarray(np.asarray(config.prescribed_direction, np.float64).reshape(-1, 3), x0.dtype)
    w = 2.0 * jnp.pi / params.period
    amp = 0.5 * params.stroke
    s, c = jnp.sin(w * t), jnp.cos(w * t)
    ramp = config.prescribed_ramp
    if ramp <= 0.0:
        return x0 + d * amp * s, d * amp * w * c
    phase = jnp.minimum(t, ramp) * (jnp.pi / ramp)
    r = 0.5 * (1.0 - jnp.cos(phase))
    dr = jnp.where(t < ramp, (0.5 * jnp.pi / ramp) * jnp.sin(phase), 0.0)
    return x0 + d * amp * r * s, d * amp * (r * w * c + dr * s)


def advance_blocks(state: BlockState, params: BlockParams, config: BlockConfig, *, dt, t, gravity,
                   external_force=None, external_torque=None):
    """Advance the blocks from t to t + dt.

    Args:
      dt: s (the caller's global step; must not exceed the block limit, see ``stable_dt``).
      t: s, time at the start of the step (PRESCRIBED motion).
      gravity: [3] m/s^2.
      external_force: [B,3] N or None (e.g. fluid load), on the centroid, world frame.
      external_torque: [B,3] N m or None, about the centroid, world frame.
    Returns:
      ``(state, status int32)``: status may hold CONTACT_OVERFLOW, BLOCK_CELL_OVERFLOW,
      CONTACT_POINT_OVERFLOW, CROSSING_EDGE_OVERFLOW, SUPPORT_EDGE_OVERFLOW, FCP_CROSS_OVERFLOW,
      JOINT_PATCH_OVERFLOW
      (buffers the driver grows), BLOCK_UNSTABLE (dt above the Eq 8 limit for these params),
      BLOCK_PENETRATION and NON_FINITE.
    """
    force, torque, hist, status = contact_forces(state, params, config, dt=dt, gravity=gravity)
    state = state.replace(history=hist)
    f = state.x.dtype
    gravity = jnp.asarray(gravity, f)
    if external_force is not None:
        force = force + external_force
    if external_torque is not None:
        torque = torque + external_torque
    x, v, q, om = state.x, state.v, state.q, state.omega
    dyn = config.dynamic
    if dyn:
        d = jnp.asarray(dyn)
        m = params.density[d] * state.shape.volume[d]
        vd = v[d] + dt * (force[d] / m[:, None] + gravity)
        qd = q[d]
        R = quat_matrix(qd)
        rho = params.density[d, None]
        wd = om[d]
        # in the body frame: L = R I_b R^T omega, and I_w^-1 = R I_b^-1 R^T (I_b^-1 built once)
        wb = jnp.einsum("bji,bj->bi", R, wd)
        L = jnp.einsum("bij,bj->bi", R, rho * jnp.einsum("bij,bj->bi", state.shape.inertia_unit[d], wb))
        rhs = torque[d] - jnp.cross(wd, L)
        rb_ = jnp.einsum("bji,bj->bi", R, rhs)
        wd = wd + dt * jnp.einsum("bij,bj->bi", R, jnp.einsum("bij,bj->bi", state.shape.inertia_unit_inverse[d], rb_) / rho)
        if config.locked:  # guided blocks: the locked world components held at zero (their reaction implied)
            free = np.asarray([[not b for b in config.locked[i]] for i in dyn], dtype=np.float64)
            vd = vd * jnp.asarray(free[:, :3], f)
            wd = wd * jnp.asarray(free[:, 3:], f)
        xd = x[d] + dt * vd
        qd = quat_integrate(qd, wd, dt)
        x, v, q, om = x.at[d].set(xd), v.at[d].set(vd), q.at[d].set(qd), om.at[d].set(wd)
        finite = jnp.all(jnp.isfinite(xd)) & jnp.all(jnp.isfinite(vd)) & jnp.all(jnp.isfinite(qd)) & jnp.all(
            jnp.isfinite(wd))
        status = status | jnp.where(finite, 0, Status.NON_FINITE.value).astype(jnp.int32)
        unstable = dt > stable_dt_jax(config, params, state.shape, safety=1.0)
        status = status | jnp.where(unstable, Status.BLOCK_UNSTABLE.value, 0).astype(jnp.int32)
    pre = config.prescribed
    paths = config.paths or (None,) * config.n_blocks
    on_path = [i for i in pre if paths[i] is not None]
    pre = [i for i in pre if paths[i] is None]
    if on_path:
        scale = params.stroke / config.path_stroke
        for i in on_path:
            xi, qi, _, _ = paths[i].motion(t + dt, state.x0[i], state.q0[i], scale)
            _, _, vi, wi = paths[i].motion(t + 0.5 * dt, state.x0[i], state.q0[i], scale)
            x, q, v, om = x.at[i].set(xi), q.at[i].set(qi), v.at[i].set(vi), om.at[i].set(wi)
    if pre:
        p = jnp.asarray(pre)
        xp, _ = prescribed_motion(config, params, state.x0, t + dt)
        _, vp = prescribed_motion(config, params, state.x0, t + 0.5 * dt)
        x, v = x.at[p].set(xp[p]), v.at[p].set(vp[p])
        q = q.at[p].set(state.q0[p])
    return state.replace(x=x, v=v, q=q, omega=om), status.astype(jnp.int32)
