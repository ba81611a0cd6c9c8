"""Host-side sampling of particles from plane-bounded regions (numpy only).

A convex region is a list of half-spaces ``n . x <= d`` (outward unit normals ``n``). Its
"clearance" ``phi(x) = min_k (d_k - n_k . x)`` is the signed distance to the boundary inside
(positive) and minus the largest violation outside. Scenes fill water where ``phi > 0.3 dx`` on a
cubic lattice and put wall layers at ``phi = -(k + 1/2) dx``, k < layers (``shell``): on faces
aligned with the lattice these are lattice points; on inclined faces (slopes, beaches) square
lattices in the face, so the wall follows the face instead of a staircase 0-1 dx deep.
"""

from __future__ import annotations

import numpy as np

from .base import lattice

__all__ = ["HalfSpace", "clearance", "fill", "shell", "plane"]

HalfSpace = tuple  # (normal [3], offset d): the set n . x <= d


def plane(normal, point) -> HalfSpace:
    """The half-space ``n . (x - point) <= 0`` with ``n`` normalised (outward = ``normal``)."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    return (n, float(n @ np.asarray(point, float)))


def clearance(x: np.ndarray, halfspaces) -> np.ndarray:
    """phi(x) [n] m: min over half-spaces of ``d - n . x``."""
    return np.min(np.stack([d - x @ n for n, d in halfspaces], axis=1), axis=1)


def fill(lo, hi, dx: float, halfspaces, *, margin: float = 0.3) -> np.ndarray:
    """Lattice points in the box [lo, hi] with clearance > margin * dx (the water).

    Next to an inclined face the water lattice's staircase leaves 0.8-1.8 dx to ``shell``'s
    face-following wall layer. The water is not kept dx/2 off such faces (so that it would start
    a spacing or more from the wall, as on aligned walls): the water on a sloping beach then
    slumps more at the start (docs/notes.md, "From the source docstrings").
    """
    pts = lattice(lo, hi, dx)
    return pts[clearance(pts, halfspaces) > margin * dx]


def shell(lo, hi, dx: float, halfspaces, layers: int, *, follow_faces: bool = True) -> np.ndarray:
    """Wall particles [n, 3] m in the box [lo, hi] outside the convex region ``halfspaces``:
    ``layers`` layers, the k-th at clearance ``-(k + 1/2) dx``.

    Where the nearest face is aligned with ``lattice(lo, hi, dx)`` (an axis normal, the plane on
    a cell face) these are the lattice points with ``-layers dx < phi <= 0``. Where it is not
    (a slope, a beach) and ``follow_faces``: per layer, a square lattice of spacing dx on that
    face of the region grown by (k + 1/2) dx (the points whose nearest face it is), rows along
    the face polygon's longest edge; those closer than dx/2 to a kept point are dropped (the
    lattice points first). So the outer layer lies exactly dx/2 behind every face, as on a
    lattice-aligned wall. As a clipped lattice (``follow_faces=False``) an inclined face is a
    staircase whose first layer is 0-1 dx deep, and water enters a 25 deg slope up to 0.3 dx.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pts = lattice(lo, hi, dx)
    viol = np.stack([d - pts @ n for n, d in halfspaces], axis=1)  # [P, H]: clearance per face
    phi = viol.min(1)
    wall = (phi <= 0) & (phi > -layers * dx)
    aligned = np.asarray([_on_lattice_faces(n, d, lo, dx) for n, d in halfspaces])
    if not follow_faces or aligned.all():
        return pts[wall]
    keep = pts[wall & aligned[np.argmin(viol, axis=1)]]
    hi_lat = lo + np.maximum(np.round((hi - lo) / dx), 0) * dx  # the lattice's box
    edges, faces = _face_layers(halfspaces, ~aligned, lo, hi_lat, dx, layers)
    from scipy.spatial import cKDTree

    from .block_sampling import _greedy_keep

    r = 0.5 * dx * (1.0 - 1e-9)
    edges = _greedy_keep(edges, 0.5 * dx) if len(edges) else edges
    if len(edges) and len(keep):  # junction edges first, then the lattice, then the inclined faces
        keep = keep[cKDTree(edges).query(keep)[0] >= r]
    kept = np.concatenate([edges, keep])
    if len(faces) and len(kept):
        faces = faces[cKDTree(kept).query(faces)[0] >= r]
    return np.concatenate([kept, _greedy_keep(faces, 0.5 * dx) if len(faces) else faces])


