"""Boundary particles of a block (``scenes.block_sampling``): the outer layer lies exactly dx/2
inside every face whatever the face's orientation, the layers have no hole wider than a cubic
lattice's, acute edges are covered, the particles' volumes partition the block's shell and make
its kernel sum that of the solid, a box gets the cubic lattice, a too-thin block is refused.

The geometric facts checked: a point of a face-parallel surface is within sqrt(3)/2 dx of the
cubic lattice's points when that lattice is aligned with it (sqrt(2)/2 in the plane); the
dx/2-deep surface of a convex block is the boundary of the block shrunk by dx/2, whose area is
computed independently here (scipy's half-space intersection and convex hull).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull, HalfspaceIntersection, cKDTree
from scipy.spatial.transform import Rotation

from rockjax.blocks.geometry import ConvexPolyhedron, box, wedge
from rockjax.scenes.block_sampling import inscribed_sphere, sample_block_particles

DX = 0.02


def _faces(poly):
    return np.asarray(poly.face_normal, float), np.asarray(poly.face_offset, float)


def _depth(points, poly):
    n, d = _faces(poly)
    return np.min(d[None] - points @ n.T, axis=1)


def _shrunk_surface(poly, depth, n_rays=20000, seed=0):
    """Points on the boundary of the block shrunk by ``depth`` (rays from its inscribed centre)
    and that boundary's area."""
    n, d = _faces(poly)
    c, _ = inscribed_sphere(n, d)
    u = np.random.default_rng(seed).normal(size=(n_rays, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    nu = u @ n.T
    t = np.where(nu > 1e-12, (d - depth - n @ c)[None] / np.where(nu > 1e-12, nu, 1.0), np.inf).min(1)
    hs = HalfspaceIntersection(np.concatenate([n, -(d - depth)[:, None]], axis=1), c)
    return c + t[:, None] * u, ConvexHull(hs.intersections).area


def _blocks():
    rng = np.random.default_rng(7)
    rot = Rotation.random(random_state=3).as_matrix()
    hulls = [ConvexPolyhedron.from_vertices(rng.normal(size=(12, 3)) * np.array([0.1, 0.07, 0.05]))
             for _ in range(3)]
    return {
        "wedge_25deg": wedge(0.4, 0.2, 0.4 * np.tan(np.radians(25.0))),
        "turned_box": ConvexPolyhedron.from_vertices(np.asarray(box(0.1, 0.08, 0.06).vertices) @ rot.T),
        "hull_0": hulls[0], "hull_1": hulls[1], "hull_2": hulls[2],
    }


BLOCKS = _blocks()


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_outer_layer_dx_half_inside_every_face(name):
    poly = BLOCKS[name]
    pts = sample_block_particles(poly, DX, 3)
    depth = _depth(pts, poly)
    assert depth.min() > 0.0  # all inside
    # the outer layer is exactly dx/2 deep; behind it a cubic lattice from dx deep; the only others
    # are the acute-edge cover, shallower than dx/2
    outer = np.abs(depth - 0.5 * DX) < 1e-9
    assert np.all(outer | (depth >= DX * (1 - 1e-9)) | (depth < 0.5 * DX)), np.sort(depth) / DX
    assert np.sum(outer) > 0.4 * len(pts)
    # spacing: no two particles closer than dx/2
    dist, _ = cKDTree(pts).query(pts, 2)
    assert dist[:, 1].min() >= 0.5 * DX * (1 - 1e-9)


@pytest.mark.parametrize("name", sorted(BLOCKS))
def test_layer_covers_the_shrunk_surface(name):
    """No hole: every point of the dx/2-deep surface is within sqrt(3)/2 dx of a particle (an
    aligned cubic lattice gives sqrt(2)/2), and the outer layer holds about one particle per dx^2
    of that surface (+-30 %: the edges are sampled twice as densely as a face's interior)."""
    poly = BLOCKS[name]
    pts = sample_block_particles(poly, DX, 3)
    surf, area = _shrunk_surface(poly, 0.5 * DX)
    gap = cKDTree(pts).query(surf)[0].max()
    assert gap <= 0.5 * np.sqrt(3.0) * DX, gap / DX
    outer = np.sum(np.abs(_depth(pts, poly) - 0.5 * DX) < 1e-9)
    assert 0.7 < outer * DX**2 / area < 1.3, outer * DX**2 / area


def test_acute_edge_is_covered(monkeypatch):
    """The wedge's 25 deg edge: the dx/2-deep layers end dx / (2 sin 12.5 deg) = 2.3 dx before it.
    With the cover, every point of the block's dx/2-thick skin is within sqrt(3)/2 dx of a particle
    up to the candidates' resolution (the cover tests a dx/4 lattice: + sqrt(3)/8 dx); without it
    (the same layers), the skin at the edge is more than 2 dx from every particle."""
    import rockjax.scenes.block_sampling as bs

    poly = BLOCKS["wedge_25deg"]
    n, d = _faces(poly)
    lo, hi = np.min(poly.vertices, 0), np.max(poly.vertices, 0)
    g = np.random.default_rng(1).uniform(lo, hi, size=(400000, 3))
    depth = _depth(g, poly)
    skin = g[(depth >= 0) & (depth <= 0.5 * DX)]
    gap = cKDTree(sample_block_particles(poly, DX, 3)).query(skin)[0].max()
    assert gap <= (0.5 + 0.125) * np.sqrt(3.0) * DX, gap / DX
    monkeypatch.setattr(bs, "_acute_cover", lambda *a: np.zeros((0, 3)))
    gap_without = cKDTree(sample_block_particles(poly, DX, 3)).query(skin)[0].max()
    assert gap_without > 2.0 * DX, gap_without / DX


def test_box_gets_the_aligned_cubic_lattice():
    """A box whose sides are whole multiples of dx: the cell-centred cubic lattice, 2 layers of an
    8 x 6 x 6 dx box = all 288 cells but the 4 x 2 x 2 core = 272 points, each with its cell's
    volume dx^3 (its share of the 2 dx thick shell)."""
    poly = box(8 * DX, 6 * DX, 6 * DX)
    pts, vol = sample_block_particles(poly, DX, 2, volumes=True)
    cells = np.stack(np.meshgrid(*[(np.arange(m) + 0.5 - m / 2) * DX for m in (8, 6, 6)], indexing="ij"),
                     -1).reshape(-1, 3)
    cells = cells[_depth(cells, poly) < 2 * DX]
    assert len(pts) == len(cells) == 272
    dist = cKDTree(cells).query(pts)[0]
    assert dist.max() < 1e-12
    np.testing.assert_allclose(vol, DX**3, rtol=1e-9)


def _wendland_c2(r, h):
    q = r / h
    return np.where(q < 2, 21.0 / (16.0 * np.pi * h**3) * (1 - q / 2) ** 4 * (2 * q + 1), 0.0)


@pytest.mark.parametrize("name", ["wedge_25deg", "hull_0"])
def test_volumes_give_the_solid_kernel_sum(name):
    """What the fluid feels of a wall is its kernel sum sum_j V_j W(x - x_j); for the block's
    particles it should be the integral of W over the solid, int_block W(x - y) dy. At 400 points
    on the faces (h = 1.3 dx; the integral by Monte Carlo, 1e6 points): the particles with their
    volumes (each its nearest-particle share of the 3 dx shell; they sum to the shell's volume)
    within 10 % rms and 25 % at worst (a clipped cubic lattice with dx^3 each, or these particles
    with dx^3 each, over-dense at edges and corners, fail that)."""
    poly = BLOCKS[name]
    n, d = _faces(poly)
    h = 1.3 * DX
    pts, vol = sample_block_particles(poly, DX, 3, volumes=True)
    lo, hi = np.min(poly.vertices, 0), np.max(poly.vertices, 0)
    rng = np.random.default_rng(2)
    g = rng.uniform(lo, hi, size=(1_000_000, 3))
    dg = _depth(g, poly)
    cell = np.prod(hi - lo) / len(g)
    assert vol.sum() == pytest.approx(np.sum((dg >= 0) & (dg < 3 * DX)) * cell, rel=0.01)
    g = g[dg >= 0]
    c, _ = inscribed_sphere(n, d)
    u = rng.normal(size=(400, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    nu = u @ n.T
    t = np.where(nu > 1e-12, (d - n @ c)[None] / np.where(nu > 1e-12, nu, 1.0), np.inf).min(1)
    surf = c + t[:, None] * u  # on the faces
    tree = cKDTree(g)
    solid = np.array([_wendland_c2(np.linalg.norm(g[tree.query_ball_point(p, 2 * h)] - p, axis=1), h).sum() * cell
                      for p in surf])
    sums = np.array([(_wendland_c2(np.linalg.norm(pts - p, axis=1), h) * vol).sum() for p in surf])
    err = sums / solid - 1.0
    print(f"{name}: kernel sum vs solid: rms {np.sqrt(np.mean(err**2)):.3f}, worst {np.abs(err).max():.3f}")
    assert np.sqrt(np.mean(err**2)) < 0.10
    assert np.abs(err).max() < 0.25


def test_too_thin_block_refused():
    with pytest.raises(ValueError, match="dx"):
        sample_block_particles(box(0.1, 0.1, 0.9 * DX), DX, 3)
