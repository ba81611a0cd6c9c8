"""Meshes in: rock blocks and fixed geometry (slopes, bathymetry) from STL / OBJ / PLY / OFF files.

This module owns the host-side (numpy + trimesh) path from a mesh file to what a scene needs:

* :func:`load_mesh` -- read a file with trimesh (vertices welded), scaled and moved into the scene
  frame; refuses a missing, unreadable or empty file with a ``ValueError`` naming it.
* :func:`block_from_mesh` -- a rock block (``blocks.geometry.ConvexPolyhedron``) from a closed,
  convex mesh. Every defect (open, inconsistent winding, inside-out, several bodies, not convex
  within ``convexity_tol``) is refused, naming the file and the defect, unless the caller asks
  for the convex hull (``hull=True``).
* :class:`FixedSolid` -- fixed geometry as a signed clearance ``phi(x)`` (positive inside the
  solid, in metres) for sampling wall particles, plus, when the solid is convex, the
  ``ConvexPolyhedron`` of a FIXED block so that moving blocks collide with it. Built by
  :func:`fixed_box`, :func:`fixed_plane` (a half-space clipped to a box) and
  :func:`fixed_from_mesh` (a closed mesh; convex -> exact plane clearance and a fixed block,
  non-convex -> :func:`signed_distance` and wall particles only).
* :func:`signed_distance` -- exact signed distance to a closed triangle mesh (winding-number
  sign, point-triangle distance), in numpy chunks; it needs neither rtree nor embree.

Units: metres. Mesh files carry no units; ``scale`` converts them (e.g. 0.001 for millimetres).
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import Callable

import numpy as np
import scipy.optimize
import scipy.spatial
import trimesh

from ..blocks.geometry import ConvexPolyhedron, box

__all__ = [
    "MESH_SUFFIXES", "load_mesh", "block_from_mesh", "FixedSolid", "fixed_box", "fixed_plane", "fixed_from_mesh",
    "fixed_from_polyhedron", "signed_distance", "polyhedron_from_halfspaces", "world_halfspaces",
]

#: File suffixes read by :func:`load_mesh` (through trimesh).
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off")


def load_mesh(path, *, scale: float = 1.0, offset=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    """Read a triangle mesh file and map it into the scene frame: ``x_scene = scale * x_file + offset``.

    Args:
        path: an STL, OBJ, PLY or OFF file. scale: file units -> metres (> 0). offset: [3] m.

    Returns:
        A ``trimesh.Trimesh`` with vertices welded (``process=True``); nothing else is repaired.

    Raises:
        ValueError: the file is missing, has another suffix, cannot be read, or holds no triangles.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"mesh file {path!r} does not exist (paths in a scene file are relative to that file)")
    if not path.lower().endswith(MESH_SUFFIXES):
        raise ValueError(f"mesh file {path!r}: unsupported format; use one of {', '.join(MESH_SUFFIXES)}")
    scale = float(scale)
    if not (scale > 0 and math.isfinite(scale)):
        raise ValueError(f"mesh file {path!r}: scale must be a positive number (got {scale})")
    try:
        mesh = trimesh.load(path, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for broken files
        raise ValueError(f"mesh file {path!r} could not be read: {exc}") from exc
    faces = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))))
    if not isinstance(mesh, trimesh.Trimesh) or faces.ndim != 2 or len(faces) == 0:
        raise ValueError(f"mesh file {path!r} holds no triangles")
    off = np.asarray(offset, float)
    if off.shape != (3,) or not np.all(np.isfinite(off)):
        raise ValueError(f"mesh file {path!r}: offset must be three finite numbers in metres (got {offset})")
    mesh = mesh.copy()
    mesh.vertices = np.asarray(mesh.vertices, float) * scale + off
    return mesh


def _hull_volume(mesh: trimesh.Trimesh) -> float:
    try:
        return float(scipy.spatial.ConvexHull(np.asarray(mesh.vertices, float)).volume)
    except Exception:  # flat or degenerate: the block check reports it
        return float("nan")


