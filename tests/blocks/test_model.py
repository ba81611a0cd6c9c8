"""Host builder validation, helpers, prescribed / fixed motion, broad phase, and a stack at rest."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.blocks as rb
from rockjax.blocks import Broadphase, Motion, box, make_blocks, slab, slope
from rockjax.blocks.broadphase import candidate_pairs
from rockjax.types import Status

from rollouts import run


def test_slab_and_slope_helpers():
    s = slab(4.0, 2.0, 0.5)
    np.testing.assert_allclose(s.centroid_world, [0, 0, -0.25])
    assert s.volume == pytest.approx(4.0)
    p = slope(4.0, 2.0, 0.5, 30.0)
    top = np.argmax(p.face_normal @ [0, 0, 1])
    np.testing.assert_allclose(p.face_normal[top], [0.5, 0, np.sqrt(3) / 2], atol=1e-12)
    # the top face passes through the input origin
    assert p.face_offset[top] + p.face_normal[top] @ p.centroid_world == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="angle_deg"):
        slope(1, 1, 1, 95.0)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(positions=np.zeros((3, 3))), "positions"),
        (dict(density=-1.0), "density"),
        (dict(friction_angle_deg=90.0), "friction_angle_deg"),
        (dict(tensile_strength=1.0), "tensile_strength"),
        (dict(normal_stiffness=0.0), "normal_stiffness"),
        (dict(damping_ratio=-0.1), "damping_ratio"),
        (dict(orientations=np.zeros((2, 4))), "orientations"),
        (dict(motion=[Motion.DYNAMIC]), "motion"),
        (dict(motion=[Motion.PRESCRIBED, Motion.DYNAMIC]), "prescribed_direction"),
        (dict(motion=[Motion.FIXED, Motion.DYNAMIC], velocities=np.ones((2, 3))), "velocities"),
        (dict(period=0.0), "period"),
        (dict(prescribed_ramp=-1.0), "prescribed_ramp"),
        (dict(fcp_iterations=-1), "fcp_iterations"),
    ],
)
def test_make_blocks_rejects_bad_input(kw, match):
    apart = dict(positions=np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))  # not refused for overlapping
    with pytest.raises(ValueError, match=match):
        make_blocks([box(1, 1, 1), box(1, 1, 1)], **dict(apart, **kw))


def test_defaults_and_stable_dt():
    cfg, par, st = make_blocks([slab(4, 4, 0.5), box(1, 1, 1)], motion=[Motion.FIXED, Motion.DYNAMIC],
                               positions=np.array([[0, 0, -0.25], [0, 0, 0.5]]))
    L = 2 * np.sqrt(3) / 2  # median size of the dynamic blocks: 2 x bounding radius
    assert float(par.normal_stiffness) == pytest.approx(1e9 * L, rel=1e-6)
    assert float(par.shear_stiffness) == pytest.approx(0.4e9 * L, rel=1e-6)
    # seed Eq 8 bound, by hand: omega^2 = 2V k (1/m + r^2/I_min), dt = 0.5 * 2/omega * (sqrt(1+z^2) - z)
    m = 2650.0
    I = m / 6
    w = np.sqrt(16 * 1e9 * L * (1 / m + 0.75 / I))
    z = 0.2
    assert rb.stable_dt(cfg, par, st) == pytest.approx(0.5 * 2 / w * (np.sqrt(1 + z * z) - z), rel=1e-5)
    Xw = rb.world_vertices(st)
    assert Xw.shape == (2, 8, 3)
    n, d = rb.world_planes(st)
    assert np.all(np.asarray(jnp.einsum("bfi,bvi->bfv", n, Xw) - d[..., None]) <= 1e-5)


def test_prescribed_piston_and_fixed_block():
    cfg, par, st = make_blocks(
        [box(1, 1, 1), box(0.2, 1, 1), box(1, 1, 1)], positions=np.array([[0, 0, 5.0], [3, 0, 0], [6, 0, 0]]),
        motion=[Motion.FIXED, Motion.PRESCRIBED, Motion.DYNAMIC], prescribed_direction=np.array([[0, 0, 0],
                                                                                                 [1, 0, 0], [0, 0, 0]]),
        stroke=0.2, period=2.0, aabb_margin=0.01, grid_cell_size=1.0)
    dt, n = 1e-3, 1000
    s, x, q, v, stat = run(cfg, st, par, dt=dt, n_steps=n, every=100)
    t = dt * 100 * np.arange(1, 11)
    # float32 time t += dt: 1000 roundings <= ulp(1)/2 = 6e-8 s each -> <= 6e-5 s, times the
    # peak speed 0.31 m/s -> 1.9e-5 m (measured 2.9e-6 m)
    np.testing.assert_allclose(x[:, 1, 0], 3 + 0.1 * np.sin(np.pi * t), atol=2e-5)
    np.testing.assert_allclose(v[:, 1, 0], 0.1 * np.pi * np.cos(np.pi * (t - dt / 2)), atol=2e-5 * np.pi)
    np.testing.assert_allclose(x[:, 0], np.broadcast_to([0, 0, 5.0], x[:, 0].shape))  # fixed, in the air


def test_grid_broadphase_matches_all_pairs_and_flags_overflow():
    rng = np.random.default_rng(0)
    n = 40
    pos = rng.uniform(0, 2.0, size=(n, 3))
    polys = [box(*rng.uniform(0.15, 0.3, 3)) for _ in range(n)] + [slab(5, 5, 0.3)]
    pos = np.concatenate([pos, [[1.0, 1.0, -0.15]]])
    motion = [Motion.DYNAMIC] * n + [Motion.FIXED]
    kw = dict(positions=pos, motion=motion, check_overlap=False)  # random boxes, some overlapping: pairs to find
    c_all, _, s_all = make_blocks(polys, broadphase=Broadphase.ALL_PAIRS, **kw)
    c_grid, _, s_grid = make_blocks(polys, broadphase=Broadphase.GRID, pair_capacity=400, **kw)
    assert c_grid.large_blocks == (n,)
    Xw = rb.world_vertices(s_all)
    p1, m1, st1 = candidate_pairs(c_all, Xw, s_all.shape.vertex_mask)
    c_grid = c_grid.replace(aabb_margin=c_all.aabb_margin)
    p2, m2, st2 = candidate_pairs(c_grid, Xw, s_all.shape.vertex_mask)
    set1 = {tuple(p) for p in np.asarray(p1)[np.asarray(m1)]}
    set2 = {tuple(p) for p in np.asarray(p2)[np.asarray(m2)]}
    assert int(st1) == 0 and int(st2) == 0
    assert len(set1) > 10 and set1 == set2
    small = c_grid.grown(pairs=len(set1) - 1)
    _, _, st3 = candidate_pairs(small, Xw, s_all.shape.vertex_mask)
    assert int(st3) == Status.CONTACT_OVERFLOW
    # a grid cell holding more blocks than its capacity: its own bit, which the driver cures by
    # doubling grid_cell_capacity (not the pair buffer)
    from rockjax.driver import _grow
    from rockjax.types import Config

    crowded = c_grid.grown(cell_blocks=1).replace(grid_cell_size=1.0)
    _, _, st4 = candidate_pairs(crowded, Xw, s_all.shape.vertex_mask)
    assert int(st4) & Status.BLOCK_CELL_OVERFLOW and Status.BLOCK_CELL_OVERFLOW & Status.growable()
    grown, _ = _grow(Config(n_fluid=0, n_wall=0, dt=1e-4, grid=None, cutoff=0.0, skin=0.0, blocks=crowded), 8, None,
                     int(st4))
    assert grown.blocks.grid_cell_capacity == 2



def test_block_capacities_and_tuning_apart_from_physics():
    """The buffer sizes (``BlockCapacities``) and speed settings (``BlockTuning``) are objects of
    their own on ``BlockConfig``, read under their old names and changed by ``grown`` / ``tuned``
    (physics fields untouched); a bad value is refused naming the field."""
    cfg, _, _ = make_blocks([slab(4, 4, 0.5), box(1, 1, 1)], motion=[Motion.FIXED, Motion.DYNAMIC],
                            positions=np.array([[0, 0, -0.25], [0, 0, 0.5]]), pair_segment=4, law_slots=16)
    assert isinstance(cfg.capacities, rb.BlockCapacities) and isinstance(cfg.tuning, rb.BlockTuning)
    assert cfg.pair_capacity == cfg.capacities.pairs == 1 and cfg.law_slots == 16 and cfg.pair_segment == 4
    assert cfg.grid_cell_capacity == cfg.capacities.cell_blocks == 32 and cfg.skip_separated
    big = cfg.grown(pairs=8, law_slots=32)
    assert (big.pair_capacity, big.law_slots, big.crossing_edges) == (8, 32, cfg.crossing_edges)
    assert big.tuning == cfg.tuning and big.replace(capacities=cfg.capacities) == cfg
    fast = cfg.tuned(pair_segment=0, skip_separated=False)
    assert (fast.pair_segment, fast.skip_separated, fast.capacities) == (0, False, cfg.capacities)
    assert hash(cfg.grown(pairs=1)) == hash(cfg)  # static jit argument: equal configs hash alike
    with pytest.raises(AttributeError):
        cfg.pair_capacity = 4  # read-only: grow it with grown(pairs=...)
    for bad, field in ((dict(pairs=0), "BlockCapacities.pairs"), (dict(joint_patch_points=2), "joint_patch_points"),
                       (dict(law_slots=-1), "law_slots"), (dict(cell_blocks=1.5), "cell_blocks"),
                       (dict(fcp_crosses=True), "fcp_crosses")):
        with pytest.raises(ValueError, match=field):
            cfg.grown(**bad)
    with pytest.raises(ValueError, match="BlockTuning.pair_segment"):
        cfg.tuned(pair_segment=-1)
    with pytest.raises(ValueError, match="skip_separated"):
        rb.BlockTuning(skip_separated="yes")
    with pytest.raises(ValueError, match="BlockConfig.capacities"):
        cfg.replace(capacities=None)
    with pytest.raises(TypeError):
        cfg.grown(pair_capacity=8)  # the fields are BlockCapacities' (pairs, cell_blocks, ...)

def test_auto_pair_segment_and_shape_tables():
    """``pair_segment`` None (the default) resolves from the pair buffer and the blocks' edge
    directions: boxes (3 directions, the complete FCP start) the buffer in 8 segments, a multiple
    of 16 slots; rocks (many directions) 16 slots, 32 from a buffer of 256 slots; a set value is kept. The shape-only tables
    built once by ``make_blocks`` equal what the step used to build each time: the vertex ->
    edge-direction table (``fcp.vertex_directions``), the inverse inertia and its least principal
    moment."""
    from rockjax.blocks.fcp import vertex_directions
    assert [rb.auto_pair_segment(p, simple=True) for p in (55, 128, 129, 901, 9001)] == [16, 16, 32, 128, 1136]
    assert [rb.auto_pair_segment(p, simple=False) for p in (55, 255, 256, 9001)] == [16, 16, 32, 32]
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(12, 3))
    rock = rb.ConvexPolyhedron.from_vertices(0.1 * pts / np.linalg.norm(pts, axis=1, keepdims=True))
    for polys, seg in (([slab(4, 4, 0.5), box(1, 1, 1), box(0.5, 1, 2)], 16),
                       ([slab(4, 4, 0.5), rock, rock], 16)):
        cfg, _, st = make_blocks(polys, motion=[Motion.FIXED, Motion.DYNAMIC, Motion.DYNAMIC],
                                 positions=np.array([[0, 0, -0.25], [0, 0, 1.0], [0, 0, 3.0]]), pair_capacity=300)
        simple = len(polys[1].vertices) == 8
        assert cfg.tuning.pair_segment is None and cfg.pair_segment == (48 if simple else 32)
        assert cfg.tuned(pair_segment=seg).pair_segment == seg
        sh = st.shape
        ref = [np.asarray(vertex_directions(sh.edges[b], sh.edge_mask[b], sh.vertex_mask.shape[1], sh.edge_direction[b],
                                            sh.direction_edge.shape[1])) for b in range(3)]
        assert np.array_equal(np.asarray(sh.vertex_direction), np.stack(ref))
        I = np.asarray(sh.inertia_unit, np.float64)
        np.testing.assert_allclose(np.asarray(sh.inertia_unit_inverse) @ I, np.broadcast_to(np.eye(3), I.shape),
                                   atol=1e-5)
        np.testing.assert_allclose(sh.inertia_unit_min, np.linalg.eigvalsh(I)[:, 0], rtol=1e-5)


@pytest.mark.slow
def test_stack_of_five_at_rest():
    """5 cubes (0.2 m) stacked on a fixed floor stay put for 5 s: every block within 1 mm of its
    start (touching, no overlap: this includes the settlement, ~ 0.05 mm at k_n = 1e7 N/m), and
    the floor carries 5 m g (file section (d)) within 1 %."""
    k = 1e7
    polys = [slab(2, 2, 0.3)] + [box(0.2, 0.2, 0.2) for _ in range(5)]
    pos = np.array([[0, 0, -0.15]] + [[0, 0, 0.1 + 0.2 * i] for i in range(5)])
    cfg, par, st = make_blocks(polys, positions=pos, motion=[Motion.FIXED] + [Motion.DYNAMIC] * 5,
                               normal_stiffness=k, shear_stiffness=k, damping_ratio=0.2)
    dt = rb.stable_dt(cfg, par, st)
    n = int(np.ceil(5.0 / dt / 1000)) * 1000
    s, x, q, v, stat = run(cfg, st, par, dt=dt, n_steps=n, every=100)
    assert stat == 0, Status.describe(stat)
    drift = np.max(np.linalg.norm(x[:, 1:] - pos[None, 1:], axis=-1))
    print("stack drift (m):", drift, "steps", n, "dt", dt)
    assert drift < 1e-3, drift
    f, _, _, _ = rb.contact_forces(s, par, cfg, dt=dt)
    m = 2650 * 0.008
    assert float(f[0, 2]) == pytest.approx(-5 * m * 9.81, rel=1e-2)


def test_prescribed_ramp_soft_start(x64):
    # x(t) = x0 + d S/2 r(t) sin(w t), r a half-cosine ramp over `ramp` seconds: the piston starts
    # at rest with zero velocity, v is the exact derivative of x, and after the ramp the motion
    # is the plain sine
    S, T, ramp = 0.1, 0.8, 1.0
    kw = dict(motion=[Motion.PRESCRIBED], stroke=S, period=T, prescribed_direction=[(1.0, 0.0, 0.0)])
    cfg, par, st = make_blocks([box(1, 1, 1)], prescribed_ramp=ramp, **kw)
    cfg0, par0, _ = make_blocks([box(1, 1, 1)], **kw)
    assert cfg.prescribed_ramp == ramp and cfg0.prescribed_ramp == 0.0
    x0 = st.x0
    x, v = rb.prescribed_motion(cfg, par, x0, 0.0)
    np.testing.assert_allclose(np.asarray(x - x0), 0.0, atol=1e-15)
    np.testing.assert_allclose(np.asarray(v), 0.0, atol=1e-15)  # no velocity jump at t = 0
    _, v_hard = rb.prescribed_motion(cfg0, par0, x0, 0.0)
    assert float(v_hard[0, 0]) == pytest.approx(0.5 * S * 2 * np.pi / T)  # the impulsive start
    eps = 1e-6
    for t in (0.1, 0.37, 0.5, 0.93, ramp, 1.4, 2.3):
        xp, _ = rb.prescribed_motion(cfg, par, x0, t + eps)
        xm, _ = rb.prescribed_motion(cfg, par, x0, t - eps)
        _, vt = rb.prescribed_motion(cfg, par, x0, t)
        # central FD error: O(eps^2) where x is smooth, O(eps) across the ramp's end (x is C1 there)
        np.testing.assert_allclose(np.asarray(vt), np.asarray((xp - xm) / (2 * eps)), atol=1e-6 * 0.5 * S * 2 * np.pi / T)
        if t >= ramp:
            xr, vr = rb.prescribed_motion(cfg0, par0, x0, t)
            xt, _ = rb.prescribed_motion(cfg, par, x0, t)
            np.testing.assert_allclose(np.asarray(xt), np.asarray(xr), atol=1e-15)
            np.testing.assert_allclose(np.asarray(vt), np.asarray(vr), atol=1e-12)
    # half way through the ramp the amplitude is half the stroke's
    xh, _ = rb.prescribed_motion(cfg, par, x0, 0.5 * ramp)
    expect = 0.5 * (0.5 * S) * np.sin(2 * np.pi * 0.5 * ramp / T)
    assert float(xh[0, 0] - x0[0, 0]) == pytest.approx(expect, rel=1e-12)


def test_piston_wavemaker_ramp_option():
    import rockjax as rj

    scene = rj.scenes.piston_wavemaker(dx=0.1, period=0.8, ramp_periods=2.5)
    assert scene.config.blocks.prescribed_ramp == pytest.approx(2.0)
    assert rj.scenes.piston_wavemaker(dx=0.1).config.blocks.prescribed_ramp == 0.0
    with pytest.raises(ValueError, match="ramp_periods"):
        rj.scenes.piston_wavemaker(dx=0.1, ramp_periods=-1.0)


def test_make_blocks_parts_compose_to_make_blocks():
    """``make_blocks`` is ``block_geometry`` + ``BlockMaterial`` + the contact fields +
    ``block_capacities`` / ``block_tuning`` + ``block_config``: the parts give the same objects."""
    polys = [slab(4, 4, 0.5), box(1, 1, 1)]
    kw = dict(motion=[Motion.FIXED, Motion.DYNAMIC], positions=np.array([[0, 0, -0.25], [0, 0, 0.5]]))
    cfg, par, _ = make_blocks(polys, friction_angle_deg=25.0, pair_segment=8, **kw)
    geo = rb.block_geometry(polys, **kw)
    assert geo.n_blocks == 2 and geo.n_static_pairs == 1
    par2 = rb.BlockMaterial(friction_angle_deg=25.0).params(geo)
    for a, b in zip(np.asarray(list(par.__dict__.values()), dtype=object), par2.__dict__.values()):
        assert np.array_equal(np.asarray(a), np.asarray(b))
    caps = rb.block_capacities(geo, pair_capacity=None, support_edges=cfg.support_edges)
    assert caps == cfg.capacities and rb.block_tuning(pair_segment=8) == cfg.tuning
    with pytest.raises(ValueError, match="friction_angle_deg"):
        rb.BlockMaterial(friction_angle_deg=90.0)
    with pytest.raises(ValueError, match="density"):
        rb.BlockMaterial(density=[1.0, 2.0, 3.0]).params(geo)


def test_initial_overlaps_sweep_matches_every_pair():
    """``initial_overlaps`` tests only the pairs whose boxes overlap (a sweep along x): the same
    overlapping pairs and depths as testing every pair, on 60 rotated boxes packed tightly enough
    that about a third of them overlap."""
    from rockjax.blocks.geometry import overlap_depth, quat_to_matrix
    rng = np.random.default_rng(5)
    polys = [box(*rng.uniform(0.1, 0.3, 3)) for _ in range(60)]
    pos = rng.uniform(0.0, 1.2, (60, 3))
    q = rng.normal(size=(60, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    motion = [Motion.FIXED if k % 7 == 0 else Motion.DYNAMIC for k in range(60)]
    got = rb.initial_overlaps(polys, pos, q, motion)
    ref = []
    for i in range(60):
        for j in range(i + 1, 60):
            if motion[i] == motion[j] == Motion.FIXED:
                continue
            d = overlap_depth(polys[i], pos[i], quat_to_matrix(q[i]), polys[j], pos[j], quat_to_matrix(q[j]))
            if d > 0:
                ref.append((i, j, d))
    assert 10 < len(ref) and sorted(got) == sorted(ref)
    assert rb.initial_overlaps([], []) == [] and rb.initial_overlaps(polys[:1], pos[:1]) == []
