"""Shared helpers for the FCP tests and benchmark: random convex blocks, exact float64 SAT, a jitted FCP.

Not a test module (no ``test_`` prefix).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from rockjax.blocks import ConvexPolyhedron, quat_matrix
from rockjax.blocks.contact import pair_contacts
from rockjax.blocks.fcp import fcp_pair
from rockjax.blocks.geometry import pack
from rockjax.blocks.model import _stars

VMAX, FMAX, EMAX, KMAX = 12, 20, 60, 11


def random_block(rng, n_points=10, elongation=1.0):
    """Convex hull of ``n_points`` random points near the unit sphere, stretched along x."""
    while True:
        p = rng.normal(size=(n_points, 3))
        p /= np.linalg.norm(p, axis=1, keepdims=True)
        p *= rng.uniform(0.7, 1.0, size=(n_points, 1))
        p[:, 0] *= elongation
        try:
            return ConvexPolyhedron.from_vertices(p)
        except ValueError:
            continue


def random_rotation(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def padded(poly: ConvexPolyhedron):
    """Padded body-frame arrays of one block at the fixed test sizes."""
    pk = pack([poly], max_vertices=VMAX, max_faces=FMAX, max_halfedges=EMAX, max_directions=EMAX // 2)
    sf, sv, sm = _stars(poly, VMAX, KMAX)

    def idx(a):
        return np.where(a < 0, 0, a)

    return dict(V=pk.vertices[0], vm=pk.vertex_mask[0], N=pk.face_normal[0], D=pk.face_offset[0],
                fm=pk.face_mask[0], sf=sf, sv=sv, sm=sm, e=idx(pk.edges[0]), em=pk.edge_mask[0],
                r=pk.bounding_radius[0],
                dirs=(idx(pk.edge_direction[0]), idx(pk.direction_edge[0]), pk.direction_mask[0]))


def support_edges_of(*polys, multiple: int = 4) -> int:
    """``make_blocks``' default ``support_edges`` for these blocks (the most edge directions touching
    one face), rounded up to a multiple of ``multiple`` (fewer compiled variants in the tests)."""
    k = max(p.support_directions() for p in polys)
    return -(-k // multiple) * multiple


def world(poly: ConvexPolyhedron, q, x):
    R = np.asarray(quat_matrix(jnp.asarray(q, jnp.float64) if jax.config.jax_enable_x64 else jnp.asarray(q)),
                   np.float64)
    q = np.asarray(q, np.float64)
    w, a, b, c = q
    R = np.array([[1 - 2 * (b * b + c * c), 2 * (a * b - w * c), 2 * (a * c + w * b)],
                  [2 * (a * b + w * c), 1 - 2 * (a * a + c * c), 2 * (b * c - w * a)],
                  [2 * (a * c - w * b), 2 * (b * c + w * a), 1 - 2 * (a * a + b * b)]])
    X = poly.vertices @ R.T + x
    N = poly.face_normal @ R.T
    E = X[poly.edges[:, 1]] - X[poly.edges[:, 0]]
    return X, N, E, R


def sat(pi, qi, xi, pj, qj, xj):
    """Exact separating-axis test in float64.

    Returns ``(gap, axis)``: the largest gap ``min_j n.x - max_i n.x`` over the face normals of
    both blocks and all cross products of their edges (each in its better orientation), and its
    unit axis from i to j.  gap > 0: separated; gap < 0: -gap is the minimum penetration depth.
    """
    Xi, Ni, Ei, _ = world(pi, qi, xi)
    Xj, Nj, Ej, _ = world(pj, qj, xj)
    cr = np.cross(Ei[:, None, :], Ej[None, :, :]).reshape(-1, 3)
    ln = np.linalg.norm(cr, axis=1)
    ref = (np.linalg.norm(Ei, axis=1)[:, None] * np.linalg.norm(Ej, axis=1)[None, :]).reshape(-1)
    cr = cr[ln > 1e-9 * ref] / ln[ln > 1e-9 * ref][:, None]
    axes = np.concatenate([Ni, Nj, cr])
    pI, pJ = Xi @ axes.T, Xj @ axes.T
    gp = pJ.min(0) - pI.max(0)
    gm = pI.min(0) - pJ.max(0)
    g = np.maximum(gp, gm)
    k = int(np.argmax(g))
    ax = axes[k] * (1 if gp[k] >= gm[k] else -1)
    second = np.max(np.where(np.abs(np.abs(axes @ ax) - 1) > 1e-6, g, -np.inf)) if len(g) > 1 else -np.inf
    return float(g[k]), ax, float(second)


@functools.lru_cache(maxsize=None)
def fcp_fn(iterations: int, by_direction: bool = True, crossing_edges: int = 0, support_edges: int = 0,
           crosses: int = 0):
    """Jitted ``(bi, qi, xi, bj, qj, xj, n_prev, prev_valid) -> dict`` on padded blocks; with
    ``by_direction`` the FCP scores edge directions (as ``contact_forces`` does), else every edge;
    ``crossing_edges``: of ``pair_contacts`` (0: crossings among every edge); ``support_edges``: of
    ``fcp_pair`` (0: every direction in each round); ``crosses``: of ``fcp_pair`` (0: every
    cross of the gathered directions)."""

    def run(bi, qi, xi, bj, qj, xj, n_prev, prev_valid):
        Ri, Rj = quat_matrix(qi), quat_matrix(qj)
        Xi = bi["V"] @ Ri.T + xi
        Xj = bj["V"] @ Rj.T + xj
        Ni, Nj = bi["N"] @ Ri.T, bj["N"] @ Rj.T
        Di = bi["D"] + Ni @ xi
        Dj = bj["D"] + Nj @ xj
        out = fcp_pair(Xi, bi["vm"], Ni, bi["fm"], bi["e"], bi["em"],
                       Xj, bj["vm"], Nj, bj["fm"], bj["e"], bj["em"], xi, xj, n_prev, prev_valid,
                       bi["dirs"] if by_direction else None, bj["dirs"] if by_direction else None,
                       iterations=iterations, support_edges=support_edges, crosses=crosses)
        pc = pair_contacts(Xi, bi["vm"], Ni, Di, bi["fm"], bi["e"], bi["em"], bi["r"],
                           Xj, bj["vm"], Nj, Dj, bj["fm"], bj["e"], bj["em"], bj["r"],
                           out["normal"], out["gap"], tol_rel=1e-4, edge_contacts=True, crossing_edges=crossing_edges)
        out.update(points=pc.points, depth=pc.depth, active=pc.active, feature=pc.feature,
                   edge_overflow=pc.edge_overflow)
        return out

    return jax.jit(run)


def place_at_gap(pi, qi, pj, qj, direction, target):
    """Centroid of j (i at the origin) along ``direction`` so that the exact SAT gap is ``target`` (m)."""
    u = np.asarray(direction, float) / np.linalg.norm(direction)
    lo, hi = 0.0, 10.0 * (pi.bounding_radius + pj.bounding_radius) + abs(target)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        g = sat(pi, qi, np.zeros(3), pj, qj, mid * u)[0]
        if g < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi) * u