def block_from_mesh(path, *, hull: bool = False, scale: float = 1.0, offset=(0.0, 0.0, 0.0),
                    convexity_tol: float = 1e-4, angle_tol: float = 1e-4) -> ConvexPolyhedron:
    """A rock block from a mesh file: closed, outward-wound and convex within ``convexity_tol``.

    Args:
        path: mesh file (see :func:`load_mesh`); scale, offset: file -> scene frame.
        hull: take the convex hull of the mesh vertices instead of refusing a defective mesh.
        convexity_tol: largest accepted ``(V_hull - V_mesh) / V_hull`` [-]. The default 1e-4
            allows for float32 vertices (STL) and nothing a user would call non-convex.
        angle_tol: rad; adjacent triangles closer to coplanar than this merge into one face
            (1e-4 suits float32 files; see ``ConvexPolyhedron.from_vertices``).

    Returns:
        A ``ConvexPolyhedron`` whose ``centroid_world`` is the centroid in the scene frame [m].

    Raises:
        ValueError: naming the file and the defect (open, non-manifold, inconsistent winding,
            inside-out, several bodies, not convex: with the volume ratio), and that
            ``hull = true`` would take the convex hull instead.
    """
    mesh = load_mesh(path, scale=scale, offset=offset)
    name = os.fspath(path)
    if hull:
        try:
            return ConvexPolyhedron.from_vertices(np.asarray(mesh.vertices, float), angle_tol=angle_tol)
        except ValueError as exc:
            raise ValueError(f"mesh file {name!r}: its convex hull is not a valid block: {exc}") from exc
    try:
        return ConvexPolyhedron.from_trimesh(mesh, convexity_tol=convexity_tol, angle_tol=angle_tol)
    except ValueError as exc:
        hv = _hull_volume(mesh)
        extra = ""
        if mesh.is_volume and math.isfinite(hv):
            extra = f" (mesh volume {abs(float(mesh.volume)):.4g} m^3, convex hull {hv:.4g} m^3)"
        raise ValueError(f"mesh file {name!r} is not a valid convex block: {exc}{extra}. To use its convex "
                         "hull instead, set `hull = true` (scene file) / hull=True.") from exc


def world_halfspaces(poly: ConvexPolyhedron, position) -> list[tuple[np.ndarray, float]]:
    """The block's faces as half-spaces ``n . x <= d`` in the world frame (block at ``position`` [3] m,
    unrotated)."""
    pos = np.asarray(position, float)
    return [(np.asarray(n, float), float(d) + float(np.asarray(n) @ pos))
            for n, d in zip(poly.face_normal, poly.face_offset)]


def _halfspace_clearance(halfspaces) -> Callable[[np.ndarray], np.ndarray]:
    normals = np.stack([np.asarray(n, float) for n, _ in halfspaces])
    offsets = np.asarray([d for _, d in halfspaces], float)

    def clearance(x: np.ndarray) -> np.ndarray:
        return np.min(offsets[None, :] - np.asarray(x, float) @ normals.T, axis=1)

    return clearance


def polyhedron_from_halfspaces(halfspaces, *, what: str = "region") -> ConvexPolyhedron:
    """The bounded convex polyhedron ``{x : n_k . x <= d_k}`` (outward normals ``n_k``, offsets m).

    Raises ValueError (naming ``what``) when the intersection is empty, flat or unbounded.
    """
    A = np.stack([np.asarray(n, float) for n, _ in halfspaces])
    b = np.asarray([d for _, d in halfspaces], float)
    A = A / np.linalg.norm(A, axis=1, keepdims=True)
    # Chebyshev centre: the interior point farthest from every face (a linear program).
    res = scipy.optimize.linprog(c=[0, 0, 0, -1], A_ub=np.c_[A, np.ones(len(A))], b_ub=b,
                                 bounds=[(None, None)] * 3 + [(0, None)], method="highs")
    if res.status != 0 or res.x[3] <= 1e-9 * max(1.0, float(np.max(np.abs(b)))):
        raise ValueError(f"{what}: the half-spaces enclose no volume (empty or flat region); check the planes")
    centre = res.x[:3]
    hs = scipy.spatial.HalfspaceIntersection(np.c_[A, -b], centre)
    return ConvexPolyhedron.from_vertices(hs.intersections)


@dataclasses.dataclass(frozen=True, eq=False)
class FixedSolid:
    """Fixed geometry: ``clearance(x [n, 3] m) -> [n] m`` (positive inside the solid; outside, minus
    a distance-like violation), and for a convex solid the ``polyhedron`` of a FIXED block placed at
    ``position`` [3] m (else None). ``name`` is used in messages; ``convex`` says which it is."""

    name: str
    clearance: Callable[[np.ndarray], np.ndarray]
    polyhedron: ConvexPolyhedron | None
    position: np.ndarray | None
    convex: bool


