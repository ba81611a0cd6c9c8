"""Host-side geometry of rigid rock blocks (convex polyhedra) for 3D-DDA.

This module owns the *shape* of a block, built once on the host with numpy
(and trimesh / scipy for input and convex hulls); it never imports JAX.

What it owns
------------
* :class:`ConvexPolyhedron` -- one convex block in its BODY frame (origin at
  the centroid, axes parallel to the input axes; NOT principal axes):

  - vertices, and polygon faces (coplanar hull triangles merged) stored as a
    half-edge table, so that "faces / edges around a vertex" and "vertices of a
    face" are index walks (Mikola & Sitar 2013, section 4);
  - outward unit face normals ``n`` and offsets ``d`` (``n . x = d`` on the
    face, ``n . x <= d`` inside), the undirected edge list and the
    half-edge -> edge map, as needed by the Fast Common Plane contact search
    (Nezami et al. 2004);
  - exact mass properties for unit density (volume, inertia about the
    centroid) from the divergence theorem, and where the centroid was in the
    input coordinates (``centroid_world``) so the block can be placed.

* Constructors: :meth:`ConvexPolyhedron.from_vertices` (convex hull of a point
  set), :meth:`ConvexPolyhedron.from_trimesh` (validated closed convex mesh),
  and the shape helpers :func:`box`, :func:`wedge`, :func:`prism`, and
  :func:`slab` / :func:`slope` (a floor or an inclined plane, meant to be a
  large FIXED block).

* :func:`mass_properties` -- volume, centroid and inertia of any closed,
  outward-wound triangle mesh (signed tetrahedra; Tonon 2004).

* :class:`PackedBlocks` / :func:`pack` -- several blocks padded to common
  sizes as numpy arrays with validity masks, ready to hand to JAX.

Conventions
-----------
* Lengths in metres (m), volumes in m^3, inertia for unit density in
  kg m^2 / (kg m^-3) = m^5; multiply by the density rho [kg/m^3] to get the
  inertia tensor in kg m^2 (``I = rho * inertia_unit_density``).
* Face loops are counter-clockwise seen from outside (right-hand rule gives
  the outward normal). The face of a half-edge lies on its left, seen from
  outside.
* Index arrays are ``int32``; in :class:`PackedBlocks` padding entries hold
  :data:`PAD_INDEX` (``-1``).  Note that ``-1`` is a *valid* (wrapping) index
  for numpy/JAX gathers, so always combine with the masks.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence

import numpy as np
import scipy.spatial
import trimesh

__all__ = [
    "PAD_INDEX",
    "ConvexPolyhedron",
    "PackedBlocks",
    "box",
    "mass_properties",
    "overlap_depth",
    "pack",
    "prism",
    "slab",
    "slope",
    "wedge",
]

#: Index value used for padding entries of integer arrays in :class:`PackedBlocks`.
PAD_INDEX = -1

_INT = np.int32

try:  # scipy >= 1.11 exposes QhullError at top level of scipy.spatial
    _QhullError = scipy.spatial.QhullError
except AttributeError:  # pragma: no cover - older scipy
    from scipy.spatial.qhull import QhullError as _QhullError  # type: ignore


# --------------------------------------------------------------------------
# mass properties
# --------------------------------------------------------------------------


def _raw_moments(vertices: np.ndarray, triangles: np.ndarray):
    """Signed volume, first and second moments of a closed triangle mesh.

    Each outward triangle (a, b, c) forms a signed tetrahedron with the origin,
    ``det = a . (b x c)``; over that tetrahedron
    ``vol = det/6``, ``int x dV = det (a+b+c) / 24`` and
    ``int x x^T dV = det/120 (a a^T + b b^T + c c^T + s s^T)``, ``s = a+b+c``
    (image of the canonical tetrahedron covariance ``(I + 1 1^T)/120``).
    Summing over a closed surface gives the moments of the enclosed solid
    (divergence theorem).
    """
    a = vertices[triangles[:, 0]]
    b = vertices[triangles[:, 1]]
    c = vertices[triangles[:, 2]]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    s = a + b + c
    volume = det.sum() / 6.0
    first = (det[:, None] * s).sum(axis=0) / 24.0
    outer = (
        np.einsum("i,ij,ik->jk", det, a, a)
        + np.einsum("i,ij,ik->jk", det, b, b)
        + np.einsum("i,ij,ik->jk", det, c, c)
        + np.einsum("i,ij,ik->jk", det, s, s)
    )
    second = outer / 120.0
    return volume, first, second


def mass_properties(vertices, triangles):
    """Exact volume, centroid and unit-density inertia of a closed triangle mesh.

    Uses the divergence theorem over signed tetrahedra (Tonon 2004): first the
    volume and centroid with a reference point at the vertex mean (to limit
    cancellation), then the second moments directly about the centroid.

    Args:
      vertices: [V, 3] float, vertex positions (m).
      triangles: [T, 3] int, vertex indices of triangles wound counter-clockwise
        seen from outside (outward normals). The surface must be closed.

    Returns:
      ``(volume, centroid, inertia)``: signed volume (m^3; negative if the
      triangles are wound inward), centroid [3] (m, same frame as
      ``vertices``) and the inertia tensor about the centroid for density
      1 kg/m^3, [3, 3] (kg m^2 per kg/m^3 = m^5).  If the volume is zero the
      centroid and inertia are NaN.
    """
    v = np.asarray(vertices, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.int64)
    ref = v.mean(axis=0)
    vol, first, _ = _raw_moments(v - ref, t)
    if vol == 0.0:
        nan = np.full(3, np.nan)
        return 0.0, nan, np.full((3, 3), np.nan)
    centroid = ref + first / vol
    _, _, cov = _raw_moments(v - centroid, t)
    inertia = np.trace(cov) * np.eye(3) - cov
    inertia = 0.5 * (inertia + inertia.T)
    return float(vol), centroid, inertia


# --------------------------------------------------------------------------
# the polyhedron
# --------------------------------------------------------------------------


def _readonly(a, dtype):
    arr = np.array(a, dtype=dtype, copy=True)
    arr.flags.writeable = False
    return arr


@dataclasses.dataclass(frozen=True, eq=False)
class ConvexPolyhedron:
    """A convex polyhedral block in its body frame, with a half-edge table.

    Body frame: origin at the centroid, axes parallel to the axes of the
    input coordinates (not principal axes).  All arrays are read-only numpy
    arrays; index arrays are ``int32``.

    Attributes:
      vertices: [V, 3] float64, vertex positions relative to the centroid (m).
      he_vert: [E] origin vertex of each half-edge.
      he_next: [E] next half-edge around the same face (counter-clockwise
        seen from outside).
      he_prev: [E] previous half-edge around the same face.
      he_pair: [E] twin half-edge (same edge, opposite direction, other face).
      he_face: [E] face on the left of the half-edge (seen from outside).
      he_edge: [E] index into ``edges`` of the undirected edge.
      face_first_he: [F] one half-edge of each face.
      face_normal: [F, 3] outward unit normals (body frame).
      face_offset: [F] plane offsets d (m): ``n . x = d`` on the face and
        ``n . x <= d`` for every point of the block (body frame).
      vertex_first_he: [V] one outgoing half-edge of each vertex.
      edges: [nE, 2] unique undirected edges as vertex pairs with
        ``edges[k, 0] < edges[k, 1]``; ``nE = E / 2``.
      volume: block volume (m^3).
      inertia_unit_density: [3, 3] inertia tensor about the centroid for
        density 1 kg/m^3, body frame (m^5); ``I = rho * inertia_unit_density``.
      centroid_world: [3] position of the centroid in the input coordinates
        (m): input point ``p`` maps to body point ``p - centroid_world``.
      bounding_radius: max vertex distance from the centroid (m).

    Equality is identity (``eq=False``): arrays do not compare as booleans.
    """

    vertices: np.ndarray
    he_vert: np.ndarray
    he_next: np.ndarray
    he_prev: np.ndarray
    he_pair: np.ndarray
    he_face: np.ndarray
    he_edge: np.ndarray
    face_first_he: np.ndarray
    face_normal: np.ndarray
    face_offset: np.ndarray
    vertex_first_he: np.ndarray
    edges: np.ndarray
    volume: float
    inertia_unit_density: np.ndarray
    centroid_world: np.ndarray
    bounding_radius: float

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, "vertices", _readonly(self.vertices, np.float64))
        for name in (
            "he_vert",
            "he_next",
            "he_prev",
            "he_pair",
            "he_face",
            "he_edge",
            "face_first_he",
            "vertex_first_he",
            "edges",
        ):
            set_(self, name, _readonly(getattr(self, name), _INT))
        set_(self, "face_normal", _readonly(self.face_normal, np.float64))
        set_(self, "face_offset", _readonly(self.face_offset, np.float64))
        set_(
            self,
            "inertia_unit_density",
            _readonly(self.inertia_unit_density, np.float64),
        )
        set_(self, "centroid_world", _readonly(self.centroid_world, np.float64))
        set_(self, "volume", float(self.volume))
        set_(self, "bounding_radius", float(self.bounding_radius))

        V, E, F = self.n_vertices, self.n_halfedges, self.n_faces
        if self.vertices.shape != (V, 3):
            raise ValueError(f"vertices must be [V, 3], got {self.vertices.shape}")
        for name in ("he_vert", "he_next", "he_prev", "he_pair", "he_face", "he_edge"):
            if getattr(self, name).shape != (E,):
                raise ValueError(f"{name} must have shape ({E},)")
        if E % 2:
            raise ValueError(f"number of half-edges must be even, got {E}")
        if self.face_first_he.shape != (F,) or self.face_offset.shape != (F,):
            raise ValueError("face_first_he and face_offset must have shape (F,)")
        if self.face_normal.shape != (F, 3):
            raise ValueError("face_normal must have shape (F, 3)")
        if self.vertex_first_he.shape != (V,):
            raise ValueError("vertex_first_he must have shape (V,)")
        if self.edges.shape != (E // 2, 2):
            raise ValueError(f"edges must have shape ({E // 2}, 2)")
        if self.inertia_unit_density.shape != (3, 3):
            raise ValueError("inertia_unit_density must be [3, 3]")
        if self.centroid_world.shape != (3,):
            raise ValueError("centroid_world must be [3]")

    # ---- sizes ------------------------------------------------------------

    @property
    def n_vertices(self) -> int:
        """Number of vertices V."""
        return int(self.vertices.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of (polygon) faces F."""
        return int(self.face_first_he.shape[0])

    @property
    def n_halfedges(self) -> int:
        """Number of half-edges E (twice the number of edges)."""
        return int(self.he_vert.shape[0])

    @property
    def n_edges(self) -> int:
        """Number of undirected edges nE = E / 2."""
        return int(self.edges.shape[0])

    # ---- half-edge walks --------------------------------------------------

    def halfedges_around_vertex(self, v: int) -> np.ndarray:
        """Outgoing half-edges of vertex ``v``, counter-clockwise seen from outside.

        Walks ``e -> he_pair[he_prev[e]]`` starting at ``vertex_first_he[v]``.

        Returns:
          [k] int32 half-edge indices, k = valence of ``v``.
        """
        v = self._check_index(v, self.n_vertices, "vertex")
        start = int(self.vertex_first_he[v])
        out = [start]
        e = int(self.he_pair[self.he_prev[start]])
        while e != start:
            out.append(e)
            if len(out) > self.n_halfedges:  # pragma: no cover - corrupt table
                raise RuntimeError("half-edge loop around vertex does not close")
            e = int(self.he_pair[self.he_prev[e]])
        return np.asarray(out, dtype=_INT)

    def faces_around_vertex(self, v: int) -> np.ndarray:
        """Faces incident to vertex ``v``, counter-clockwise seen from outside.

        Returns:
          [k] int32 face indices (each face once).
        """
        return self.he_face[self.halfedges_around_vertex(v)]

    def edges_around_vertex(self, v: int) -> np.ndarray:
        """Edges incident to vertex ``v``, counter-clockwise seen from outside.

        Returns:
          [k] int32 indices into ``edges``.
        """
        return self.he_edge[self.halfedges_around_vertex(v)]

    def edge_directions(self) -> tuple[np.ndarray, np.ndarray]:
        """Group the edges by direction (parallel or anti-parallel).

        Two edges share a direction when the sine of their angle is at most 1e-9 (parallel to
        round-off: a box has 3 directions for its 12 edges, a prism 1 + its base's). The common
        plane's edge-edge candidates are cross products of directions, so each group is scored once.

        Returns:
          ``(group [nE] int32, representative [nD] int32)``: the direction index of each edge, and
          for each direction its first edge (an index into ``edges``); read-only, computed once
          per polyhedron (``pack`` and :meth:`support_directions` both ask).
        """
        return self._edge_direction_groups

    @functools.cached_property
    def _edge_direction_groups(self) -> tuple[np.ndarray, np.ndarray]:
        d = self.vertices[self.edges[:, 1]] - self.vertices[self.edges[:, 0]]
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        parallel = np.linalg.norm(np.cross(d[:, None, :], d[None, :, :]), axis=-1) <= 1e-9  # [nE, nE]
        group = np.full(self.n_edges, -1, dtype=_INT)
        reps: list[int] = []
        for k in range(self.n_edges):
            if group[k] < 0:  # the first edge of a new direction: it and the later edges parallel to it
                group[parallel[k] & (group < 0)] = len(reps)
                reps.append(k)
        reps = np.asarray(reps, dtype=_INT)
        group.setflags(write=False)
        reps.setflags(write=False)
        return group, reps

    def support_directions(self, feature: str = "face") -> int:
        """The most edge directions (:meth:`edge_directions`) touching one support set.

        The support set of a direction n (the vertices farthest along n) is a vertex, an edge or a
        face; the edges touching it are those with an endpoint in it. The largest such set of a
        face holds those of its edges and vertices, so this is the maximum over faces of the
        directions of the edges with an endpoint on the face (a box: 3; a random 12-vertex rock:
        12-19 of its ~30, 14 on average). The common plane's local candidates are built from these edges only
        (``BlockConfig.support_edges``).

        Args:
          feature: ``"face"`` (the largest, above), ``"edge"`` (the most touching one edge's two
            vertices; a 12-vertex rock ~12) or ``"vertex"`` (the most touching one vertex: its
            degree without parallel edges; a rock ~7). The generic support-set pairs of a common
            plane, face-vertex and edge-edge, bound its crosses (``BlockConfig.fcp_crosses``).
        """
        sets = {"face": lambda: (self.face_vertices(f) for f in range(self.n_faces)),
                "edge": lambda: iter(self.edges),
                "vertex": lambda: ([v] for v in range(self.n_vertices))}
        if feature not in sets:
            raise ValueError(f"support_directions: feature must be 'face', 'edge' or 'vertex', got {feature!r}")
        group, _ = self.edge_directions()
        best = 0
        for verts in sets[feature]():
            on = np.zeros(self.n_vertices, dtype=bool)
            on[np.asarray(verts)] = True
            touching = on[self.edges[:, 0]] | on[self.edges[:, 1]]
            best = max(best, len(np.unique(group[touching])))
        return best

    def face_halfedges(self, f: int) -> np.ndarray:
        """Half-edges of face ``f`` in loop order (walks ``he_next``).

        Returns:
          [k] int32 half-edge indices.
        """
        f = self._check_index(f, self.n_faces, "face")
        start = int(self.face_first_he[f])
        out = [start]
        e = int(self.he_next[start])
        while e != start:
            out.append(e)
            if len(out) > self.n_halfedges:  # pragma: no cover - corrupt table
                raise RuntimeError("face loop does not close")
            e = int(self.he_next[e])
        return np.asarray(out, dtype=_INT)

    def face_vertices(self, f: int) -> np.ndarray:
        """Vertices of face ``f``, counter-clockwise seen from outside.

        Returns:
          [k] int32 vertex indices, k >= 3.
        """
        return self.he_vert[self.face_halfedges(f)]

    def triangles(self) -> np.ndarray:
        """Fan triangulation of all faces, wound outward.

        Returns:
          [T, 3] int32 vertex indices, T = E - 2 F.
        """
        tris = []
        for f in range(self.n_faces):
            loop = self.face_vertices(f)
            for i in range(1, len(loop) - 1):
                tris.append((loop[0], loop[i], loop[i + 1]))
        return np.asarray(tris, dtype=_INT).reshape(-1, 3)

    def to_trimesh(self) -> trimesh.Trimesh:
        """The block's surface in the body frame as a (triangulated) trimesh."""
        return trimesh.Trimesh(
            vertices=np.array(self.vertices), faces=self.triangles(), process=False
        )

    @staticmethod
    def _check_index(i, n, what):
        i = int(i)
        if not 0 <= i < n:
            raise IndexError(f"{what} index {i} out of range [0, {n})")
        return i

    # ---- constructors -----------------------------------------------------

    @classmethod
    def from_vertices(
        cls, points, *, tol: float = 1e-9, angle_tol: float = 1e-6
    ) -> "ConvexPolyhedron":
        """Convex hull of a point set as a block.

        The vertices of the block are the corners of the convex hull: points
        strictly inside the hull, in the interior of a hull face or on a hull
        edge (between two corners) are not vertices and are silently dropped.
        Nearly coplanar hull facets (outward normals differing by less than
        about ``angle_tol``) are merged into one polygon face by Qhull's
        pre-merging (option ``A-cos(angle_tol)``), which keeps the result
        convex and drops corners made redundant by a merge.  The merge is
        accepted only if it shrinks the volume by at most ``angle_tol``
        (relative) and leaves every input point within ``angle_tol * size``
        of the block; otherwise (e.g. very thin blocks) the hull with only
        Qhull's round-off merging (option C-0) is used, as for
        ``angle_tol = 0``.  Angles below ~1e-8 rad (the resolution of a
        cosine) are always merged when ``angle_tol > 0``.  Merged faces are
        planar to about ``angle_tol * size``; ``face_offset`` is the support
        value ``max_v n . v``, so every vertex satisfies ``n . x <= d``.
        For meshes exported in float32, ``angle_tol ~ 1e-4`` is more suitable.

        Args:
          points: [N, 3] float, N >= 4 (m), in any ("world") frame.
          tol: relative length tolerance: two points closer than
            ``tol * size`` (``size`` = bounding-box diagonal) are duplicates,
            and a point set thinner than that is degenerate.
          angle_tol: angle (rad) under which adjacent hull facets are
            considered coplanar and merged, in [0, pi/2).

        Returns:
          The block in its body frame; ``centroid_world`` holds the centroid in
          the frame of ``points``.

        Raises:
          ValueError: wrong shape, non-finite values, duplicate points, fewer
            than 4 points, or (nearly) coplanar / collinear points (zero volume).
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape [N, 3], got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError("points contain NaN or inf")
        if pts.shape[0] < 4:
            raise ValueError(
                f"need at least 4 non-coplanar points for a polyhedron, got {pts.shape[0]}"
            )
        size = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
        if size == 0.0:
            raise ValueError("degenerate point set: all points coincide (zero volume)")
        _check_duplicates(
            pts, tol * size, hint="remove repeated points (e.g. np.unique(points, axis=0))"
        )
        _check_not_flat(pts, tol, what="points")

        if not 0.0 <= angle_tol < 0.5 * np.pi:
            raise ValueError(f"angle_tol must be in [0, pi/2) rad, got {angle_tol}")
        # Qhull merges facets during construction ("premerge"): C-0 merges
        # facets coplanar within round-off, A-c merges neighbours whose normals'
        # cosine exceeds c = cos(angle_tol). Qhull keeps the merged hull convex
        # and drops vertices that become redundant (e.g. on a merged ridge);
        # Qt (always on in scipy) triangulates each merged facet, all its
        # triangles sharing the facet's hyperplane. The points are centred
        # first because Qhull's round-off bounds scale with max |coordinate|.
        centred = pts - pts.mean(axis=0)
        try:
            exact = scipy.spatial.ConvexHull(centred, qhull_options="C-0")
        except _QhullError as exc:  # pragma: no cover - flat cases caught above
            raise ValueError(f"convex hull failed (degenerate point set?): {exc}") from exc
        if exact.volume <= tol * size**3:
            raise ValueError(
                f"degenerate point set: convex hull volume {exact.volume:.3e} m^3 is "
                f"zero within tolerance (size {size:.3e} m)"
            )
        if angle_tol > 0.0:
            merged = _merged_hull(pts, centred, exact.volume, size, angle_tol)
            if merged is not None:
                return merged
        return _build(pts, *_hull_polygons(pts, exact))

    @classmethod
    def from_trimesh(
        cls,
        mesh: trimesh.Trimesh,
        *,
        convexity_tol: float = 1e-6,
        tol: float = 1e-9,
        angle_tol: float = 1e-6,
    ) -> "ConvexPolyhedron":
        """Validated closed convex triangle mesh as a block.

        The mesh is checked, in this order, and refused with a ValueError that
        says what is wrong and how to fix it:

        1. no faces / non-finite vertices / bad face indices;
        2. duplicate (unwelded) vertices closer than ``tol * size``
           -> ``mesh.merge_vertices()``;
        3. degenerate: all vertices (nearly) coplanar, zero volume;
        4. not closed (boundary edges), non-manifold edges, inconsistent
           winding -> close it / fix winding, or use :meth:`from_vertices`;
        5. not a single genus-0 surface (Euler characteristic != 2), e.g.
           several bodies -> ``mesh.split()``;
        6. inside-out (negative signed volume) -> ``mesh.invert()``;
        7. non-convex: ``|V_hull - V_mesh| / V_hull > convexity_tol``.

        Vertices not referenced by any face are ignored.  The block is then
        built from the mesh vertices exactly as :meth:`from_vertices` does
        (polygon faces from merged coplanar triangles).

        Args:
          mesh: a ``trimesh.Trimesh`` (m).
          convexity_tol: relative volume tolerance of the convexity test.
          tol: relative length tolerance (see :meth:`from_vertices`).
          angle_tol: coplanarity angle (rad) for merging triangles.

        Returns:
          The block in its body frame; ``centroid_world`` is in mesh coordinates.
        """
        verts = np.asarray(getattr(mesh, "vertices", None), dtype=np.float64)
        faces = np.asarray(getattr(mesh, "faces", None))
        if verts.ndim != 2 or verts.shape[-1] != 3:
            raise ValueError(f"mesh.vertices must be [V, 3], got shape {verts.shape}")
        if faces.ndim != 2 or faces.shape[-1] != 3 or faces.shape[0] == 0:
            raise ValueError(
                f"mesh has no triangle faces (faces shape {faces.shape}); "
                "a closed triangle mesh is required"
            )
        faces = faces.astype(np.int64)
        if faces.min() < 0 or faces.max() >= verts.shape[0]:
            raise ValueError("mesh.faces index vertices out of range")
        if not np.all(np.isfinite(verts)):
            raise ValueError("mesh.vertices contain NaN or inf")

        used = np.unique(faces)
        remap = np.full(verts.shape[0], -1, dtype=np.int64)
        remap[used] = np.arange(used.size)
        v = verts[used]
        fcs = remap[faces]

        size = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
        if size == 0.0:
            raise ValueError("degenerate mesh: all vertices coincide (zero volume)")
        _check_duplicates(
            v,
            tol * size,
            hint="the mesh has duplicate/unwelded vertices; merge vertices with "
            "mesh.merge_vertices() (or build it with process=True)",
        )
        _check_not_flat(v, tol, what="mesh vertices")

        # --- closedness, manifoldness, winding consistency ----------------
        directed = np.concatenate([fcs[:, [0, 1]], fcs[:, [1, 2]], fcs[:, [2, 0]]])
        if np.any(directed[:, 0] == directed[:, 1]):
            raise ValueError(
                "mesh has faces with a repeated vertex index (collapsed triangles); "
                "remove them with mesh.update_faces(mesh.nondegenerate_faces())"
            )
        undirected = np.sort(directed, axis=1)
        uniq, inverse, counts = np.unique(
            undirected, axis=0, return_inverse=True, return_counts=True
        )
        inverse = inverse.reshape(-1)
        n_boundary = int(np.sum(counts == 1))
        if n_boundary:
            raise ValueError(
                f"mesh is not closed: {n_boundary} boundary edges (edges used by one "
                "face only). Close it (e.g. mesh.fill_holes()) or use "
                "ConvexPolyhedron.from_vertices(mesh.vertices) to take its convex hull"
            )
        n_nonmanifold = int(np.sum(counts > 2))
        if n_nonmanifold:
            raise ValueError(
                f"mesh is not manifold: {n_nonmanifold} edges are shared by more than "
                "two faces. Repair the mesh or use ConvexPolyhedron.from_vertices"
            )
        forward = directed[:, 0] < directed[:, 1]
        n_fwd = np.bincount(inverse, weights=forward, minlength=uniq.shape[0])
        n_bad = int(np.sum(n_fwd != 1))
        if n_bad:
            raise ValueError(
                f"mesh face winding is inconsistent: {n_bad} edges are traversed in "
                "the same direction by both faces; fix winding with "
                "trimesh.repair.fix_winding(mesh) (then mesh.invert() if it ends inward)"
            )
        chi = v.shape[0] - uniq.shape[0] + fcs.shape[0]
        if chi != 2:
            raise ValueError(
                f"mesh is not a single closed genus-0 surface (Euler characteristic "
                f"V - E + F = {chi}, expected 2): it may consist of several bodies or "
                "have handles; split it with mesh.split() and build one block per body"
            )

        # --- orientation, volume, convexity -------------------------------
        vol, _, _ = mass_properties(v, fcs)
        if abs(vol) <= tol * size**3:
            raise ValueError(
                f"degenerate mesh: enclosed volume {vol:.3e} m^3 is zero within tolerance"
            )
        if vol < 0.0:
            raise ValueError(
                f"mesh is inside-out: signed volume {vol:.6g} m^3 < 0, so its faces are "
                "inward; call mesh.invert() or fix winding "
                "(trimesh.repair.fix_normals(mesh))"
            )
        try:
            hull_vol = float(scipy.spatial.ConvexHull(v).volume)
        except _QhullError as exc:  # pragma: no cover - flat caught above
            raise ValueError(f"degenerate mesh (zero volume): {exc}") from exc
        rel = (hull_vol - vol) / hull_vol
        if rel > convexity_tol:
            raise ValueError(
                f"mesh is not convex: its volume {vol:.6g} m^3 is {rel:.3e} (relative) "
                f"smaller than its convex hull's {hull_vol:.6g} m^3 "
                f"(convexity_tol={convexity_tol:g}). Split it into convex pieces "
                "(e.g. mesh.convex_decomposition()) or use "
                "ConvexPolyhedron.from_vertices(mesh.vertices) for its hull"
            )
        if -rel > convexity_tol:
            raise ValueError(
                f"mesh is not a simple convex solid: its volume {vol:.6g} m^3 exceeds "
                f"its convex hull's {hull_vol:.6g} m^3 by {-rel:.3e} (relative); it "
                "self-intersects or has overlapping parts. Repair it or use "
                "ConvexPolyhedron.from_vertices(mesh.vertices)"
            )
        return cls.from_vertices(v, tol=tol, angle_tol=angle_tol)


# --------------------------------------------------------------------------
# construction internals
# --------------------------------------------------------------------------


def _merged_hull(pts, centred, exact_volume, size, angle_tol):
    """Hull with angle pre-merging, or None if the merge distorts the shape.

    Qhull's angle merging may drop corners that stick out by up to about
    ``angle_tol * size``; for very thin point sets this can remove a large
    fraction of the volume, or Qhull may fail. The merge is accepted only if
    the volume shrinks by at most ``angle_tol`` (relative) and every input
    point stays within ``angle_tol * size`` of the merged block.
    """
    try:
        hull = scipy.spatial.ConvexHull(
            centred, qhull_options=f"C-0 A-{float(np.cos(angle_tol))!r}"
        )
    except _QhullError:
        return None
    poly = _build(pts, *_hull_polygons(pts, hull))
    lost = (exact_volume - poly.volume) / exact_volume
    outside = np.max(
        (pts - poly.centroid_world) @ poly.face_normal.T - poly.face_offset[None, :]
    )
    if lost > angle_tol or outside > angle_tol * size:
        return None
    return poly


def _check_duplicates(pts: np.ndarray, radius: float, *, hint: str) -> None:
    tree = scipy.spatial.cKDTree(pts)
    pairs = tree.query_pairs(r=radius, output_type="ndarray")
    if len(pairs):
        i, j = (int(x) for x in pairs[0])
        raise ValueError(
            f"{len(pairs)} pair(s) of duplicate vertices closer than {radius:.3e} m "
            f"(e.g. indices {i} and {j} at {pts[i].tolist()}); {hint}"
        )


def _check_not_flat(pts: np.ndarray, tol: float, *, what: str) -> None:
    centred = pts - pts.mean(axis=0)
    s = np.linalg.svd(centred, compute_uv=False)
    if s.size < 3 or s[2] <= tol * s[0]:
        kind = "collinear" if s.size < 2 or s[1] <= tol * s[0] else "coplanar"
        raise ValueError(
            f"degenerate {what}: all points are (nearly) {kind}, the polyhedron "
            "would have zero volume; at least 4 non-coplanar points are needed"
        )


def _hull_polygons(pts: np.ndarray, hull) -> tuple[list[list[int]], np.ndarray]:
    """Polygon faces of a qhull hull: (loops of point indices CCW from outside,
    [F, 3] outward unit normals of qhull's facet hyperplanes).

    Triangles of one (merged) qhull facet share the facet's hyperplane
    bitwise; each connected set of such triangles becomes one polygon.
    """
    simp = np.array(hull.simplices, dtype=np.int64)
    nbr = np.array(hull.neighbors, dtype=np.int64)
    eqs = np.array(hull.equations, dtype=np.float64)
    normals = eqs[:, :3] / np.linalg.norm(eqs[:, :3], axis=1, keepdims=True)
    T = simp.shape[0]

    # 1. Consistent outward winding. qhull's simplices are not oriented and
    #    its triangulated output ("Qt") may contain zero-area triangles, so
    #    orient topologically (BFS over neighbours, starting from the
    #    largest triangle oriented by its outward facet normal).
    a, b, c = (pts[simp[:, k]] for k in range(3))
    cr = np.cross(b - a, c - a)
    area2 = np.linalg.norm(cr, axis=1)
    tri = simp.copy()
    done = np.zeros(T, dtype=bool)
    seed = int(np.argmax(area2))
    if np.dot(cr[seed], normals[seed]) < 0:
        tri[seed] = tri[seed][[0, 2, 1]]
    done[seed] = True
    queue = [seed]
    while queue:
        t = queue.pop()
        dir_edges = {(int(tri[t, k]), int(tri[t, (k + 1) % 3])) for k in range(3)}
        for n in nbr[t]:
            n = int(n)
            if done[n]:
                continue
            # the shared edge must appear reversed in the neighbour
            n_edges = [(int(tri[n, k]), int(tri[n, (k + 1) % 3])) for k in range(3)]
            if any(e in dir_edges for e in n_edges):
                tri[n] = tri[n][[0, 2, 1]]
            done[n] = True
            queue.append(n)
    if not done.all():  # pragma: no cover - qhull hulls are connected
        raise RuntimeError("convex hull triangulation is not connected")
    vol, _, _ = _raw_moments(pts - pts.mean(axis=0), tri)
    if vol < 0:  # pragma: no cover - seed orientation makes this positive
        tri = tri[:, [0, 2, 1]]

    # 2. Group the triangles of each facet: connected components of
    #    neighbours with identical hyperplanes.
    group = np.full(T, -1, dtype=np.int64)
    n_groups = 0
    for s in range(T):
        if group[s] >= 0:
            continue
        group[s] = n_groups
        stack = [s]
        while stack:
            t = stack.pop()
            for n in nbr[t]:
                n = int(n)
                if group[n] < 0 and np.array_equal(eqs[n], eqs[s]):
                    group[n] = n_groups
                    stack.append(n)
        n_groups += 1

    # 3. Boundary loop of each group: directed edges whose reverse is not in
    #    the same group.
    loops: list[list[int]] = []
    face_normals = np.zeros((n_groups, 3))
    for g in range(n_groups):
        face_normals[g] = normals[np.argmax(group == g)]
        members = tri[group == g]
        dedges = {(int(t[k]), int(t[(k + 1) % 3])) for t in members for k in range(3)}
        boundary = [(u, w) for (u, w) in dedges if (w, u) not in dedges]
        succ: dict[int, int] = {}
        for u, w in boundary:
            if u in succ:  # pragma: no cover - cannot happen for a convex face
                raise RuntimeError("merged hull face is not a simple polygon")
            succ[u] = w
        start = min(succ)
        loop = [start]
        nxt = succ[start]
        while nxt != start:
            loop.append(nxt)
            if len(loop) > len(succ):  # pragma: no cover
                raise RuntimeError("merged hull face boundary does not close")
            nxt = succ[nxt]
        if len(loop) != len(succ):  # pragma: no cover
            raise RuntimeError("merged hull face has more than one boundary loop")
        loops.append(loop)

    # 4. Drop points that lie on an edge between two corners: a true corner
    #    of a convex polyhedron touches at least three faces.
    n_faces_at = np.zeros(pts.shape[0], dtype=np.int64)
    for loop in loops:
        n_faces_at[loop] += 1
    loops = [[p for p in loop if n_faces_at[p] >= 3] for loop in loops]
    if any(len(loop) < 3 for loop in loops):  # pragma: no cover
        raise RuntimeError("a hull face lost its corners while removing collinear points")
    return loops, face_normals


def _build(pts: np.ndarray, loops: list[list[int]], normals: np.ndarray) -> ConvexPolyhedron:
    """Assemble the half-edge table and mass properties from polygon loops.

    ``normals`` [F, 3] are the outward unit normals of the faces.
    """
    used = np.unique(np.concatenate([np.asarray(lp) for lp in loops]))
    remap = np.full(pts.shape[0], -1, dtype=np.int64)
    remap[used] = np.arange(used.size)
    loops = [[int(remap[p]) for p in loop] for loop in loops]
    V = used.size
    F = len(loops)

    # mass properties from the fan triangulation of the polygon faces
    tris = np.array(
        [(lp[0], lp[i], lp[i + 1]) for lp in loops for i in range(1, len(lp) - 1)],
        dtype=np.int64,
    )
    vol, centroid, inertia = mass_properties(pts[used], tris)
    verts = pts[used] - centroid

    # half-edges, contiguous per face
    he_vert, he_next, he_prev, he_face = [], [], [], []
    face_first = np.zeros(F, dtype=np.int64)
    for f, loop in enumerate(loops):
        k = len(loop)
        base = len(he_vert)
        face_first[f] = base
        for i in range(k):
            he_vert.append(loop[i])
            he_next.append(base + (i + 1) % k)
            he_prev.append(base + (i - 1) % k)
            he_face.append(f)
    he_vert = np.asarray(he_vert, dtype=np.int64)
    he_next = np.asarray(he_next, dtype=np.int64)
    he_prev = np.asarray(he_prev, dtype=np.int64)
    he_face = np.asarray(he_face, dtype=np.int64)
    E = he_vert.size

    index = {}
    for e in range(E):
        key = (int(he_vert[e]), int(he_vert[he_next[e]]))
        if key in index:  # pragma: no cover
            raise RuntimeError(f"half-edge {key} appears twice")
        index[key] = e
    he_pair = np.empty(E, dtype=np.int64)
    for (u, w), e in index.items():
        if (w, u) not in index:  # pragma: no cover
            raise RuntimeError(f"half-edge {(u, w)} has no twin")
        he_pair[e] = index[(w, u)]

    he_edge = np.full(E, -1, dtype=np.int64)
    edges = []
    for e in range(E):
        if he_edge[e] < 0:
            u, w = int(he_vert[e]), int(he_vert[he_pair[e]])
            he_edge[e] = he_edge[he_pair[e]] = len(edges)
            edges.append((min(u, w), max(u, w)))
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)

    vertex_first = np.full(V, -1, dtype=np.int64)
    for e in range(E - 1, -1, -1):
        vertex_first[he_vert[e]] = e

    # face planes: the normal is Qhull's facet hyperplane (the one its
    # convexity tests used; a Newell normal of a thin sliver facet can be far
    # less consistent with the neighbours); the offset is the support value
    # max_v n . v over all vertices, so that n . x <= d holds for the whole
    # block (faces merged within angle_tol may be non-planar by
    # ~angle_tol * size; exactly planar faces are planar to rounding).
    normals = np.asarray(normals, dtype=np.float64)
    offsets = np.max(verts @ normals.T, axis=0)

    return ConvexPolyhedron(
        vertices=verts,
        he_vert=he_vert,
        he_next=he_next,
        he_prev=he_prev,
        he_pair=he_pair,
        he_face=he_face,
        he_edge=he_edge,
        face_first_he=face_first,
        face_normal=normals,
        face_offset=offsets,
        vertex_first_he=vertex_first,
        edges=edges,
        volume=vol,
        inertia_unit_density=inertia,
        centroid_world=centroid,
        bounding_radius=float(np.max(np.linalg.norm(verts, axis=1))),
    )


# --------------------------------------------------------------------------
# placed blocks
# --------------------------------------------------------------------------


def quat_to_matrix(q) -> np.ndarray:
    """[3, 3] rotation matrix of a quaternion ``(w, x, y, z)`` (normalised here), host numpy."""
    w, x, y, z = np.asarray(q, np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def overlap_depth(a: "ConvexPolyhedron", xa, ra, b: "ConvexPolyhedron", xb, rb) -> float:
    """How deep two placed convex blocks overlap (m): ``a`` with its centroid at ``xa`` [3] and
    rotation matrix ``ra`` [3, 3] (body -> world), ``b`` likewise; <= 0 when they are apart.

    The least overlap of their projections over every separating-axis candidate of two convex
    polyhedra (the face normals of both and the cross products of their edge directions): the
    minimum translation that separates them, so a block resting on another gives ~0 and one
    sunk 3 cm into a floor gives 0.03 (host numpy; used to refuse blocks that start inside
    each other).
    """
    ra, rb = np.asarray(ra, float), np.asarray(rb, float)
    va = a.vertices @ ra.T + np.asarray(xa, float)
    vb = b.vertices @ rb.T + np.asarray(xb, float)
    da = a.vertices[a.edges[:, 1]] - a.vertices[a.edges[:, 0]]
    db = b.vertices[b.edges[:, 1]] - b.vertices[b.edges[:, 0]]
    da = (da[a.edge_directions()[1]]) @ ra.T
    db = (db[b.edge_directions()[1]]) @ rb.T
    cross = np.cross(da[:, None, :], db[None, :, :]).reshape(-1, 3)
    norm = np.linalg.norm(cross, axis=1)
    scale = np.linalg.norm(da, axis=1).max() * np.linalg.norm(db, axis=1).max()
    cross = cross[norm > 1e-9 * scale] / norm[norm > 1e-9 * scale, None]
    axes = np.concatenate([a.face_normal @ ra.T, b.face_normal @ rb.T, cross])
    pa, pb = va @ axes.T, vb @ axes.T
    overlap = np.minimum(pa.max(0) - pb.min(0), pb.max(0) - pa.min(0))
    return float(overlap.min())


# --------------------------------------------------------------------------
# shape helpers
# --------------------------------------------------------------------------


def _positive(name, x):
    x = float(x)
    if not np.isfinite(x) or x <= 0:
        raise ValueError(f"{name} must be a positive finite length (m), got {x}")
    return x


def box(lx: float, ly: float, lz: float) -> ConvexPolyhedron:
    """Rectangular box with edge lengths ``lx, ly, lz`` (m), centred at the origin.

    ``centroid_world`` is the origin; 8 vertices, 6 faces.
    """
    hx, hy, hz = (
        0.5 * _positive("lx", lx),
        0.5 * _positive("ly", ly),
        0.5 * _positive("lz", lz),
    )
    pts = np.array(
        [[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
    )
    return ConvexPolyhedron.from_vertices(pts)


def wedge(length: float, width: float, height: float) -> ConvexPolyhedron:
    """Right triangular prism (m).

    The triangle lies in the x-z plane with its right angle at the origin and
    legs along +x (``length``) and +z (``height``); it is extruded along +y
    from ``y = 0`` to ``y = width``.  In the input frame the centroid
    (``centroid_world``) is ``(length/3, width/2, height/3)``.
    """
    L, W, H = (
        _positive("length", length),
        _positive("width", width),
        _positive("height", height),
    )
    tri = np.array([[0.0, 0.0], [L, 0.0], [0.0, H]])  # (x, z)
    pts = [[x, y, z] for y in (0.0, W) for (x, z) in tri]
    return ConvexPolyhedron.from_vertices(np.array(pts))


def prism(polygon_xy, height: float) -> ConvexPolyhedron:
    """Extrude a convex polygon in the x-y plane along +z from 0 to ``height``.

    Args:
      polygon_xy: [n, 2] float, n >= 3 corners (m) of a strictly convex
        polygon, in either winding order (no repeated or collinear corners).
      height: extrusion length (m).

    Raises:
      ValueError: if the polygon is not strictly convex and simple.
    """
    h = _positive("height", height)
    poly = np.asarray(polygon_xy, dtype=np.float64)
    if poly.ndim != 2 or poly.shape[1] != 2 or poly.shape[0] < 3:
        raise ValueError(f"polygon_xy must be [n >= 3, 2], got shape {poly.shape}")
    if not np.all(np.isfinite(poly)):
        raise ValueError("polygon_xy contains NaN or inf")
    d = np.roll(poly, -1, axis=0) - poly
    scale = float(np.max(np.linalg.norm(d, axis=1)))
    cross = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    eps = 1e-12 * scale**2
    turning = np.sum(np.arctan2(cross, np.einsum("ij,ij->i", d, np.roll(d, -1, axis=0))))
    if not (np.all(cross > eps) or np.all(cross < -eps)) or abs(abs(turning) - 2 * np.pi) > 1e-6:
        raise ValueError(
            "polygon_xy must be a simple, strictly convex polygon (all turns in the "
            "same direction, no repeated or collinear corners); for other shapes "
            "use ConvexPolyhedron.from_vertices or split into convex pieces"
        )
    pts = np.concatenate(
        [np.c_[poly, np.zeros(len(poly))], np.c_[poly, np.full(len(poly), h)]]
    )
    return ConvexPolyhedron.from_vertices(pts)


def slab(lx: float, ly: float, thickness: float) -> ConvexPolyhedron:
    """A floor: box ``lx x ly x thickness`` (m) whose TOP face is the plane z = 0 of the input frame.

    It spans ``[-lx/2, lx/2] x [-ly/2, ly/2] x [-thickness, 0]``; ``centroid_world`` is
    ``(0, 0, -thickness/2)``, so placing the block at its ``centroid_world`` puts the floor surface
    at z = 0.  Use it as a large FIXED block (``Motion.FIXED``).
    """
    t = _positive("thickness", thickness)
    hx, hy = 0.5 * _positive("lx", lx), 0.5 * _positive("ly", ly)
    pts = np.array(
        [[sx * hx, sy * hy, z] for sx in (-1, 1) for sy in (-1, 1) for z in (-t, 0.0)]
    )
    return ConvexPolyhedron.from_vertices(pts)


def slope(length: float, width: float, thickness: float, angle_deg: float) -> ConvexPolyhedron:
    """An inclined plane: a :func:`slab` rotated about +y so that its top surface descends along +x.

    The top face passes through the origin of the input frame with outward normal
    ``(sin a, 0, cos a)`` (``a = angle_deg`` in degrees, ``0 <= a < 90``); the down-slope unit
    vector is ``(cos a, 0, -sin a)``.  ``length`` is measured along the slope, ``width`` along y.
    Use it as a large FIXED block placed at its ``centroid_world``.
    """
    a = float(angle_deg)
    if not np.isfinite(a) or not 0.0 <= a < 90.0:
        raise ValueError(f"angle_deg must be in [0, 90) degrees, got {angle_deg}")
    base = slab(length, width, thickness)
    pts = base.vertices + base.centroid_world
    c, s = np.cos(np.radians(a)), np.sin(np.radians(a))
    rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return ConvexPolyhedron.from_vertices(pts @ rot.T)


# --------------------------------------------------------------------------
# packing for JAX
# --------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False)
class PackedBlocks:
    """B blocks padded to common sizes (numpy arrays, ready for ``jnp.asarray``).

    Padding: float arrays hold 0, index arrays hold :data:`PAD_INDEX` (-1),
    masks are False.  Indices are local to each block (``he_next[b]`` indexes
    into ``he_*[b]``, ``he_vert[b]`` into ``vertices[b]``, etc.).  Index
    dtype is int32.

    Attributes:
      vertices: [B, Vmax, 3] body-frame vertices (m).
      vertex_mask: [B, Vmax] bool.
      vertex_first_he: [B, Vmax] one outgoing half-edge per vertex.
      face_normal: [B, Fmax, 3] outward unit normals.
      face_offset: [B, Fmax] plane offsets (m), ``n . x = d`` on the face.
      face_first_he: [B, Fmax] one half-edge per face.
      face_mask: [B, Fmax] bool.
      he_vert, he_next, he_prev, he_pair, he_face, he_edge: [B, Emax].
      halfedge_mask: [B, Emax] bool.
      edges: [B, nEmax, 2] undirected edges (vertex pairs).
      edge_mask: [B, nEmax] bool.
      edge_direction: [B, nEmax] the direction group of each edge
        (:meth:`ConvexPolyhedron.edge_directions`).
      direction_edge: [B, nDmax] the representative edge of each direction.
      direction_mask: [B, nDmax] bool.
      n_vertices, n_faces, n_halfedges, n_edges: [B] int32 true counts.
      volume: [B] (m^3).
      inertia_unit_density: [B, 3, 3] inertia about the centroid for unit
        density, body frame (m^5).
      centroid_world: [B, 3] centroid in each block's input frame (m).
      bounding_radius: [B] (m).
    """

    vertices: np.ndarray
    vertex_mask: np.ndarray
    vertex_first_he: np.ndarray
    face_normal: np.ndarray
    face_offset: np.ndarray
    face_first_he: np.ndarray
    face_mask: np.ndarray
    he_vert: np.ndarray
    he_next: np.ndarray
    he_prev: np.ndarray
    he_pair: np.ndarray
    he_face: np.ndarray
    he_edge: np.ndarray
    halfedge_mask: np.ndarray
    edges: np.ndarray
    edge_mask: np.ndarray
    edge_direction: np.ndarray
    direction_edge: np.ndarray
    direction_mask: np.ndarray
    n_vertices: np.ndarray
    n_faces: np.ndarray
    n_halfedges: np.ndarray
    n_edges: np.ndarray
    volume: np.ndarray
    inertia_unit_density: np.ndarray
    centroid_world: np.ndarray
    bounding_radius: np.ndarray

    @property
    def n_blocks(self) -> int:
        """Number of blocks B."""
        return int(self.volume.shape[0])

    @property
    def max_vertices(self) -> int:
        """Padded vertex count Vmax."""
        return int(self.vertices.shape[1])

    @property
    def max_faces(self) -> int:
        """Padded face count Fmax."""
        return int(self.face_normal.shape[1])

    @property
    def max_halfedges(self) -> int:
        """Padded half-edge count Emax."""
        return int(self.he_vert.shape[1])

    @property
    def max_edges(self) -> int:
        """Padded edge count nEmax (= Emax // 2)."""
        return int(self.edges.shape[1])

    @property
    def max_directions(self) -> int:
        """Padded edge-direction count nDmax."""
        return int(self.direction_edge.shape[1])


def pack(
    polyhedra: Sequence[ConvexPolyhedron],
    *,
    max_vertices: int | None = None,
    max_faces: int | None = None,
    max_halfedges: int | None = None,
    max_directions: int | None = None,
) -> PackedBlocks:
    """Pad several blocks to common array sizes.

    Args:
      polyhedra: non-empty sequence of :class:`ConvexPolyhedron`.
      max_vertices: Vmax; default the largest ``n_vertices``.
      max_faces: Fmax; default the largest ``n_faces``.
      max_halfedges: Emax; default the largest ``n_halfedges``.  The edge
        arrays are padded to ``nEmax = Emax // 2``.
      max_directions: nDmax, edge directions (:meth:`ConvexPolyhedron.edge_directions`); default
        the largest count.

    Returns:
      :class:`PackedBlocks`.

    Raises:
      ValueError: empty input, or a given maximum smaller than needed (the
        message names the field and the needed value).
      TypeError: an item is not a :class:`ConvexPolyhedron`.
    """
    polys = list(polyhedra)
    if not polys:
        raise ValueError("pack() needs at least one polyhedron")
    for i, p in enumerate(polys):
        if not isinstance(p, ConvexPolyhedron):
            raise TypeError(f"polyhedra[{i}] is {type(p).__name__}, not ConvexPolyhedron")

    def _size(name, given, counts):
        need = max(counts)
        if given is None:
            return need
        given = int(given)
        if given < need:
            block = int(np.argmax(counts))
            raise ValueError(
                f"{name}={given} is too small: block {block} needs {name} >= {need}"
            )
        return given

    B = len(polys)
    nv = [p.n_vertices for p in polys]
    nf = [p.n_faces for p in polys]
    ne = [p.n_halfedges for p in polys]
    Vm = _size("max_vertices", max_vertices, nv)
    Fm = _size("max_faces", max_faces, nf)
    Em = _size("max_halfedges", max_halfedges, ne)
    Km = Em // 2
    dirs = [p.edge_directions() for p in polys]
    Dm = _size("max_directions", max_directions, [len(r) for _, r in dirs])

    def ipad(shape):
        return np.full(shape, PAD_INDEX, dtype=_INT)

    out = dict(
        vertices=np.zeros((B, Vm, 3)),
        vertex_mask=np.zeros((B, Vm), dtype=bool),
        vertex_first_he=ipad((B, Vm)),
        face_normal=np.zeros((B, Fm, 3)),
        face_offset=np.zeros((B, Fm)),
        face_first_he=ipad((B, Fm)),
        face_mask=np.zeros((B, Fm), dtype=bool),
        he_vert=ipad((B, Em)),
        he_next=ipad((B, Em)),
        he_prev=ipad((B, Em)),
        he_pair=ipad((B, Em)),
        he_face=ipad((B, Em)),
        he_edge=ipad((B, Em)),
        halfedge_mask=np.zeros((B, Em), dtype=bool),
        edges=ipad((B, Km, 2)),
        edge_mask=np.zeros((B, Km), dtype=bool),
        edge_direction=ipad((B, Km)),
        direction_edge=ipad((B, Dm)),
        direction_mask=np.zeros((B, Dm), dtype=bool),
        n_vertices=np.asarray(nv, dtype=_INT),
        n_faces=np.asarray(nf, dtype=_INT),
        n_halfedges=np.asarray(ne, dtype=_INT),
        n_edges=np.asarray([p.n_edges for p in polys], dtype=_INT),
        volume=np.asarray([p.volume for p in polys], dtype=np.float64),
        inertia_unit_density=np.stack([p.inertia_unit_density for p in polys]),
        centroid_world=np.stack([p.centroid_world for p in polys]),
        bounding_radius=np.asarray([p.bounding_radius for p in polys]),
    )
    for b, p in enumerate(polys):
        V, F, E, K = p.n_vertices, p.n_faces, p.n_halfedges, p.n_edges
        out["vertices"][b, :V] = p.vertices
        out["vertex_mask"][b, :V] = True
        out["vertex_first_he"][b, :V] = p.vertex_first_he
        out["face_normal"][b, :F] = p.face_normal
        out["face_offset"][b, :F] = p.face_offset
        out["face_first_he"][b, :F] = p.face_first_he
        out["face_mask"][b, :F] = True
        for name in ("he_vert", "he_next", "he_prev", "he_pair", "he_face", "he_edge"):
            out[name][b, :E] = getattr(p, name)
        out["halfedge_mask"][b, :E] = True
        out["edges"][b, :K] = p.edges
        out["edge_mask"][b, :K] = True
        group, rep = dirs[b]
        out["edge_direction"][b, :K] = group
        out["direction_edge"][b, :len(rep)] = rep
        out["direction_mask"][b, :len(rep)] = True
    return PackedBlocks(**out)
