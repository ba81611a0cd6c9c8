"""Shared jitted block rollouts for the block tests (compiled once per (config, n_steps, record)).

Not a test module (no ``test_`` prefix).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from rockjax.blocks import advance_blocks


@functools.lru_cache(maxsize=None)
def rollout_fn(config, n_steps: int, every: int = 1):
    """``run(state, params, dt, gravity) -> (final_state, (x [n/every,B,3], q [..,B,4], v [..,B,3]), status)``.

    ``every`` steps are taken per recorded frame (an inner scan), status is OR-ed over all steps.
    """
    assert n_steps % every == 0

    def run(state, params, dt, gravity):
        def inner(carry, _):
            s, stat, t = carry
            s, st = advance_blocks(s, params, config, dt=dt, t=t, gravity=gravity)
            return (s, stat | st, t + dt), None

        def outer(carry, _):
            carry, _ = jax.lax.scan(inner, carry, None, length=every)
            s = carry[0]
            return carry, (s.x, s.q, s.v)

        t0 = jnp.zeros((), state.x.dtype)
        (s, stat, _), traj = jax.lax.scan(outer, (state, jnp.int32(0), t0), None, length=n_steps // every)
        return s, traj, stat

    return jax.jit(run)


def run(config, state, params, *, dt, n_steps, gravity=(0.0, 0.0, -9.81), every=1):
    """Run and return numpy trajectories ``(final_state, x, q, v, status)``."""
    f = state.x.dtype
    s, (x, q, v), stat = rollout_fn(config, n_steps, every)(state, params, jnp.asarray(dt, f),
                                                           jnp.asarray(gravity, f))
    return s, np.asarray(x), np.asarray(q), np.asarray(v), int(stat)


def incline_scene(*, theta_deg, b, h, phi_deg, kn=1e6, ks=1e6, zeta=0.2, width=0.2, density=2650.0,
                  s0=-0.5, lift=None, v0=None, law=None, locked=None):
    """A FIXED ``slope`` (theta) and a DYNAMIC box (b along the slope, ``width`` across, h normal to it).

    The box rests on the slope with its base centre ``s0`` m along the down-slope direction from
    the origin, pushed into the slope by its static penetration ``m g cos(theta) / (4 kn)`` (so
    it starts near equilibrium), or lifted by ``lift`` m if given.  The static config fields that
    depend on sizes are fixed so that every incline shares one compiled rollout.

    ``law``: the contact law (default ``PenaltyCoulomb()``). ``locked``: the box's locked degrees
    of freedom (``make_blocks(locked=...)``).

    Returns ``(config, params, state, down [3], normal [3])``.
    """
    from rockjax.blocks import Motion, box, make_blocks, quat_from_axis_angle, slope

    th = np.radians(theta_deg)
    down = np.array([np.cos(th), 0.0, -np.sin(th)])
    nrm = np.array([np.sin(th), 0.0, np.cos(th)])
    sl = slope(6.0, 2.0, 0.3, theta_deg)
    bx = box(b, width, h)
    m = density * b * width * h
    pen = m * 9.81 * np.cos(th) / (4 * kn)
    off = h / 2 - pen if lift is None else h / 2 + lift
    xb = s0 * down + off * nrm
    q = quat_from_axis_angle([0, 1, 0], th)
    cfg, par, st = make_blocks(
        [sl, bx], positions=np.stack([sl.centroid_world, xb]), orientations=np.stack([[1.0, 0, 0, 0], q]),
        motion=[Motion.FIXED, Motion.DYNAMIC], density=density, friction_angle_deg=phi_deg,
        normal_stiffness=kn, shear_stiffness=ks, damping_ratio=zeta, aabb_margin=0.01, grid_cell_size=1.0,
        velocities=None if v0 is None else np.stack([np.zeros(3), v0]), law=law,
        locked=None if locked is None else [None, locked],
    )
    return cfg, par, st, down, nrm


def grown_by_driver(block_config, bit):
    """The :class:`BlockConfig` the host driver's regrowth (``driver._grow``) makes of
    ``block_config`` for the status bit ``bit`` (a blocks-only Config around it)."""
    from rockjax.driver import _grow
    from rockjax.types import Config

    cfg = Config(n_fluid=0, n_wall=0, dt=1e-4, grid=None, cutoff=0.0, skin=0.0, blocks=block_config)
    return _grow(cfg, 8, None, int(bit))[0].blocks


def assert_same_loads(a, b):
    """Forces and torques (the first two entries of ``a`` and ``b``) equal to round-off."""
    for x, y in zip(a[:2], b[:2]):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-9)