def fixed_from_polyhedron(poly: ConvexPolyhedron, position, *, name: str) -> FixedSolid:
    """A convex fixed solid from a block shape placed (unrotated) at ``position`` [3] m."""
    pos = np.asarray(position, float)
    return FixedSolid(name=name, clearance=_halfspace_clearance(world_halfspaces(poly, pos)), polyhedron=poly,
                      position=pos, convex=True)


def fixed_box(lo, hi, *, name: str = "box") -> FixedSolid:
    """The solid box ``[lo, hi]`` (m) as fixed geometry (and a fixed block)."""
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    size = hi - lo
    if np.any(size <= 0):
        raise ValueError(f"{name}: hi must exceed lo on every axis (lo {lo.tolist()}, hi {hi.tolist()})")
    return fixed_from_polyhedron(box(*size), 0.5 * (lo + hi), name=name)


def fixed_plane(point, normal, *, clip_lo, clip_hi, name: str = "plane") -> FixedSolid:
    """The half-space behind a plane (``n . (x - point) <= 0``; ``normal`` points out of the solid,
    towards the water), clipped to the box ``[clip_lo, clip_hi]`` (m) so that it is a finite block."""
    n = np.asarray(normal, float)
    nn = float(np.linalg.norm(n))
    if not nn > 0:
        raise ValueError(f"{name}: normal must be a non-zero vector")
    n = n / nn
    d = float(n @ np.asarray(point, float))
    lo = np.asarray(clip_lo, float)
    hi = np.asarray(clip_hi, float)
    hs = [(n, d)]
    for a in range(3):
        e = np.zeros(3)
        e[a] = 1.0
        hs += [(e, float(hi[a])), (-e, -float(lo[a]))]
    poly = polyhedron_from_halfspaces(hs, what=f"{name} (clipped to the domain)")
    pos = poly.centroid_world
    return FixedSolid(name=name, clearance=_halfspace_clearance(world_halfspaces(poly, pos)), polyhedron=poly,
                      position=np.asarray(pos, float), convex=True)


