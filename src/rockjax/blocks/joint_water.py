"""Water pressure in the joints between blocks (quasi-static, from a still water level).

Owns :func:`joint_water_load` (the hydrostatic load on one pair's contact patch) and its two
pieces, :func:`patch_triangles` (the patch) and :func:`submerged_parts` (its wet part).

Why: a block pressed on a slope or a floor under water touches it over a face.  The fluid model
cannot put water into that face-to-face joint (it is thinner than a particle), so the water
presses on every other face and none presses back from the joint: the block is pushed into its
support by ``p A`` and friction holds it (the seed's wedge stopped on its slope this way, see
``tests/coupling/test_wedge_run.py``).  Real joints carry water at the surrounding pressure; in
rock mechanics this is the joint water pressure of a phreatic level (Hoek & Bray, *Rock Slope
Engineering*; DDA with water pressure, Kim et al. 1999).  Here each contact patch carries the
hydrostatic pressure of a still water level ``z_w``:

    p(x) = rho_w |g| max(z_w - x . up, 0),      up = -g / |g|,

integrated exactly over the patch, pushing the two blocks apart along the common plane normal.
What it does not model: the wave's dynamic pressure in the joint, flow into or out of a joint,
suction.

The patch of a pair is the polygon of its active contact points (``contact.pair_contacts``): for
two faces pressed together these are exactly the vertices of their overlap (vertices of either
face inside the other and the crossings of their edges), so the patch is their convex hull.  It is
built as a fan around the points' mean, in angular order on the common plane; a vertex, edge or
edge-edge contact has fewer than three points or no area and carries nothing.
"""

from __future__ import annotations

import jax.numpy as jnp

__all__ = ["joint_water_load", "patch_triangles", "submerged_parts"]


def _pseudo_angle(x, y):
    """A monotone stand-in for ``atan2(y, x)``, in (-2, 2] (no transcendental function)."""
    p = y / jnp.where(jnp.abs(x) + jnp.abs(y) > 0, jnp.abs(x) + jnp.abs(y), 1.0)
    return jnp.where(x >= 0, p, jnp.where(y >= 0, 2.0 - p, -2.0 - p))


def _pseudo_direction(pa):
    """The direction (x, y), |x| + |y| = 1, of a pseudo-angle (inverse of :func:`_pseudo_angle`)."""
    p = jnp.where(pa > 1.0, 2.0 - pa, jnp.where(pa < -1.0, -2.0 - pa, pa))
    x = 1.0 - jnp.abs(p)
    return jnp.where(jnp.abs(pa) > 1.0, -x, x), p


def patch_triangles(points, active, n, t1, t2):
    """The contact patch (the convex hull of the active points on the common plane) as a fan of
    triangles from the points' mean, in angular order.

    Interior points are dropped first.  Seen from a hull vertex p, the directions to all other
    points lie within an angle of at most pi that contains the direction to their mean c; seen
    from an interior point they span more than pi.  So, with the extreme directions d_lo, d_hi
    (measured from c - p; found as the least and greatest pseudo-angle, no atan2, no
    arg-reduction), p is kept iff ``d_lo x d_hi >= 0`` (a relative tolerance of 1e-5 keeps points
    on a hull edge, which add nothing to the fan).  O(S^2) arithmetic, no sort; the
    first version (a per-point orientation test against its successor) lost corners under jit,
    where fused multiply-adds round ``e x e`` to either sign.  Duplicates and padding carry no
    triangle.

    Args:
      points: [S,3] m contact points; active: [S] bool; n: [3] unit common-plane normal;
      t1, t2: [3] unit tangents with ``t1 x t2 = n``.
    Returns:
      ``(c [3], a [S,3], b [S,3], area [S])``: triangle k is (c, a_k, b_k), its area on the
      common plane (m^2; 0 for dropped points and padding).
    """
    f = points.dtype
    S = points.shape[0]
    w = active.astype(f)
    c = jnp.sum(points * w[:, None], 0) / jnp.maximum(jnp.sum(w), 1.0)
    u = jnp.stack([(points - c) @ t1, (points - c) @ t2], -1)  # [S,2] on the plane, about c
    scale = jnp.max(jnp.where(active, jnp.abs(u).sum(-1), 0.0))
    eps = 1e-6 * scale
    idx = jnp.arange(S)
    dx_ = u[None, :, 0] - u[:, None, 0]  # [p, q]: q - p
    dy_ = u[None, :, 1] - u[:, None, 1]
    near = dx_ * dx_ + dy_ * dy_ <= eps * eps
    keep = active & ~jnp.any(near & active[None, :] & (idx[None, :] < idx[:, None]), 1)  # no duplicates
    other = keep[None, :] & ~near
    rx, ry = -u[:, 0:1], -u[:, 1:2]  # from p towards c
    dot = rx * dx_ + ry * dy_
    crs = rx * dy_ - ry * dx_
    pa = _pseudo_angle(dot, crs)
    lx, ly = _pseudo_direction(jnp.min(jnp.where(other, pa, 9.0), 1))
    hx, hy = _pseudo_direction(jnp.max(jnp.where(other, pa, -9.0), 1))
    opening = lx * hy - ly * hx  # L1-unit directions in p's frame (r, r_perp): same orientation
    tol = 1e-5
    away = jnp.sum(u * u, -1) > eps * eps  # p is not the mean itself
    hull = keep & ((jnp.sum(other, 1) < 2) | (away & (opening >= -tol)))
    # the star polygon of the hull points about c, in angular order
    key = jnp.where(hull, _pseudo_angle(u[:, 0], u[:, 1]), 10.0)
    order = jnp.argsort(key)
    P = points[order]
    n_h = jnp.sum(hull.astype(jnp.int32))
    nxt = jnp.where(idx + 1 < n_h, idx + 1, 0)
    Q = P[nxt]
    area = 0.5 * (jnp.cross(P - c, Q - c) @ n)
    return c, P, Q, jnp.where((idx < n_h) & (n_h >= 3), area, 0.0)


