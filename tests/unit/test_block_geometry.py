"""Unit tests for rockjax.blocks.geometry (host-side convex polyhedra)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from rockjax.blocks.geometry import (
    PAD_INDEX,
    ConvexPolyhedron,
    PackedBlocks,
    box,
    mass_properties,
    pack,
    prism,
    wedge,
)

RTOL = 1e-12


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------


def check_halfedge_invariants(
    p: ConvexPolyhedron, tol: float = 1e-9, *, merged: bool = True
) -> None:
    """All structural and geometric invariants of a valid block."""
    E, F, V = p.n_halfedges, p.n_faces, p.n_vertices
    e = np.arange(E)
    size = 2.0 * p.bounding_radius

    # half-edge table
    np.testing.assert_array_equal(p.he_next[p.he_prev], e)
    np.testing.assert_array_equal(p.he_prev[p.he_next], e)
    np.testing.assert_array_equal(p.he_pair[p.he_pair], e)
    assert np.all(p.he_pair != e)
    np.testing.assert_array_equal(p.he_vert[p.he_pair], p.he_vert[p.he_next])
    np.testing.assert_array_equal(p.he_face[p.he_next], p.he_face)
    assert np.all(p.he_face[p.he_pair] != p.he_face)
    np.testing.assert_array_equal(p.he_edge[p.he_pair], p.he_edge)
    assert E % 2 == 0 and p.n_edges == E // 2
    # Euler characteristic of a convex polyhedron
    assert V - E // 2 + F == 2
    # edges: unique, sorted, consistent with he_edge
    assert np.all(p.edges[:, 0] < p.edges[:, 1])
    assert len({tuple(x) for x in p.edges.tolist()}) == p.n_edges
    np.testing.assert_array_equal(
        np.sort(np.c_[p.he_vert, p.he_vert[p.he_next]], axis=1), p.edges[p.he_edge]
    )
    # vertex_first_he is outgoing; every vertex used
    np.testing.assert_array_equal(p.he_vert[p.vertex_first_he], np.arange(V))
    np.testing.assert_array_equal(p.he_face[p.face_first_he], np.arange(F))

    # every face loop closes and the loops partition the half-edges
    seen = np.zeros(E, dtype=int)
    for f in range(F):
        hes = p.face_halfedges(f)
        assert len(hes) >= 3
        assert np.all(p.he_face[hes] == f)
        seen[hes] += 1
    assert np.all(seen == 1)

    # walks around each vertex: each incident face/edge exactly once
    for v in range(V):
        faces = p.faces_around_vertex(v)
        edges = p.edges_around_vertex(v)
        assert len(faces) >= 3
        assert len(set(faces.tolist())) == len(faces)
        assert sorted(faces.tolist()) == sorted(set(p.he_face[p.he_vert == v].tolist()))
        assert sorted(edges.tolist()) == sorted(
            np.nonzero((p.edges == v).any(axis=1))[0].tolist()
        )
        # counter-clockwise seen from outside: consecutive outgoing edges
        # d_i, d_{i+1} bound the corner of face(e_i) at v, and that corner is
        # convex and counter-clockwise about the face's outward normal
        hes = p.halfedges_around_vertex(v)
        np.testing.assert_array_equal(np.roll(hes, -1), p.he_pair[p.he_prev[hes]])
        d = p.vertices[p.he_vert[p.he_next[hes]]] - p.vertices[v]
        corner = np.einsum(
            "ij,ij->i", np.cross(d, np.roll(d, -1, axis=0)), p.face_normal[faces]
        )
        assert np.all(corner > 0.0)

    # planes: unit outward normals, planar faces, convexity
    np.testing.assert_allclose(np.linalg.norm(p.face_normal, axis=1), 1.0, rtol=1e-12)
    for f in range(F):
        fv = p.face_vertices(f)
        dist = p.vertices[fv] @ p.face_normal[f] - p.face_offset[f]
        assert np.max(np.abs(dist)) <= tol * size, "face not planar"
    all_dist = p.vertices @ p.face_normal.T - p.face_offset[None, :]
    assert np.max(all_dist) <= tol * size, "a vertex is outside a face plane"
    # the centroid (origin) is strictly inside
    assert np.all(p.face_offset > 0)
    if merged:
        # adjacent faces are not coplanar (merging worked)
        f1, f2 = p.he_face, p.he_face[p.he_pair]
        cosang = np.einsum("ij,ij->i", p.face_normal[f1], p.face_normal[f2])
        assert np.all(cosang < 1.0 - 1e-12)
    # closed surface: sum of area-weighted normals vanishes
    tri = p.triangles()
    a, b, c = (p.vertices[tri[:, k]] for k in range(3))
    area_n = 0.5 * np.cross(b - a, c - a)
    np.testing.assert_allclose(area_n.sum(axis=0), 0.0, atol=1e-12 * size**2)
    # fan triangles are wound outward, consistent with the face normals
    tri_face = np.repeat(np.arange(F), [len(p.face_vertices(f)) - 2 for f in range(F)])
    assert np.all(np.einsum("ij,ij->i", area_n, p.face_normal[tri_face]) >= -1e-14 * size**2)
    # body frame: centroid at the origin
    vol, cen, _ = mass_properties(p.vertices, tri)
    np.testing.assert_allclose(vol, p.volume, rtol=1e-12)
    np.testing.assert_allclose(cen, 0.0, atol=1e-12 * size)
    assert p.bounding_radius == pytest.approx(np.max(np.linalg.norm(p.vertices, axis=1)))


def box_inertia(m, lx, ly, lz):
    return m / 12.0 * np.diag([ly**2 + lz**2, lx**2 + lz**2, lx**2 + ly**2])


def right_tet_inertia(a, b, c):
    """Inertia about the centroid, unit density, of tet (0, a e1, b e2, c e3).

    From int x_i x_j dV = V (1 + delta_ij) a_i a_j / 20 and centroid a_i / 4:
    central second moments C = V/80 [[3a^2, -ab, -ac], ...], I = tr(C) 1 - C.
    """
    vol = a * b * c / 6.0
    s = np.array([a, b, c])
    C = vol / 80.0 * (4.0 * np.diag(s**2) - np.outer(s, s))
    return vol, np.trace(C) * np.eye(3) - C


def wedge_inertia(L, W, H):
    """Right triangular prism: triangle (0,0),(L,0),(0,H) in x-z, y in [0, W].

    Triangle central second moments (area A = LH/2): int dx^2 = A L^2/18,
    int dz^2 = A H^2/18, int dx dz = -A L H/36.  Times W for the prism, plus
    int dy^2 = m W^2/12, with m = A W (unit density).
    """
    m = 0.5 * L * H * W
    Cxx, Cyy, Czz, Cxz = m * L**2 / 18, m * W**2 / 12, m * H**2 / 18, -m * L * H / 36
    C = np.array([[Cxx, 0, Cxz], [0, Cyy, 0], [Cxz, 0, Czz]])
    return m, np.trace(C) * np.eye(3) - C


# --------------------------------------------------------------------------
# closed forms
# --------------------------------------------------------------------------


@pytest.mark.parametrize("dims", [(1.0, 1.0, 1.0), (2.0, 0.5, 3.0), (1e-3, 2e-3, 5e-4)])
def test_box(dims):
    lx, ly, lz = dims
    p = box(lx, ly, lz)
    assert (p.n_vertices, p.n_faces, p.n_halfedges, p.n_edges) == (8, 6, 24, 12)
    m = lx * ly * lz
    assert p.volume == pytest.approx(m, rel=RTOL)
    np.testing.assert_allclose(
        p.inertia_unit_density, box_inertia(m, lx, ly, lz), rtol=RTOL, atol=1e-15 * m * lx**2
    )
    np.testing.assert_allclose(p.centroid_world, 0.0, atol=1e-15)
    assert p.bounding_radius == pytest.approx(0.5 * np.linalg.norm(dims), rel=RTOL)
    for v in range(8):
        assert len(p.faces_around_vertex(v)) == 3
        assert len(p.edges_around_vertex(v)) == 3
    for f in range(6):
        assert len(p.face_vertices(f)) == 4
    # face normals are the six axis directions, offsets the half lengths
    np.testing.assert_allclose(np.abs(p.face_normal).max(axis=1), 1.0, rtol=RTOL)
    assert sorted(np.argmax(np.abs(p.face_normal), axis=1).tolist()) == [0, 0, 1, 1, 2, 2]
    half = 0.5 * np.array(dims)
    for n, d in zip(p.face_normal, p.face_offset):
        axis = int(np.argmax(np.abs(n)))
        assert d == pytest.approx(half[axis], rel=RTOL)
    check_halfedge_invariants(p)


def test_box_translated_keeps_world_centroid():
    pts = box(1.0, 2.0, 3.0).vertices + np.array([10.0, -5.0, 2.0])
    p = ConvexPolyhedron.from_vertices(pts)
    np.testing.assert_allclose(p.centroid_world, [10.0, -5.0, 2.0], rtol=1e-14)
    np.testing.assert_allclose(
        p.inertia_unit_density, box_inertia(6.0, 1.0, 2.0, 3.0), rtol=1e-11
    )


def test_right_tetrahedron():
    a, b, c = 1.0, 2.0, 3.0
    pts = np.array([[0, 0, 0], [a, 0, 0], [0, b, 0], [0, 0, c]], dtype=float)
    p = ConvexPolyhedron.from_vertices(pts)
    vol, inertia = right_tet_inertia(a, b, c)
    assert (p.n_vertices, p.n_faces, p.n_halfedges) == (4, 4, 12)
    assert p.volume == pytest.approx(vol, rel=RTOL)
    np.testing.assert_allclose(p.centroid_world, [a / 4, b / 4, c / 4], rtol=RTOL)
    np.testing.assert_allclose(p.inertia_unit_density, inertia, rtol=1e-12)
    check_halfedge_invariants(p)


def test_cube_inertia_assembled_from_right_tetrahedra():
    """Cube [0,1]^3 = corner tetrahedra cut off + middle tetrahedron.

    The unit cube splits into the regular tetrahedron on (1,0,0),(0,1,0),
    (0,0,1),(1,1,1) and four right corner tetrahedra; sum of their second
    moments (parallel-axis theorem) must equal the cube's.
    """
    corners = np.array([[0, 0, 0], [1, 1, 0], [1, 0, 1], [0, 1, 1]], dtype=float)
    total_C = np.zeros((3, 3))
    total_v = 0.0
    pieces = [ConvexPolyhedron.from_vertices(
        np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=float))]
    for c in corners:
        nbrs = [c + s * e for e, s in zip(np.eye(3), np.where(c == 0, 1.0, -1.0))]
        pieces.append(ConvexPolyhedron.from_vertices(np.vstack([c, nbrs])))
    for q in pieces:
        I = q.inertia_unit_density
        C = 0.5 * np.trace(I) * np.eye(3) - I  # central second moments
        x = q.centroid_world - 0.5
        total_C += C + q.volume * np.outer(x, x)
        total_v += q.volume
    assert total_v == pytest.approx(1.0, rel=RTOL)
    total_I = np.trace(total_C) * np.eye(3) - total_C
    np.testing.assert_allclose(total_I, box_inertia(1.0, 1, 1, 1), rtol=1e-12, atol=1e-15)


def test_regular_tetrahedron():
    s = 2.0  # edge length
    pts = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    pts = pts * s / (2.0 * np.sqrt(2.0)) + np.array([0.3, -0.2, 5.0])
    p = ConvexPolyhedron.from_vertices(pts)
    vol = s**3 / (6.0 * np.sqrt(2.0))
    assert p.volume == pytest.approx(vol, rel=RTOL)
    np.testing.assert_allclose(p.centroid_world, pts.mean(axis=0), rtol=RTOL)
    # isotropic inertia m s^2 / 20
    np.testing.assert_allclose(
        p.inertia_unit_density, vol * s**2 / 20.0 * np.eye(3), rtol=1e-12, atol=1e-14
    )
    # distance centroid -> face is s / sqrt(24), -> vertex s sqrt(6)/4
    np.testing.assert_allclose(p.face_offset, s / np.sqrt(24.0), rtol=1e-12)
    assert p.bounding_radius == pytest.approx(s * np.sqrt(6.0) / 4.0, rel=1e-12)
    check_halfedge_invariants(p)


@pytest.mark.parametrize("dims", [(3.0, 2.0, 1.5), (1.0, 1.0, 1.0), (0.2, 5.0, 0.7)])
def test_wedge(dims):
    L, W, H = dims
    p = wedge(L, W, H)
    assert (p.n_vertices, p.n_faces, p.n_halfedges) == (6, 5, 18)
    assert sorted(len(p.face_vertices(f)) for f in range(5)) == [3, 3, 4, 4, 4]
    m, inertia = wedge_inertia(L, W, H)
    assert p.volume == pytest.approx(L * H * W / 2.0, rel=RTOL)
    np.testing.assert_allclose(p.centroid_world, [L / 3, W / 2, H / 3], rtol=RTOL)
    # zero products of inertia come out at rounding level: absolute tolerance
    # relative to the tensor's size
    scale = np.abs(inertia).max()
    np.testing.assert_allclose(p.inertia_unit_density, inertia, rtol=1e-12, atol=1e-15 * scale)
    # second, independent check: trimesh's mass properties (density 1)
    tm = p.to_trimesh()
    np.testing.assert_allclose(tm.volume, m, rtol=1e-12)
    np.testing.assert_allclose(tm.moment_inertia, inertia, rtol=1e-10, atol=1e-14 * scale)
    check_halfedge_invariants(p)


def test_prism_hexagon():
    ang = np.linspace(0, 2 * np.pi, 7)[:-1]
    r, h = 0.8, 1.7
    poly = np.c_[r * np.cos(ang), r * np.sin(ang)] + [1.0, 2.0]
    p = prism(poly[::-1], h)  # clockwise input is fine
    assert (p.n_vertices, p.n_faces) == (12, 8)
    area = 1.5 * np.sqrt(3.0) * r**2
    assert p.volume == pytest.approx(area * h, rel=RTOL)
    np.testing.assert_allclose(p.centroid_world, [1.0, 2.0, h / 2], rtol=1e-12)
    # regular hexagon: polar moment about centroid = 5 sqrt(3)/8 r^4
    Izz = 5.0 * np.sqrt(3.0) / 8.0 * r**4 * h
    assert p.inertia_unit_density[2, 2] == pytest.approx(Izz, rel=1e-12)
    np.testing.assert_allclose(
        p.to_trimesh().moment_inertia, p.inertia_unit_density, rtol=1e-10, atol=1e-14
    )
    check_halfedge_invariants(p)


def test_prism_rejects_nonconvex_polygon():
    L = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]]
    with pytest.raises(ValueError, match="convex"):
        prism(L, 1.0)
    with pytest.raises(ValueError, match="convex"):
        prism([[0, 0], [1, 0], [2, 0], [0, 1]], 1.0)  # collinear corner


def test_points_inside_on_faces_and_edges_are_not_vertices():
    corners = box(2.0, 2.0, 2.0).vertices
    extra = np.array(
        [
            [0.0, 0.0, 0.0],  # interior
            [0.3, -0.2, 1.0],  # face interior
            [1.0, 0.0, 1.0],  # edge midpoint
            [1.0, 1.0, 0.25],  # on an edge
            [0.0, 0.0, -1.0],  # face centre
        ]
    )
    p = ConvexPolyhedron.from_vertices(np.vstack([extra, corners]))
    assert (p.n_vertices, p.n_faces, p.n_halfedges) == (8, 6, 24)
    np.testing.assert_allclose(np.abs(p.vertices), 1.0, rtol=1e-14)
    assert p.volume == pytest.approx(8.0, rel=RTOL)
    check_halfedge_invariants(p)


def test_nearly_coplanar_facets_are_merged():
    """A 5x5x5 grid of points jittered by 1e-11 m: still a cube with 6 faces."""
    g = np.linspace(-1.0, 1.0, 5)
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    pts = grid + 1e-11 * np.random.default_rng(3).normal(size=grid.shape)
    p = ConvexPolyhedron.from_vertices(pts)
    assert (p.n_vertices, p.n_faces, p.n_halfedges) == (8, 6, 24)
    assert p.volume == pytest.approx(8.0, rel=1e-9)
    check_halfedge_invariants(p, tol=1e-9)
    # with a zero angle tolerance the jitter makes many small facets
    q = ConvexPolyhedron.from_vertices(pts, angle_tol=0.0)
    assert q.n_faces > 6
    check_halfedge_invariants(q, tol=1e-9, merged=False)


def test_faces_are_read_only():
    p = box(1, 1, 1)
    with pytest.raises(ValueError):
        p.vertices[0, 0] = 5.0
    with pytest.raises(AttributeError):
        p.volume = 2.0  # frozen dataclass


# --------------------------------------------------------------------------
# property tests on random convex hulls
# --------------------------------------------------------------------------


@st.composite
def point_clouds(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    n = draw(st.integers(4, 40))
    kind = draw(st.sampled_from(["gauss", "grid", "sphere"]))
    rng = np.random.default_rng(seed)
    if kind == "gauss":
        pts = rng.normal(size=(n, 3)) * rng.uniform(0.1, 3.0, size=3)
    elif kind == "grid":  # many exactly coplanar/collinear points
        pts = np.unique(rng.integers(-2, 3, size=(n, 3)), axis=0).astype(float) * 0.37
    else:
        pts = rng.normal(size=(n, 3))
        pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    pts = pts + rng.uniform(-10.0, 10.0, size=3)
    return pts


@settings(max_examples=30, deadline=None)
@given(point_clouds())
def test_random_hull_invariants(pts):
    if len(pts) < 4:
        assume(False)
    centred = pts - pts.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    assume(len(sv) == 3 and sv[2] > 1e-3 * sv[0])
    from scipy.spatial import cKDTree

    size = np.linalg.norm(np.ptp(pts, axis=0))
    assume(len(cKDTree(pts).query_pairs(1e-6 * size)) == 0)

    p = ConvexPolyhedron.from_vertices(pts)
    check_halfedge_invariants(p)

    # the block is the convex hull: volume and vertices agree with trimesh
    hull = trimesh.convex.convex_hull(pts)
    assert p.volume == pytest.approx(hull.volume, rel=1e-9)
    tm = p.to_trimesh()
    tm_world = trimesh.Trimesh(tm.vertices + p.centroid_world, tm.faces, process=False)
    np.testing.assert_allclose(tm_world.center_mass, p.centroid_world, rtol=0, atol=1e-9 * size)
    np.testing.assert_allclose(
        tm.moment_inertia, p.inertia_unit_density, rtol=1e-8, atol=1e-10 * p.volume * size**2
    )
    # every input point is inside every face plane
    d = (pts - p.centroid_world) @ p.face_normal.T - p.face_offset
    assert np.max(d) <= 1e-9 * size
    # vertices are a subset of the input points
    world = p.vertices + p.centroid_world
    dmin = np.min(np.linalg.norm(world[:, None, :] - pts[None, :, :], axis=2), axis=1)
    assert np.max(dmin) <= 1e-12 * max(size, np.abs(pts).max())

    # rotation covariance of the inertia tensor
    q, _ = np.linalg.qr(np.random.default_rng(len(pts)).normal(size=(3, 3)))
    pr = ConvexPolyhedron.from_vertices(pts @ q.T)
    np.testing.assert_allclose(
        pr.inertia_unit_density,
        q @ p.inertia_unit_density @ q.T,
        rtol=1e-9,
        atol=1e-9 * p.volume * size**2,
    )
    assert pr.n_faces == p.n_faces and pr.n_vertices == p.n_vertices


# --------------------------------------------------------------------------
# validation
# --------------------------------------------------------------------------


def test_from_trimesh_box_matches_box():
    m = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    m.apply_translation([1.0, 2.0, 3.0])
    p = ConvexPolyhedron.from_trimesh(m)
    assert (p.n_vertices, p.n_faces, p.n_halfedges) == (8, 6, 24)
    np.testing.assert_allclose(p.centroid_world, [1.0, 2.0, 3.0], rtol=1e-14)
    np.testing.assert_allclose(
        p.inertia_unit_density, box_inertia(6.0, 1.0, 2.0, 3.0), rtol=1e-12
    )
    check_halfedge_invariants(p)


def test_from_trimesh_icosphere():
    m = trimesh.creation.icosphere(subdivisions=2, radius=2.0)
    p = ConvexPolyhedron.from_trimesh(m)
    assert p.n_vertices == len(m.vertices)
    assert p.volume == pytest.approx(m.volume, rel=1e-12)
    np.testing.assert_allclose(p.inertia_unit_density, m.moment_inertia, rtol=1e-10, atol=1e-12)
    check_halfedge_invariants(p)


def test_open_mesh_raises():
    m = trimesh.creation.box()
    open_mesh = trimesh.Trimesh(m.vertices, m.faces[:-1], process=False)
    with pytest.raises(ValueError, match="not closed") as exc:
        ConvexPolyhedron.from_trimesh(open_mesh)
    assert "3 boundary edges" in str(exc.value)
    assert "from_vertices" in str(exc.value)


def _l_prism() -> trimesh.Trimesh:
    v2 = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)
    f2 = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    return trimesh.creation.extrude_triangulation(v2, f2, height=1.0)


def test_nonconvex_mesh_raises():
    m = _l_prism()
    assert m.is_watertight and m.volume == pytest.approx(3.0)
    with pytest.raises(ValueError, match="not convex"):
        ConvexPolyhedron.from_trimesh(m)
    # a dented box (one corner pushed inside the hull of the others)
    d = trimesh.creation.box()
    v = d.vertices.copy()
    v[0] *= 0.2
    dented = trimesh.Trimesh(v, d.faces, process=False)
    with pytest.raises(ValueError, match="not convex"):
        ConvexPolyhedron.from_trimesh(dented)
    # ... but the convex hull of its vertices is a valid block (the dent vertex dropped)
    assert ConvexPolyhedron.from_vertices(dented.vertices).n_vertices == 7


def test_two_bodies_raise():
    a = trimesh.creation.box()
    b = trimesh.creation.box()
    b.apply_translation([0.5, 0.5, 0.0])  # overlapping
    with pytest.raises(ValueError, match="several bodies"):
        ConvexPolyhedron.from_trimesh(trimesh.util.concatenate([a, b]))


def test_inverted_mesh_raises():
    m = trimesh.creation.box()
    m.invert()
    with pytest.raises(ValueError, match="inward") as exc:
        ConvexPolyhedron.from_trimesh(m)
    assert "invert()" in str(exc.value)


def test_inconsistent_winding_raises():
    m = trimesh.creation.box()
    faces = m.faces.copy()
    faces[0] = faces[0][::-1]
    with pytest.raises(ValueError, match="winding"):
        ConvexPolyhedron.from_trimesh(trimesh.Trimesh(m.vertices, faces, process=False))


def test_duplicate_vertices_raise():
    m = trimesh.creation.box()
    tri = m.triangles.reshape(-1, 3)
    unwelded = trimesh.Trimesh(tri, np.arange(len(tri)).reshape(-1, 3), process=False)
    with pytest.raises(ValueError, match="merge_vertices"):
        ConvexPolyhedron.from_trimesh(unwelded)
    pts = np.vstack([box(1, 1, 1).vertices, [[0.5, 0.5, 0.5 + 1e-13]]])
    with pytest.raises(ValueError, match="duplicate"):
        ConvexPolyhedron.from_vertices(pts)


def test_degenerate_raises():
    flat = np.random.default_rng(1).normal(size=(10, 3))
    flat[:, 2] = 0.0
    with pytest.raises(ValueError, match="coplanar"):
        ConvexPolyhedron.from_vertices(flat)
    with pytest.raises(ValueError, match="collinear"):
        ConvexPolyhedron.from_vertices(np.outer(np.arange(5.0), [1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="at least 4"):
        ConvexPolyhedron.from_vertices(np.eye(3))
    # a flat, two-sided closed mesh
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=float)
    flat_mesh = trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 1]], process=False)
    with pytest.raises(ValueError, match="degenerate"):
        ConvexPolyhedron.from_trimesh(flat_mesh)
    with pytest.raises(ValueError, match="positive"):
        box(1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="NaN"):
        ConvexPolyhedron.from_vertices(np.r_[box(1, 1, 1).vertices, [[np.nan, 0, 0]]])


def test_mass_properties_sign():
    p = box(1.0, 2.0, 3.0)
    tri = p.triangles()
    vol, cen, inertia = mass_properties(p.vertices, tri)
    assert vol == pytest.approx(6.0)
    vol_in, _, inertia_in = mass_properties(p.vertices, tri[:, ::-1])
    assert vol_in == pytest.approx(-6.0)
    np.testing.assert_allclose(inertia_in, -inertia, rtol=1e-12)


# --------------------------------------------------------------------------
# packing
# --------------------------------------------------------------------------


def test_pack_shapes_and_masks():
    blocks = [box(1, 2, 3), wedge(1, 1, 1), ConvexPolyhedron.from_trimesh(
        trimesh.creation.icosphere(subdivisions=1))]
    pk = pack(blocks)
    assert isinstance(pk, PackedBlocks)
    B = 3
    Vm = max(b.n_vertices for b in blocks)
    Fm = max(b.n_faces for b in blocks)
    Em = max(b.n_halfedges for b in blocks)
    assert pk.n_blocks == B
    assert pk.vertices.shape == (B, Vm, 3)
    assert pk.face_normal.shape == (B, Fm, 3) and pk.face_offset.shape == (B, Fm)
    for name in ("he_vert", "he_next", "he_prev", "he_pair", "he_face", "he_edge"):
        arr = getattr(pk, name)
        assert arr.shape == (B, Em) and arr.dtype == np.int32
    assert pk.edges.shape == (B, Em // 2, 2)
    assert pk.inertia_unit_density.shape == (B, 3, 3)
    assert pk.volume.shape == (B,)
    for b, blk in enumerate(blocks):
        V, F, E, K = blk.n_vertices, blk.n_faces, blk.n_halfedges, blk.n_edges
        assert pk.vertex_mask[b].sum() == V and pk.vertex_mask[b, :V].all()
        assert pk.face_mask[b].sum() == F and pk.halfedge_mask[b].sum() == E
        assert pk.edge_mask[b].sum() == K
        np.testing.assert_array_equal(pk.vertices[b, :V], blk.vertices)
        np.testing.assert_array_equal(pk.vertices[b, V:], 0.0)
        np.testing.assert_array_equal(pk.he_next[b, :E], blk.he_next)
        assert np.all(pk.he_next[b, E:] == PAD_INDEX)
        assert np.all(pk.edges[b, K:] == PAD_INDEX)
        assert np.all(pk.face_first_he[b, F:] == PAD_INDEX)
        assert np.all(pk.vertex_first_he[b, V:] == PAD_INDEX)
        np.testing.assert_array_equal(pk.face_normal[b, :F], blk.face_normal)
        assert pk.volume[b] == blk.volume
        np.testing.assert_array_equal(pk.inertia_unit_density[b], blk.inertia_unit_density)
        assert (pk.n_vertices[b], pk.n_faces[b], pk.n_halfedges[b], pk.n_edges[b]) == (V, F, E, K)


def test_pack_explicit_sizes_and_errors():
    blocks = [box(1, 1, 1), wedge(1, 1, 1)]
    pk = pack(blocks, max_vertices=10, max_faces=9, max_halfedges=30)
    assert pk.vertices.shape == (2, 10, 3)
    assert pk.face_mask.shape == (2, 9)
    assert pk.he_vert.shape == (2, 30) and pk.edges.shape == (2, 15, 2)
    with pytest.raises(ValueError, match=r"max_vertices=7.*needs max_vertices >= 8"):
        pack(blocks, max_vertices=7)
    with pytest.raises(ValueError, match=r"max_faces.*>= 6"):
        pack(blocks, max_faces=5)
    with pytest.raises(ValueError, match=r"max_halfedges.*>= 24"):
        pack(blocks, max_halfedges=20)
    with pytest.raises(ValueError, match="at least one"):
        pack([])
    with pytest.raises(TypeError):
        pack([trimesh.creation.box()])


def test_project_equals_matrix_products():
    """``blocks.rotation.project`` (the narrow phase's products over 3 components as multiply-adds)
    equals ``X @ N.T`` for a batch of points and a table of directions, and ``X @ n`` for one."""
    import jax.numpy as jnp

    from rockjax.blocks.rotation import project

    rng = np.random.default_rng(3)
    X = rng.normal(size=(5, 7, 3))
    N = rng.normal(size=(11, 3))
    np.testing.assert_allclose(np.asarray(project(jnp.asarray(X), jnp.asarray(N))), X @ N.T, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(np.asarray(project(jnp.asarray(X), jnp.asarray(N[0]))), X @ N[0], rtol=1e-6, atol=1e-6)
    assert project(jnp.asarray(X), jnp.asarray(N)).shape == (5, 7, 11)


def test_sliding_wedge_guided_locks_the_wedge_only():
    """``sliding_wedge(guided=True)``: the wedge (block 0) is held in the x-z plane (y, rx, rz
    locked); the slope and floor (FIXED) carry no lock; unguided, nothing is locked."""
    import rockjax as rj

    kw = dict(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2, flat_length=0.4)
    guided = rj.scenes.sliding_wedge(guided=True, **kw).config.blocks.locked
    assert guided == ((False, True, False, True, False, True), (False,) * 6, (False,) * 6)
    assert rj.scenes.sliding_wedge(**kw).config.blocks.locked == ()
