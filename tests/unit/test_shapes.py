"""Wall layers of plane-bounded containers (``scenes.shapes.shell``): lattice points on faces
aligned with the lattice, face-following lattices on inclined faces (slopes, beaches)."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from rockjax.scenes.shapes import clearance, plane, shell

DX = 0.04
LAYERS = 3


def _slope_container(angle_deg=25.0):
    """A flume like ``sliding_wedge``'s: floor at z = -0.4, a slope through the origin rising to
    the left, side walls at y = 0 / 0.4, end walls; open at the top."""
    th = math.radians(angle_deg)
    n_slope = np.array([math.sin(th), 0.0, math.cos(th)])
    return [plane(-n_slope, [0, 0, 0]), plane([0, 0, -1], [0, 0, -0.4]), plane([0, -1, 0], [0, 0, 0]),
            plane([0, 1, 0], [0, 0.4, 0]), plane([1, 0, 0], [1.2, 0, 0]), plane([-1, 0, 0], [-0.6, 0, 0])]


def _box():
    pad = LAYERS * DX
    return np.array([-0.6 - pad, -pad, -0.4 - pad]), np.array([1.2 + pad, 0.4 + pad, 0.2])


def test_aligned_container_is_the_lattice():
    """A tank whose walls lie on the lattice's cell faces: the same points as the clipped lattice."""
    hs = [plane([0, 0, -1], [0, 0, -0.4]), plane([0, -1, 0], [0, 0, 0]), plane([0, 1, 0], [0, 0.4, 0]),
          plane([1, 0, 0], [1.2, 0, 0]), plane([-1, 0, 0], [-0.6, 0, 0])]
    lo, hi = _box()
    a = shell(lo, hi, DX, hs, LAYERS)
    b = shell(lo, hi, DX, hs, LAYERS, follow_faces=False)
    assert len(a) > 1000 and np.array_equal(a, b)


@pytest.fixture(scope="module")
def slope_walls():
    lo, hi = _box()
    hs = _slope_container()
    return hs, shell(lo, hi, DX, hs, LAYERS), shell(lo, hi, DX, hs, LAYERS, follow_faces=False)


def test_layers_at_half_spacings_behind_every_face(slope_walls):
    """Every wall particle lies (k + 1/2) dx behind its nearest face, k < layers: on the slope too
    (the clipped lattice's staircase does not: its first layer is anywhere 0-1 dx deep there)."""
    hs, walls, lattice_walls = slope_walls
    depth = -clearance(walls, hs) / DX - 0.5
    assert np.all(np.abs(depth - np.round(depth)) < 1e-6) and depth.min() > -1e-6 and depth.max() < LAYERS - 0.5
    old = -clearance(lattice_walls, hs) / DX - 0.5
    assert np.max(np.abs(old - np.round(old))) > 0.3


def test_spacing_and_cover_of_the_slope(slope_walls):
    """No two particles closer than dx/2; every point of the slope's dx/2-deep surface (away from
    the junctions with other walls) within sqrt(2)/2 dx of the outer layer (a square lattice's
    worst), and the slope's layers hold one particle per dx^3 there (+-5 %)."""
    hs, walls, _ = slope_walls
    d, _ = cKDTree(walls).query(walls, k=2)
    assert d[:, 1].min() >= 0.5 * DX * (1 - 1e-9)
    th = math.radians(25.0)
    n = np.array([-math.sin(th), 0.0, -math.cos(th)])  # the slope's outward normal (into the wall)
    u = np.array([0.0, 1.0, 0.0])
    s = np.array([math.cos(th), 0.0, -math.sin(th)])  # down-slope
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0.1, 0.3, 4000), rng.uniform(0.15, 0.75, 4000)  # metres across / down the slope
    probe = a[:, None] * u + b[:, None] * s + 0.5 * DX * n  # on the slope's dx/2-deep surface
    outer = walls[np.abs(clearance(walls, hs) + 0.5 * DX) < 1e-6]
    dist, _ = cKDTree(outer).query(probe)
    assert dist.max() <= math.sqrt(0.5) * DX * (1 + 1e-6), dist.max()
    # density: particles of the slope's layers in a patch 0.2 m x 0.6 m x LAYERS dx (its sides
    # between the rows, which lie at the cubic lattice's y)
    rel = walls @ np.stack([u, s, n], 1)
    patch = (rel[:, 0] > 0.12) & (rel[:, 0] < 0.32) & (rel[:, 1] > 0.15) & (rel[:, 1] < 0.75) & (rel[:, 2] > 0)
    expected = 0.2 * 0.6 * LAYERS * DX / DX**3
    assert abs(patch.sum() / expected - 1) < 0.05, (patch.sum(), expected)

