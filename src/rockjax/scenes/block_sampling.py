"""Boundary particles of a convex block: an outer layer that follows its faces, a lattice
behind it, and volumes that make it weigh as the solid does (host, numpy).

A moving block's boundary particles (``Coupling.BOUNDARY_PARTICLES``) are where the fluid sees
the block. As for the tank walls, the outer layer must lie dx/2 inside every face, so that the
fluid's first layer rests ~dx/2 outside the particles, i.e. at the face. A cubic lattice clipped
by the block cannot do this for a face that is not aligned with it: along an inclined face the
outer layer's depth is a staircase anywhere in (0, dx] and water settles up to ~dx/2 inside the
block (RESULTS.md "Water inside the sliding wedge").

* Outer layer: the surface of the block shrunk by dx/2 (the half-space intersection of the faces
  moved inwards; faces may vanish near acute edges) -- its vertices, its edges at spacing <= dx
  and a square lattice of spacing dx on each face polygon (aligned with the polygon's longest
  edge). Every outer particle is exactly dx/2 inside its nearest face.
* Behind it, a cubic lattice (aligned with the largest axis-normal faces) from dx to ``layers`` dx
  deep. A greedy pass keeps candidates at least dx/2 from every kept one, outer layer first.
* Acute edges: the dx/2-deep layer ends dx / (2 sin(theta/2)) before an edge sharper than 90 deg;
  where the block's dx/2 skin is farther than sqrt(3)/2 dx from every particle, particles are
  added (``_acute_cover``).
* Volumes: each particle carries its nearest-particle share of the block's ``layers`` dx thick
  shell (``_shell_volumes``), so that the wall's kernel sum sum_j V_j W is that of the solid
  (tests: within 3-5 % rms on the faces; with dx^3 each these particles are over-dense at edges
  and corners, up to +80 %, and a clipped cubic lattice is off by 6-15 % rms, 30-55 % at worst).

For a box whose sides are multiples of dx this is the cubic lattice aligned with the box, dx^3
each.
"""

from __future__ import annotations

import numpy as np

__all__ = ["sample_block_particles", "inscribed_sphere", "submerged_pair_count"]


