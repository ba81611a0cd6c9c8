"""Unit-quaternion helpers for block orientations (jit/vmap/grad-safe), a host constructor, and
the small vector helpers the narrow phase shares (``safe_norm``, ``project``, ``tied_max``,
``tied_min``).

Convention: ``q = (w, x, y, z)``, a unit quaternion rotating BODY-frame vectors into the WORLD
frame: ``x_world = R(q) @ x_body + centroid``.
"""

from __future__ import annotations

import functools

import jax
import numpy as np
import jax.numpy as jnp

__all__ = ["quat_matrix", "quat_mul", "quat_integrate", "quat_from_axis_angle", "safe_norm", "project",
           "tied_max", "tied_min"]


def safe_norm(v, axis=-1, keepdims=False, eps=1e-30):
    """Euclidean norm with a finite gradient at ``v = 0`` (gradient 0 there)."""
    s = jnp.sum(v * v, axis=axis, keepdims=keepdims)
    pos = s > eps
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, s, 1.0)), 0.0)


@functools.partial(jax.custom_jvp, nondiff_argnums=(1,))
def tied_max(x, axis: int = -1):
    """``jnp.max(x, axis)`` whose derivative cannot be NaN.

    ``jnp.max``'s derivative averages the tangents of the entries EQUAL to the max, dividing by
    their count. XLA may compute ``x`` twice, once for the max and once for that comparison, and
    round the two copies differently (an unoptimised CPU compile did, for the FCP gap): the count
    is then 0 and the gradient NaN. Here the entries within 4 ulps of the max tie, and the argmax
    always counts, so the count is at least 1; at exact ties the derivative is ``jnp.max``'s.
    """
    return _max(x, axis)


#: :func:`tied_max` reduces an axis of at most this many entries as a tree of ``maximum``
UNROLL_MAX = 16


def _max(x, axis: int):
    """``jnp.max(x, axis)``; a short axis (a block's vertices) as a tree of elementwise maxima of
    its slices, which XLA:CPU fuses with the projections that produce ``x`` (as a reduction it
    ran as a separate library call, ~2-3x slower on the narrow phase's [pairs, V, candidates])."""
    n = x.shape[axis]
    if n > UNROLL_MAX or n < 2:
        return jnp.max(x, axis)
    parts = [jax.lax.index_in_dim(x, k, axis, keepdims=False) for k in range(n)]
    while len(parts) > 1:
        parts = [jnp.maximum(a, b) for a, b in zip(parts[::2], parts[1::2])] + parts[len(parts) - len(parts) % 2:]
    return parts[0]


@tied_max.defjvp
def _tied_max_jvp(axis, primals, tangents):
    (x,), (t,) = primals, tangents
    x, t = jnp.moveaxis(x, axis, -1), jnp.moveaxis(t, axis, -1)
    m = jnp.max(x, -1, keepdims=True)
    first = jnp.arange(x.shape[-1]) == jnp.argmax(x, -1)[..., None]
    w = ((x >= m - 4 * jnp.finfo(x.dtype).eps * jnp.abs(m)) | first).astype(x.dtype)
    return m[..., 0], jnp.sum(t * w, -1) / jnp.sum(w, -1)


def tied_min(x, axis: int = -1):
    """``jnp.min(x, axis)`` with :func:`tied_max`'s NaN-free derivative."""
    return -tied_max(-x, axis)


def project(X, N):
    """``X @ N.T`` written as three multiply-adds: [..., 3] points X, [C, 3] directions N -> [..., C].

    The per-pair products of the narrow phase contract over 3 only; as a batched ``dot`` XLA on
    CPU materialised each [pairs, V, C] product through a matmul library call (the largest costs of
    a 100-block pile step); as elementwise arithmetic they fuse with the max / min / compare that
    consume them. ``N`` may also be one direction [3] (result [...]).
    """
    if N.ndim == 1:
        return X[..., 0] * N[0] + X[..., 1] * N[1] + X[..., 2] * N[2]
    return X[..., 0, None] * N[:, 0] + X[..., 1, None] * N[:, 1] + X[..., 2, None] * N[:, 2]


def quat_matrix(q):
    """Rotation matrices of unit quaternions.

    Args:
      q: [..., 4] (w, x, y, z), body -> world.
    Returns:
      [..., 3, 3] rotation matrices.
    """
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r00 = 1 - 2 * (y * y + z * z)
    r01 = 2 * (x * y - w * z)
    r02 = 2 * (x * z + w * y)
    r10 = 2 * (x * y + w * z)
    r11 = 1 - 2 * (x * x + z * z)
    r12 = 2 * (y * z - w * x)
    r20 = 2 * (x * z - w * y)
    r21 = 2 * (y * z + w * x)
    r22 = 1 - 2 * (x * x + y * y)
    return jnp.stack(
        [jnp.stack([r00, r01, r02], -1), jnp.stack([r10, r11, r12], -1), jnp.stack([r20, r21, r22], -1)], -2
    )


def quat_mul(a, b):
    """Hamilton product ``a * b`` of [..., 4] quaternions (w, x, y, z)."""
    aw, ax, ay, az = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bw, bx, by, bz = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return jnp.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        -1,
    )


def quat_integrate(q, omega, dt):
    """Rotate ``q`` by the world-frame angular velocity ``omega`` over ``dt`` and renormalise.

    Exact exponential map ``q' = exp(omega dt / 2) * q``; ``sin(a)/a`` uses a Taylor series near 0 so
    the gradient is finite at ``omega = 0``.

    Args:
      q: [..., 4] unit quaternions.  omega: [..., 3] rad/s (world frame).  dt: s.
    Returns:
      [..., 4] unit quaternions.
    """
    half = 0.5 * dt * omega
    a2 = jnp.sum(half * half, axis=-1, keepdims=True)
    small = a2 < 1e-8
    a = jnp.sqrt(jnp.where(small, 1.0, a2))
    sinc = jnp.where(small, 1.0 - a2 / 6.0, jnp.sin(a) / a)
    cos = jnp.where(small, 1.0 - a2 / 2.0, jnp.cos(a))
    dq = jnp.concatenate([cos, sinc * half], axis=-1)
    out = quat_mul(dq, q)
    return out / jnp.linalg.norm(out, axis=-1, keepdims=True)


def quat_from_axis_angle(axis, angle) -> np.ndarray:
    """Host helper: unit quaternion (w, x, y, z) of a rotation by ``angle`` (rad) about ``axis`` [3]."""
    axis = np.asarray(axis, dtype=np.float64)
    n = np.linalg.norm(axis)
    if axis.shape != (3,) or not np.isfinite(n) or n == 0:
        raise ValueError(f"axis must be a finite non-zero 3-vector, got {axis}")
    axis = axis / n
    return np.concatenate([[np.cos(0.5 * angle)], np.sin(0.5 * angle) * axis])