def _on_lattice_faces(n, d, lo, dx: float) -> bool:
    """Whether the plane ``n . x = d`` is an axis plane on a cell face of the lattice from ``lo``."""
    a = int(np.argmax(np.abs(n)))
    if abs(abs(n[a]) - 1.0) > 1e-12:
        return False
    c = d / n[a]  # the plane x_a = c
    k = (c - lo[a]) / dx
    return abs(k - round(k)) <= 1e-6


def _face_layers(halfspaces, which, lo, hi, dx: float, layers: int) -> np.ndarray:
    """Wall points on the faces ``which`` [H] of the region grown by (k + 1/2) dx, k < layers,
    clipped to the box [lo, hi]: ``(edges, faces)`` -- the edges those faces share with other
    walls (spacing <= dx: they close the junction, e.g. a beach's toe) and a square lattice on
    each face (``_wall_face_lattice``)."""
    from .block_sampling import _edge_points, _face_polygons, inscribed_sphere

    normals = np.asarray([n for n, _ in halfspaces], float)
    offsets = np.asarray([d for _, d in halfspaces], float)
    eye = np.eye(3)
    N0 = np.concatenate([normals, eye, -eye])
    D0 = np.concatenate([offsets, hi, -lo])
    n_hs = len(normals)
    tol = 1e-9 * max(float(np.max(hi - lo)), dx)
    edges, faces_out = [], []
    for k in range(layers):
        D = D0.copy()
        D[:n_hs] += (k + 0.5) * dx
        centre, radius = inscribed_sphere(N0, D)
        if radius <= tol:
            continue
        verts, faces = _face_polygons(N0, D, centre, tol)
        owner = {}  # edge (vertex ids) -> indices of the planes whose faces share it
        for n, ids in faces:
            d = float(verts[ids[0]] @ n)
            j = int(np.flatnonzero(np.all(np.abs(N0 - n) <= 1e-12, axis=1) & (np.abs(D - d) <= 1e3 * tol))[0])
            for i in range(len(ids)):
                owner.setdefault(tuple(sorted((int(ids[i]), int(ids[(i + 1) % len(ids)])))), []).append(j)
            if j < n_hs and which[j]:
                faces_out.append(_wall_face_lattice(verts[ids], n, dx, lo, tol))
        for (a, b), js in owner.items():
            if all(j < n_hs for j in js) and any(which[j] for j in js):  # between two walls, one inclined
                edges.append(np.concatenate([verts[[a, b]], _edge_points(verts[a], verts[b], dx)]))
    cat = lambda parts: np.concatenate(parts) if parts else np.zeros((0, 3))
    return cat(edges), cat(faces_out)


def _wall_face_lattice(poly: np.ndarray, n: np.ndarray, dx: float, lo, tol: float) -> np.ndarray:
    """Square-lattice points (spacing dx) on the convex wall polygon ``poly`` [k, 3] (normal ``n``).
    A face containing an axis direction (a slope across the flume) has its rows along that axis
    at the cubic lattice's coordinates ``lo + (i + 1/2) dx``, and its columns from half a spacing
    off its lowest edge across them; any other face, rows along its longest edge."""
    from .block_sampling import _face_lattice, _polygon_boundary_distance

    a = int(np.argmin(np.abs(n)))
    if abs(n[a]) > 1e-12:
        return _face_lattice(poly, n, dx, tol, centred=True)
    u = np.eye(3)[a]
    v = np.cross(n, u)
    pu, pv = poly @ u, poly @ v
    su = lo[a] + (np.arange(np.floor((pu.min() - lo[a]) / dx) - 1, np.ceil((pu.max() - lo[a]) / dx) + 1) + 0.5) * dx
    sv = pv.min() + (np.arange(0, np.ceil((pv.max() - pv.min()) / dx) + 1) + 0.5) * dx
    gu, gv = np.meshgrid(su, sv, indexing="ij")
    p0 = poly[0]
    cand = p0[None] + (gu.reshape(-1, 1) - p0 @ u) * u[None] + (gv.reshape(-1, 1) - p0 @ v) * v[None]
    return cand[_polygon_boundary_distance(cand, poly, n) >= -tol]