def fixed_from_mesh(path, *, scale: float = 1.0, offset=(0.0, 0.0, 0.0), convexity_tol: float = 1e-4,
                    angle_tol: float = 1e-4, name: str | None = None, exact_within: float = 0.0) -> FixedSolid:
    """Fixed geometry (a slope, a bathymetry, an obstacle) from a closed mesh file.

    A convex mesh (within ``convexity_tol``) gives the exact plane clearance and a FIXED block; a
    closed non-convex one gives :func:`signed_distance` and no block (moving blocks would pass
    through it: split it into convex pieces to have them collide). An open surface is refused:
    close it into a solid (e.g. extrude a bathymetry surface down to a flat base).

    For a non-convex mesh the clearance is exact inside the mesh's bounding box grown by
    ``exact_within`` [m]; beyond it, it is minus the distance to the bounding box, which is at
    most ``-exact_within`` and never below the true (negative) clearance.
    """
    mesh = load_mesh(path, scale=scale, offset=offset)
    name = name or os.fspath(path)
    if not mesh.is_watertight:
        raise ValueError(f"mesh file {os.fspath(path)!r}: a fixed mesh must be a closed solid, but it has open "
                         "edges (a surface only); close it (e.g. extrude a bathymetry surface down to a flat base, "
                         "or mesh.fill_holes())")
    if not mesh.is_winding_consistent:
        raise ValueError(f"mesh file {os.fspath(path)!r}: inconsistent face winding; fix it with "
                         "trimesh.repair.fix_winding(mesh)")
    if float(mesh.volume) < 0:
        raise ValueError(f"mesh file {os.fspath(path)!r} is inside-out (negative volume); invert its faces")
    try:
        poly = ConvexPolyhedron.from_trimesh(mesh, convexity_tol=convexity_tol, angle_tol=angle_tol)
    except ValueError:
        poly = None
    if poly is not None:
        return fixed_from_polyhedron(poly, poly.centroid_world, name=name)
    verts = np.asarray(mesh.vertices, float)
    tris = verts[np.asarray(mesh.faces)]

    box_lo, box_hi = verts.min(axis=0), verts.max(axis=0)
    grow = float(exact_within)

    def clearance(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        gap = np.maximum(np.maximum(box_lo - x, x - box_hi), 0.0)
        out = -np.linalg.norm(gap, axis=1)  # minus the distance to the bounding box (>= the true clearance)
        near = np.all(gap <= grow, axis=1)
        out[near] = signed_distance(tris, x[near])
        return out

    return FixedSolid(name=name, clearance=clearance, polyhedron=None, position=None, convex=False)


def _closest_on_triangles(p, a, b, c):
    """Closest points on triangles (a, b, c) [m, 3] to points p [n, 1, 3] -> [n, m, 3] (Ericson 2005, 5.1.5)."""
    ab, ac, ap = b - a, c - a, p - a
    d1 = np.einsum("...k,...k", ab, ap)
    d2 = np.einsum("...k,...k", ac, ap)
    bp = p - b
    d3 = np.einsum("...k,...k", ab, bp)
    d4 = np.einsum("...k,...k", ac, bp)
    cp = p - c
    d5 = np.einsum("...k,...k", ab, cp)
    d6 = np.einsum("...k,...k", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    tiny = 1e-300
    denom = va + vb + vc
    v = vb / np.where(np.abs(denom) > tiny, denom, tiny)
    w = vc / np.where(np.abs(denom) > tiny, denom, tiny)
    out = a + ab * v[..., None] + ac * w[..., None]  # interior
    # Ericson's tests in reverse order (a later np.where overrides): BC, AC, C, AB, B, A
    den_bc = (d4 - d3) + (d5 - d6)
    t_bc = (d4 - d3) / np.where(np.abs(den_bc) > tiny, den_bc, tiny)
    out = np.where(((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0))[..., None], b + (c - b) * t_bc[..., None], out)
    t_ac = d2 / np.where(np.abs(d2 - d6) > tiny, d2 - d6, tiny)
    out = np.where(((vb <= 0) & (d2 >= 0) & (d6 <= 0))[..., None], a + ac * t_ac[..., None], out)
    out = np.where(((d6 >= 0) & (d5 <= d6))[..., None], np.broadcast_to(c, out.shape), out)
    t_ab = d1 / np.where(np.abs(d1 - d3) > tiny, d1 - d3, tiny)
    out = np.where(((vc <= 0) & (d1 >= 0) & (d3 <= 0))[..., None], a + ab * t_ab[..., None], out)
    out = np.where(((d3 >= 0) & (d4 <= d3))[..., None], np.broadcast_to(b, out.shape), out)
    out = np.where(((d1 <= 0) & (d2 <= 0))[..., None], np.broadcast_to(a, out.shape), out)
    return out


def signed_distance(triangles: np.ndarray, points: np.ndarray, *, chunk_pairs: int = 2_000_000) -> np.ndarray:
    """Signed distance [n] m from ``points`` [n, 3] to the closed surface ``triangles`` [m, 3, 3]:
    positive inside, negative outside. The sign is the generalised winding number (> 1/2 inside;
    van Oosterom & Strackee 1983 solid angles); the magnitude is the exact distance to the nearest
    triangle. Cost O(n m), computed in chunks of ``chunk_pairs`` point-triangle pairs."""
    tris = np.asarray(triangles, float)
    pts = np.asarray(points, float)
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    out = np.empty(len(pts))
    step = max(1, chunk_pairs // max(1, len(tris)))
    for s in range(0, len(pts), step):
        p = pts[s:s + step, None, :]
        q = _closest_on_triangles(p, a[None], b[None], c[None])
        dist = np.sqrt(np.min(np.sum((q - p) ** 2, axis=-1), axis=1))
        ra, rb, rc = a[None] - p, b[None] - p, c[None] - p
        la, lb, lc = (np.linalg.norm(r, axis=-1) for r in (ra, rb, rc))
        num = np.einsum("...k,...k", ra, np.cross(rb, rc))
        den = (la * lb * lc + np.einsum("...k,...k", ra, rb) * lc + np.einsum("...k,...k", ra, rc) * lb
               + np.einsum("...k,...k", rb, rc) * la)
        winding = np.sum(2.0 * np.arctan2(num, den), axis=1) / (4.0 * np.pi)
        out[s:s + step] = np.where(winding > 0.5, dist, -dist)
    return out