def submerged_parts(P, v):
    """The part of a triangle where a linear field is >= 0, as two triangles.

    Args:
      P: [..., 3, 3] m triangle vertices; v: [..., 3] the field (depth, m) at them.
    Returns:
      ``(Q [..., 2, 3, 3], w [..., 2, 3])``: two triangles covering ``{L >= 0}`` exactly (one of
      them degenerate unless two vertices are wet) and the field at their vertices (>= 0).  With
      v1 >= v2 >= v3: all wet -> the triangle; only v1 wet -> (P1, X12, X13); v3 alone dry ->
      (P1, P2, X23) + (P1, X23, X13), X_ab the zero crossing on edge ab.
    """
    o = jnp.argsort(-v, axis=-1)
    v = jnp.take_along_axis(v, o, -1)
    P = jnp.take_along_axis(P, o[..., None], -2)
    v1, v2, v3 = v[..., 0], v[..., 1], v[..., 2]
    P1, P2, P3 = P[..., 0, :], P[..., 1, :], P[..., 2, :]

    def cross_at(a, b, va, vb):  # zero crossing on the edge a-b (va > 0 >= vb)
        ok = va > vb
        t = jnp.where(ok, va / jnp.where(ok, va - vb, 1.0), 0.0)
        return a + t[..., None] * (b - a)

    X12, X13, X23 = cross_at(P1, P2, v1, v2), cross_at(P1, P3, v1, v3), cross_at(P2, P3, v2, v3)
    all_wet = v3 >= 0
    one = (v1 > 0) & (v2 <= 0)
    two = (v2 > 0) & (v3 < 0)
    z = jnp.zeros_like(v1)
    first = jnp.stack([P1, jnp.where(one[..., None], X12, P2),
                       jnp.where(all_wet[..., None], P3, jnp.where(one[..., None], X13, X23))], -2)
    w_first = jnp.stack([jnp.where(all_wet | one | two, v1, 0.0), jnp.where(all_wet | two, v2, 0.0),
                         jnp.where(all_wet, v3, 0.0)], -1)
    second = jnp.stack([P1, X23, X13], -2)
    w_second = jnp.stack([jnp.where(two, v1, 0.0), z, z], -1)
    return jnp.stack([first, second], -3), jnp.stack([w_first, w_second], -2)


def joint_water_load(points, active, n, t1, t2, *, level, density, gravity):
    """Hydrostatic joint-water load of one pair's contact patch, integrated exactly.

    Args:
      points: [S,3] m; active: [S] bool; n: [3] unit normal from block i to block j;
      t1, t2: [3] tangents (``t1 x t2 = n``); level: [] m, still water level (height along
      ``-gravity``); density: [] kg/m^3; gravity: [3] m/s^2.
    Returns:
      ``(force [3] N, magnitude [] N, moment [3] N m)``: the force ON block j (along n; block i
      gets the opposite), its magnitude ``f = int p dA`` and first moment ``m = int p x dA``
      (the torque on j about a point x_j is ``(m - f x_j) x n``; on i, ``-(m - f x_i) x n``).
      Exact for the hydrostatic field, wet and dry parts of a patch included: on a triangle with
      depths v_k at x_k, ``int L dA = A sum(v) / 3`` and ``int L x dA = A (sum_k v_k x_k +
      sum(v) sum(x)) / 12``.
    """
    g = jnp.sqrt(jnp.sum(gravity * gravity))
    up = -gravity / g
    c, A, Bq, area = patch_triangles(points, active, n, t1, t2)
    tri = jnp.stack([jnp.broadcast_to(c, A.shape), A, Bq], -2)  # [S,3,3]
    Q, w = submerged_parts(tri, level - tri @ up)  # [S,2,3,3], [S,2,3]
    sub = 0.5 * jnp.abs(jnp.cross(Q[..., 1, :] - Q[..., 0, :], Q[..., 2, :] - Q[..., 0, :]) @ n)  # [S,2]
    sub = jnp.where((area > 0)[:, None], sub, 0.0)
    rg = density * g
    mag = rg * jnp.sum(sub * jnp.sum(w, -1) / 3.0)
    mom = rg * jnp.sum((sub / 12.0)[..., None] * (jnp.einsum("...ck,...c->...k", Q, w) + jnp.sum(w, -1)[..., None]
                                                     * jnp.sum(Q, -2)), (0, 1))
    return mag * n, mag, mom