def inscribed_sphere(normals: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre [3] m and radius [m] of the largest sphere inside ``{x: n_f . x <= d_f}`` (the
    Chebyshev centre, a linear programme; ``normals`` [F, 3] unit, ``offsets`` [F] m)."""
    from scipy.optimize import linprog

    A = np.concatenate([normals, np.ones((len(normals), 1))], axis=1)
    res = linprog(c=[0.0, 0.0, 0.0, -1.0], A_ub=A, b_ub=offsets, bounds=[(None, None)] * 3 + [(0.0, None)],
                  method="highs")
    if not res.success:
        raise ValueError(f"block faces do not bound a solid ({res.message})")
    return np.asarray(res.x[:3]), float(res.x[3])


def _face_polygons(normals, offsets, centre, tol):
    """Vertices [V, 3] of the polyhedron ``n . x <= d`` (``centre`` strictly inside) and, per face
    that is a polygon, its vertex indices in order around the face."""
    from scipy.spatial import HalfspaceIntersection

    hs = HalfspaceIntersection(np.concatenate([normals, -offsets[:, None]], axis=1), centre)
    pts = hs.intersections
    verts = []  # merge the copies of a vertex where more than three planes meet
    for p in pts:
        if not any(np.linalg.norm(p - q) <= tol for q in verts):
            verts.append(p)
    verts = np.asarray(verts)
    faces = []
    for n, d in zip(normals, offsets):
        on = np.flatnonzero(np.abs(verts @ n - d) <= tol)
        if len(on) < 3:
            continue  # the face shrank to an edge or a vertex (or vanished)
        c = verts[on].mean(0)
        u = verts[on[0]] - c
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        ang = np.arctan2((verts[on] - c) @ v, (verts[on] - c) @ u)
        faces.append((n, on[np.argsort(ang)]))
    return verts, faces


def _edge_points(a, b, dx):
    """Points from ``a`` to ``b`` (ends excluded) at equal spacing <= dx."""
    m = int(np.ceil(np.linalg.norm(b - a) / dx - 1e-9))
    t = np.arange(1, m) / max(m, 1)
    return a[None] + t[:, None] * (b - a)[None]


def _face_lattice(poly: np.ndarray, n: np.ndarray, dx: float, tol: float, *, centred: bool = False) -> np.ndarray:
    """Square-lattice points (spacing dx) on the convex polygon ``poly`` [k, 3] (ordered, normal
    ``n``), rows parallel to its longest edge and starting on it (``centred``: half a spacing in
    from it, the centres of the lattice's cells)."""
    k = len(poly)
    lengths = [np.linalg.norm(poly[(i + 1) % k] - poly[i]) for i in range(k)]
    i0 = int(np.argmax(lengths))
    a = poly[i0]
    u = (poly[(i0 + 1) % k] - a) / lengths[i0]
    v = np.cross(n, u)
    if (poly.mean(0) - a) @ v < 0:
        v = -v
    rel = poly - a
    pu, pv = rel @ u, rel @ v
    shift = 0.5 if centred else 0.0
    iu = np.arange(np.floor(pu.min() / dx) - 1, np.ceil(pu.max() / dx) + 1) + shift
    iv = np.arange(0, np.ceil(pv.max() / dx) + 1) + shift
    gu, gv = np.meshgrid(iu * dx, iv * dx, indexing="ij")
    cand = a[None] + gu.reshape(-1, 1) * u[None] + gv.reshape(-1, 1) * v[None]
    return cand[_polygon_boundary_distance(cand, poly, n) >= -tol]


def _greedy_keep(points: np.ndarray, radius: float) -> np.ndarray:
    """The points (in their order) at least ``radius`` from every earlier kept point."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points)
    gone = np.zeros(len(points), bool)
    keep = []
    for i in range(len(points)):
        if gone[i]:
            continue
        keep.append(i)
        gone[tree.query_ball_point(points[i], radius * (1.0 - 1e-9))] = True
    return points[np.asarray(keep, int)]


def sample_block_particles(poly, dx: float, layers: int, *, volumes: bool = False):
    """Body-frame boundary particles [n, 3] m of a convex block (a ``blocks.geometry`` polyhedron):
    an outer layer dx/2 inside its faces and a cubic lattice behind it, ``layers`` dx deep
    (module docstring). With ``volumes``, returns ``(points, volume [n] m^3)``: each particle's
    share of the block's ``layers`` dx thick shell (its nearest-particle region).

    Raises ValueError if the block is too thin for ``dx`` (its inscribed sphere's diameter must
    exceed dx: the first layer lies dx/2 inside every face).
    """
    normals = np.asarray(poly.face_normal, float)
    offsets = np.asarray(poly.face_offset, float)
    size = float(np.ptp(np.asarray(poly.vertices, float), axis=0).max())
    tol = 1e-9 * max(size, dx)
    centre, radius = inscribed_sphere(normals, offsets)
    if radius <= 0.5 * dx * (1.0 + 1e-6):
        raise ValueError(f"block too thin for dx = {dx} m: its inscribed sphere has diameter {2 * radius:.4g} m, "
                         "and the boundary particles lie dx/2 inside every face; use a dx below that diameter")
    block = _face_polygons(normals, offsets, centre, tol)
    # the outer layer: the block shrunk by dx/2 -- its vertices, edges and face lattices
    verts, faces = _face_polygons(normals, offsets - 0.5 * dx, centre, tol)
    edges = sorted({tuple(sorted((int(ids[i]), int(ids[(i + 1) % len(ids)]))))
                    for _, ids in faces for i in range(len(ids))})
    groups = [verts] + [_edge_points(verts[a], verts[b], dx) for a, b in edges]
    groups += [_face_lattice(verts[ids], n, dx, tol) for n, ids in faces]
    # the inner layers: a cubic lattice (uniform density, aligned with the largest axis-normal
    # faces), from dx/2 behind the outer layer to ``layers`` dx deep
    groups.append(_interior_lattice(block, normals, offsets, dx, layers))
    pts = _greedy_keep(np.concatenate(groups), 0.5 * dx)
    pts = np.concatenate([pts, _acute_cover(pts, block, verts, normals, offsets, dx, tol)])
    if not volumes:
        return pts
    return pts, _shell_volumes(pts, block, normals, offsets, dx, layers, tol)


def _shell_volumes(pts, block, normals, offsets, dx: float, layers: int, tol: float) -> np.ndarray:
    """Volume [n] m^3 of each particle: the part of the block's shell (depth < ``layers`` dx)
    nearer to it than to any other particle, counted on a dx/4 lattice.

    The shell is partitioned by nearest face: a point whose nearest face is f lies below f's
    polygon (convexity), so each face's dx/4 lattice at depths (k + 1/2) dx/4 covers its part
    exactly once (a point as near to k faces counts 1/k for each: on a lattice such ties fill
    whole planes). Memory scales with one face's slab.
    """
    from scipy.spatial import cKDTree

    s = 0.25 * dx
    verts, faces = block  # ``_face_polygons`` of the block
    tree = cKDTree(pts)
    count = np.zeros(len(pts))
    depths = (np.arange(int(round(layers * dx / s))) + 0.5) * s
    for n, ids in faces:
        on = _face_lattice(verts[ids], n, s, tol, centred=True)
        for d in depths:
            q = on - d * n[None]
            c = offsets[None] - q @ normals.T  # clearance to every face (d to this one)
            ties = np.sum(c <= d + tol, axis=1)  # faces this point is nearest to (>= 1)
            mine = np.all(c >= d - tol, axis=1)
            if np.any(mine):
                count += np.bincount(tree.query(q[mine])[1], weights=1.0 / ties[mine], minlength=len(pts))
    return count * s**3


def _interior_lattice(block, normals, offsets, dx: float, layers: int) -> np.ndarray:
    """Points of a cubic lattice of spacing dx with depth in [dx, layers dx) [n, 3] m; along each
    axis the lattice is shifted so that its layers lie (k + 1/2) dx inside the largest face normal
    to that axis, if the block has one (``block``: its ``_face_polygons``)."""
    from .base import lattice

    verts, faces = block
    vmin, vmax = verts.min(0), verts.max(0)
    origin = vmin.copy()
    for a in range(3):
        normal = [(n, ids) for n, ids in faces if abs(abs(n[a]) - 1.0) < 1e-9]
        if normal:
            areas = np.array([_polygon_area(verts[ids], n) for n, ids in normal])
            n, ids = normal[int(np.flatnonzero(areas >= areas.max() * (1.0 - 1e-9))[0])]  # first of the largest
            plane_at = float(verts[ids[0]] @ n) * n[a]  # lattice cells end on the plane x_a = plane_at
            origin[a] = plane_at - np.ceil((plane_at - vmin[a]) / dx - 1e-9) * dx
    pts = lattice(origin, origin + np.ceil((vmax - origin) / dx - 1e-9) * dx, dx)
    phi = np.min(offsets[None] - pts @ normals.T, axis=1)
    return pts[(phi >= dx * (1.0 - 1e-9)) & (phi < layers * dx)]


def _polygon_area(poly: np.ndarray, n: np.ndarray) -> float:
    """Area [m^2] of the ordered convex polygon ``poly`` [k, 3] with unit normal ``n``."""
    return 0.5 * abs(float(np.sum(np.cross(poly, np.roll(poly, -1, axis=0)) @ n)))


def _polygon_boundary_distance(points: np.ndarray, poly: np.ndarray, n: np.ndarray) -> np.ndarray:
    """In-plane distance [m] from points on a convex polygon (``poly`` [k, 3] ordered, normal ``n``)
    to its boundary."""
    centre = poly.mean(0)
    dist = np.full(len(points), np.inf)
    for i in range(len(poly)):
        e = poly[(i + 1) % len(poly)] - poly[i]
        w = np.cross(n, e)
        if (centre - poly[i]) @ w < 0:
            w = -w
        dist = np.minimum(dist, (points - poly[i]) @ (w / np.linalg.norm(w)))
    return dist


def _acute_cover(pts: np.ndarray, block, inner: np.ndarray, normals: np.ndarray, offsets: np.ndarray, dx: float,
                 tol: float) -> np.ndarray:
    """Particles [m, 3] added where the block's dx/2-thick skin is farther than ``COVER * dx`` from
    every particle of ``pts``.

    On a face, every point of the skin is within ``sqrt(3)/2 dx`` of the dx/2-deep layer (a corner
    of a cube of side dx); at an edge sharper than 90 deg the layer's edge recedes by
    ``dx / (2 sin(theta/2))`` (2.3 dx for the sliding wedge's 25 deg edge; more at a sharp apex)
    and water would settle in the empty edge. Candidates: a dx/4 lattice on each face, within
    (the layer's largest recession + dx) of the face's boundary, at depths dx/8, dx/4 and 3dx/8
    (at least dx/16 deep: no particle on the surface); those farther than that from every particle get particles, deepest first, each covering its
    neighbourhood. The candidates scale with the blocks' edge length, not their volume.
    """
    from scipy.spatial import cKDTree

    verts, faces = block  # ``_face_polygons`` of the block; ``inner``: of the block shrunk by dx/2
    recess = np.max(cKDTree(inner).query(verts)[0])
    band = recess + dx
    cand = []
    for n, ids in faces:
        on = _face_lattice(verts[ids], n, 0.25 * dx, tol)
        on = on[_polygon_boundary_distance(on, verts[ids], n) <= band]
        cand += [on - depth * n[None] for depth in (0.125 * dx, 0.25 * dx, 0.375 * dx)]
    cand = np.concatenate(cand)
    phi = np.min(offsets[None] - cand @ normals.T, axis=1)
    skin = (phi > 0.0625 * dx) & (phi < 0.5 * dx)
    cand, phi = cand[skin], phi[skin]
    far = cKDTree(pts).query(cand)[0] > COVER * dx
    if not np.any(far):
        return np.zeros((0, 3))
    cand, phi = cand[far], phi[far]
    return _greedy_keep(cand[np.argsort(-phi, kind="stable")], COVER * dx)


COVER = 0.5 * np.sqrt(3.0) * (1.0 + 1e-6)  # [dx] the farthest a point of a face is from the dx/2-deep lattice


def submerged_pair_count(poly, points: np.ndarray, dx: float, radius: float) -> int:
    """(block particle, water particle) pairs closer than ``radius`` [m] when the block lies in
    still water: ``points`` [n, 3] its boundary particles (``sample_block_particles``, body frame)
    and a cubic water lattice of spacing ``dx`` [m] filling every point more than dx/4 outside its
    faces (water rests ~dx/2 outside). Sizes ``Config.body_pair_capacity`` (host, numpy)."""
    from scipy.spatial import cKDTree

    normals = np.asarray(poly.face_normal, float)
    offsets = np.asarray(poly.face_offset, float)
    lo = points.min(0) - radius - dx
    hi = points.max(0) + radius + dx
    axes = [np.arange(lo[a], hi[a], dx) for a in range(3)]
    water = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    outside = np.max(water @ normals.T - offsets, axis=1) > 0.25 * dx
    return int(cKDTree(points).count_neighbors(cKDTree(water[outside]), radius))
