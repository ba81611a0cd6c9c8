"""The ``rock_slope`` scene: a rock mass cut from joint sets on a slope above a reservoir (built
here, not run: tests/physics/test_hoek_bray.py checks the failure modes on one block)."""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax.blocks import ConvexPolyhedron, Motion, initial_overlaps


def rock_polyhedra(scene, n):
    """The scene's first ``n`` blocks as placed polyhedra (from the state's padded geometry)."""
    shape, x = scene.state.blocks.shape, np.asarray(scene.state.blocks.x)
    verts, mask = np.asarray(shape.vertices), np.asarray(shape.vertex_mask)
    return [ConvexPolyhedron.from_vertices(verts[b][mask[b]] + x[b]) for b in range(n)]


@pytest.mark.parametrize("failure, regime, n_blocks, thickness",
                         [("planar", "sliding", 10 * 3 * 3, 0.12), ("toppling", "toppling", 15 * 3, 0.2)])
def test_rock_slope_builds_its_failure_mode(failure, regime, n_blocks, thickness):
    scene = rj.scenes.rock_slope(dx=0.05, failure=failure)
    cfg = scene.config.blocks
    assert scene.meta["hoek_bray_regime"] == regime
    assert scene.meta["rock_mass"]["blocks"] == n_blocks and scene.meta["rock_mass"]["dropped"] == 0
    assert cfg.n_blocks == n_blocks + 2 and cfg.motion[:n_blocks] == (Motion.DYNAMIC,) * n_blocks
    assert scene.counts()["fluid"] > 0 and len(scene.meta["gauges"].names) == 3
    assert scene.meta["runup_slope"] is not None
    polys = rock_polyhedra(scene, n_blocks)
    # the blocks tile the slab (0.6 m along the slope, 0.3 m across) and touch without overlapping
    assert sum(p.volume for p in polys) == pytest.approx(0.6 * 0.3 * thickness, rel=1e-6)
    assert all(depth < 1e-6 for _, _, depth in initial_overlaps(polys, [p.centroid_world for p in polys]))
    th = math.radians(scene.meta["slope_angle_deg"])
    n = np.array([math.sin(th), 0.0, math.cos(th)])
    lowest = min(float(np.min((p.vertices + p.centroid_world) @ n)) for p in polys)
    assert lowest == pytest.approx(1e-3, abs=1e-6)  # 1 mm above the slide plane
    # the contact stiffness stops the heaviest block, falling from the top into the reservoir,
    # within half the penetration limit of the smallest
    k = float(scene.params.blocks.normal_stiffness)
    m = float(np.asarray(scene.params.blocks.density)[0]) * max(p.volume for p in polys)
    v = math.sqrt(2 * 9.81 * (max(float(np.max((p.vertices + p.centroid_world)[:, 2])) for p in polys) + 0.1 + 0.3))
    r = min(p.bounding_radius for p in polys)
    assert v * math.sqrt(m / k) <= 0.5 * cfg.penetration_limit * r * (1 + 1e-6)


@pytest.mark.parametrize("kw, pattern", [
    (dict(failure="wedge"), "failure must be"),
    (dict(slope_angle_deg=70.0), "slope_angle_deg must be in"),
    (dict(column_spacing=0.0), "column_spacing"),
    (dict(rock_width=0.39), "rock_width"),
    (dict(block_density=1e-6), "block_density"),
    (dict(water_depth=0.32), r"water_depth = 0.32 m is not a whole number of dx = 0.05 m.*0.3 m deep"),
])
def test_rock_slope_refuses_bad_input(kw, pattern):
    with pytest.raises(ValueError, match=pattern):
        rj.scenes.rock_slope(dx=0.05, **kw)
