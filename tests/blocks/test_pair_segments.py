"""The narrow phase in segments (``BlockConfig.pair_segment``), the contact law over the gathered
active slots (``BlockConfig.law_slots``) and the crossings among the selected edges
(``BlockConfig.crossing_edges``) give what one pass over every slot and every edge gives.

``contact_forces`` evaluates FCP, the contact points and the contact law over the pair buffer in
segments of ``pair_segment`` slots and skips (``lax.cond``) a segment holding no overlapping pair;
within a segment the law runs over each pair's active contact points gathered into ``law_slots``
slots (their shear history kept per law slot with its contact feature). None may change anything:
the forces, the contact history (per contact feature), a rollout, its gradient and its ``vmap`` are
compared with the evaluation over every pair slot, every contact slot and the crossings of every
edge pair (``pair_segment=0, law_slots=0, crossing_edges=0``) in
float64, on a scene whose buffer has both empty and occupied segments (two stacks of boxes far
apart, sliding on each other, with joint water so that its patch path is segmented too), in
segments of 4 pairs (one level) and of 1 pair (21 segments: skipped in two levels, groups of
segments). A pair
with more active points than ``law_slots`` sets ``CONTACT_POINT_OVERFLOW``, never silently dropped.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.blocks as rb
from rockjax.blocks import Motion, box, make_blocks, slab
from rockjax.types import Status

from rollouts import assert_same_loads, grown_by_driver

SEG = 4
GRAV = (0.0, 0.0, -9.81)  # m/s^2; an array is made under float64 (a float32 g sits the stacks on a stick/slip knife edge)


def _scene(seg=SEG):
    polys, pos = [slab(3.0, 1.0, 0.2)], [[0.0, 0.0, -0.1]]
    for x0 in (-1.0, 1.0):  # two stacks of 3 boxes, 2 m apart: most pairs never overlap
        for k in range(3):
            polys.append(box(0.2, 0.2, 0.1))
            pos.append([x0 + 0.003 * k, 0.0, 0.05 + 0.1 * k - 1e-4 * (k + 1)])
    vel = [[0.0, 0.0, 0.0]] + [[0.1 * (k % 3), 0.0, 0.0] for k in range(6)]  # the boxes slide on each other
    cfg, par, st = make_blocks(polys, positions=np.asarray(pos), motion=[Motion.FIXED] + [Motion.DYNAMIC] * 6,
                               velocities=np.asarray(vel),
                               normal_stiffness=1e7, joint_water=True, joint_water_level=0.5,
                               joint_aperture=2e-3, pair_segment=seg)
    return cfg, par, st


@pytest.fixture(scope="module", params=[SEG, 1], ids=["segments", "groups"])
def scene(x64, request):
    return _scene(request.param)


def _rollout(cfg, n_steps, dt):
    def run(par, st):
        def body(s, _):
            s, stat = rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=jnp.asarray(GRAV))
            return s, stat

        s, stat = jax.lax.scan(body, st, None, length=n_steps)
        return s, jnp.bitwise_or.reduce(stat)

    return run


def _one_pass(cfg):
    return cfg.tuned(pair_segment=0).grown(law_slots=0, crossing_edges=0)


def _by_feature(history):
    """{(pair slot, contact feature): shear [3]} of the live pairs' active law slots."""
    live = np.asarray(history.pair_mask)
    feat, shear = np.asarray(history.contact_feature), np.asarray(history.shear)
    return {(int(p), int(feat[p, k])): shear[p, k] for p in np.flatnonzero(live) for k in np.flatnonzero(feat[p] >= 0)}


def _assert_same_history(h_a, h_b):
    a, b = _by_feature(h_a), _by_feature(h_b)
    assert a.keys() == b.keys() and len(a) > 0
    np.testing.assert_allclose(np.array([a[k] for k in a]), np.array([b[k] for k in a]), rtol=0, atol=1e-12)


def test_segments_skip_and_match_one_pass(scene):
    cfg, par, st = scene
    one = _one_pass(cfg)
    assert cfg.crossing_slots < one.crossing_slots == cfg.max_edges  # crossings among selected edges
    g = jnp.asarray(GRAV)
    seg_out = jax.jit(lambda s: rb.contact_forces(s, par, cfg, dt=1e-4, gravity=g, return_info=True))(st)
    one_out = jax.jit(lambda s: rb.contact_forces(s, par, one, dt=1e-4, gravity=g, return_info=True))(
        rb.fit_history(one, st))
    live = np.asarray(seg_out[4]["pair_mask"])
    P, seg = live.size, cfg.pair_segment
    per_seg = np.pad(live, (0, -P % seg)).reshape(-1, seg).any(1)
    assert per_seg.any() and not per_seg.all(), per_seg  # the scene really has skipped segments
    if seg == 1:  # two levels: groups of ceil(sqrt(21)) = 5 segments; the evaluated pairs are
        # gathered to the front, so the groups past them are skipped whole
        from rockjax.blocks.contact import SEGMENT_GROUPS_FROM
        assert per_seg.size >= SEGMENT_GROUPS_FROM
        n_eval = int(np.sum(np.asarray(seg_out[4]["evaluated"])))
        assert 0 < -(-n_eval // 5) < 5, n_eval
    assert int(seg_out[4]["n_contacts"]) > 0
    assert 0 < cfg.law_slots < cfg.contact_slots  # the law really runs over gathered slots
    for a, b in zip(seg_out[:2], one_out[:2]):  # forces, torques
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-12)
    h_seg, h_one = seg_out[2], one_out[2]  # the history of the live pairs (a skipped pair's is unused)
    assert np.array_equal(np.asarray(h_seg.pair_mask), live) and np.array_equal(np.asarray(h_one.pair_mask), live)
    np.testing.assert_allclose(np.asarray(h_seg.plane)[live], np.asarray(h_one.plane)[live], rtol=0, atol=1e-12)
    _assert_same_history(h_seg, h_one)
    assert int(seg_out[3]) == int(one_out[3])
    np.testing.assert_allclose(np.asarray(seg_out[4]["joint_water_force"]), np.asarray(one_out[4]["joint_water_force"]),
                               rtol=1e-12, atol=1e-12)
    # the contact points per feature (the two layouts differ in their crossing slots)
    for out in (seg_out, one_out):
        assert np.all(np.asarray(out[4]["feature"])[np.asarray(out[4]["active"])] >= 0)
    pts = [{(int(p), int(f)): (d, fn, ft) for p in np.flatnonzero(live)
            for f, a, d, fn, ft in zip(*(np.asarray(o[4][k])[p] for k in ("feature", "active", "depth", "normal_force",
                                                                          "tangential_force"))) if a}
           for o in (seg_out, one_out)]
    assert pts[0].keys() == pts[1].keys()
    for k in pts[0]:
        for a, b in zip(pts[0][k], pts[1][k]):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


@pytest.mark.slow  # ~60 s of compiles (two rollouts, two gradients, a vmap): the slow suite, run in CI
def test_segmented_rollout_grad_and_vmap(scene):
    cfg, par, st = scene
    if cfg.pair_segment != 1:
        pytest.skip("the two-level scene covers the segments (one compile budget for the slow suite)")
    one = _one_pass(cfg)
    dt = 0.5 * float(rb.stable_dt(cfg, par, st))
    n = 60

    def loss(c):
        run = _rollout(c, n, dt)

        def f(density, friction):
            p = dataclasses.replace(par, density=density, friction_angle=friction)
            s, _ = run(p, rb.fit_history(c, st))
            return jnp.sum(s.x[1:, 0]) + jnp.sum(s.x[1:, 2])

        return f

    args = (par.density, par.friction_angle)
    s_seg, stat_seg = jax.jit(_rollout(cfg, n, dt))(par, st)
    with pytest.raises(ValueError, match="fit_history"):  # the state's history is shaped for cfg
        jax.jit(_rollout(one, n, dt))(par, st)
    st_one = rb.fit_history(one, st)
    s_one, stat_one = jax.jit(_rollout(one, n, dt))(par, st_one)
    assert int(stat_seg) == int(stat_one) == 0
    np.testing.assert_allclose(np.asarray(s_seg.x), np.asarray(s_one.x), rtol=0, atol=1e-12)
    _assert_same_history(s_seg.history, s_one.history)
    g_seg = jax.jit(jax.grad(loss(cfg), argnums=(0, 1)))(*args)
    g_one = jax.jit(jax.grad(loss(one), argnums=(0, 1)))(*args)
    assert float(jnp.abs(g_one[1])) > 0  # friction matters over this horizon
    # the law over gathered slots sums in another order, and this stick-slip rollout's gradient
    # moves with round-off: shifting the initial x by 1e-15 m moves d/d(friction) by up to a few
    # 1e-6 of itself, depending on the compiled program: the bound is that sensitivity, not a
    # property of either path
    for a, b in zip(jax.tree.leaves(g_seg), jax.tree.leaves(g_one)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-5, atol=1e-14)
    # a batch of two friction angles through the segmented path (the cond becomes a select)
    fr = jnp.stack([par.friction_angle, 0.8 * par.friction_angle])
    batched = jax.jit(jax.vmap(loss(cfg), in_axes=(None, 0)))(par.density, fr)
    each = [float(jax.jit(loss(one))(par.density, f)) for f in fr]
    np.testing.assert_allclose(np.asarray(batched), each, rtol=1e-12)


def _forces(shapes, **kw):
    """``contact_forces`` (jitted, with info) of the blocks ``make_blocks(shapes, **kw)`` makes:
    ``(F, T, history, status, info)``."""
    cfg, par, st = make_blocks(shapes, **kw)
    return jax.jit(lambda s: rb.contact_forces(s, par, cfg, dt=1e-4, return_info=True))(st)


def test_law_slots_overflow_flagged_and_grown(x64):
    """Two boxes face on face (offset: 4 corners of the small one inside the large one, and
    crossings): with 8 law slots the same loads as over all 81 slots; with 2 the pair has more
    points than slots, which sets CONTACT_POINT_OVERFLOW (a growable bit), and the driver's
    ``_grow`` doubles the slots."""
    from rockjax.types import Status

    pos = np.array([[0.0, 0.0, 0.15], [0.1, 0.15, 0.4 - 1e-4]])
    kw = dict(positions=pos, motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6)
    shapes = [box(0.3, 0.3, 0.3), box(0.2, 0.2, 0.2)]
    out = {}
    for k in (0, 8, 2):
        F, T, _, status, info = _forces(shapes, law_slots=k, **kw)
        out[k] = (np.asarray(F), np.asarray(T), int(status), int(np.asarray(info["active"]).sum()))
    assert out[0][2] == 0 and out[8][2] == 0
    assert 2 < out[0][3] <= 8, out[0][3]
    assert_same_loads(out[8], out[0])
    assert out[2][2] & Status.CONTACT_POINT_OVERFLOW
    assert Status.CONTACT_POINT_OVERFLOW & Status.growable()
    cfg2, _, _ = make_blocks(shapes, law_slots=2, **kw)
    assert grown_by_driver(cfg2, Status.CONTACT_POINT_OVERFLOW).law_slots == 4
    with pytest.raises(ValueError, match="law_slots"):
        make_blocks(shapes, law_slots=-1, **kw)


def test_crossing_edges_overflow_flagged_and_grown(x64):
    """Crossed squares (a cube on a cube turned 45 deg about z: no corner inside the other, 8
    edge-edge crossings from 4 edges of each cube inside the other): with ``crossing_edges`` 4 the
    same loads, points and features as with the crossings of every edge pair (0); with 2 a cube
    has more edges inside the other than that, which sets CROSSING_EDGE_OVERFLOW (a growable bit),
    and the driver's ``_grow`` doubles it (at most ``max_edges``). The driver's ``resize`` then
    fits the shear history to grown law slots, keeping what it held."""
    from rockjax.blocks import quat_from_axis_angle
    from rockjax.types import Status

    pos = np.array([[0.0, 0.0, 0.15], [0.0, 0.0, 0.45 - 1e-4]])
    q = np.stack([[1.0, 0, 0, 0], quat_from_axis_angle((0, 0, 1), np.pi / 4)])
    kw = dict(positions=pos, orientations=q, motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6,
              velocities=np.array([[0.0, 0, 0], [0.01, 0.02, 0]]))
    shapes = [box(0.3, 0.3, 0.3), box(0.3, 0.3, 0.3)]
    out = {}
    for k in (0, 4, 2):
        F, T, h, status, info = _forces(shapes, crossing_edges=k, **kw)
        act = np.asarray(info["active"])[0]
        out[k] = (np.asarray(F), np.asarray(T), int(status), dict(zip(np.asarray(info["feature"])[0][act].tolist(),
                                                                       np.asarray(info["points"])[0][act])), h)
    assert out[0][2] == 0 and out[4][2] == 0
    assert len(out[0][3]) == 8 and all(f >= 2 * 8 for f in out[0][3])  # 8 points, all crossings
    assert out[4][3].keys() == out[0][3].keys()
    for f in out[0][3]:
        np.testing.assert_allclose(out[4][3][f], out[0][3][f], rtol=0, atol=1e-12)
    assert_same_loads(out[4], out[0])
    assert out[2][2] & Status.CROSSING_EDGE_OVERFLOW
    assert Status.CROSSING_EDGE_OVERFLOW & Status.growable()
    cfg2, _, _ = make_blocks(shapes, crossing_edges=2, **kw)
    assert grown_by_driver(cfg2, Status.CROSSING_EDGE_OVERFLOW).crossing_edges == 4
    assert grown_by_driver(cfg2.grown(crossing_edges=8),
                           Status.CROSSING_EDGE_OVERFLOW).crossing_edges == 12 == cfg2.max_edges
    with pytest.raises(ValueError, match="crossing_edges"):
        make_blocks(shapes, crossing_edges=-1, **kw)
    # the history of the 4-edge run, refitted to 64 law slots: the same springs, empty slots added
    h4 = out[4][4]
    st4 = make_blocks(shapes, crossing_edges=4, **kw)[2]
    st4 = st4.replace(history=h4)
    wide = rb.fit_history(cfg2.grown(crossing_edges=8, law_slots=64), st4)
    L = cfg2.law_slots
    wide = wide.history
    assert wide.shear.shape[1] == 64 > L
    np.testing.assert_array_equal(np.asarray(wide.shear)[:, :L], np.asarray(h4.shear))
    np.testing.assert_array_equal(np.asarray(wide.contact_feature)[:, :L], np.asarray(h4.contact_feature))
    assert np.all(np.asarray(wide.contact_feature)[:, L:] == -1) and not np.any(np.asarray(wide.shear)[:, L:])


def _rock_pair():
    """Two random rocks (12-vertex hulls, ~30 edges each, one direction per edge: the FCP rounds
    run) pressed 2 cm together: ``(shapes, make_blocks keywords)``."""
    from rockjax.blocks import quat_from_axis_angle

    from fcp_cases import place_at_gap, random_block

    rng = np.random.default_rng(4)
    shapes = [random_block(rng, 12), random_block(rng, 12)]
    q = np.stack([[1.0, 0, 0, 0], quat_from_axis_angle((0.3, 0.2, 1), 0.7)])
    pos = np.stack([np.zeros(3), place_at_gap(shapes[0], q[0], shapes[1], q[1], (0.2, -0.1, 1.0), -0.02)])
    return shapes, dict(positions=pos, orientations=q, motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6,
                        check_overlap=False)  # a pair pressed into each other: the loads to test


def _check_fcp_buffer(field, small, bit):
    """For the rock pair: ``make_blocks``' default of the FCP buffer ``field`` gives the plane,
    points, loads and the loads' gradients with respect to the poses of the full buffer (0);
    ``small`` sets the growable status ``bit``. Returns the default config."""
    shapes, kw = _rock_pair()
    out = {}
    for k in (0, None, small):
        F, T, _, status, info = _forces(shapes, **{field: k}, **kw)
        out[k] = (np.asarray(F), np.asarray(T), int(status), np.asarray(info["normal"])[0],
                  int(np.asarray(info["active"]).sum()))
    assert out[0][2] == 0 and out[None][2] == 0
    assert out[0][4] > 0  # in contact
    np.testing.assert_array_equal(out[None][3], out[0][3])
    assert_same_loads(out[None], out[0])
    assert out[small][2] & bit
    assert bit & Status.growable()
    # the gathered edges carry the same derivatives (the normal's, through the winning candidate)
    grads = {}
    for k in (0, None):
        cfg_k, par, st = make_blocks(shapes, **{field: k}, **kw)

        def load(x, q, cfg_k=cfg_k, par=par, st=st):
            F, T = rb.contact_forces(st.replace(x=x, q=q), par, cfg_k, dt=1e-4)[:2]
            return F[1] @ jnp.array([0.3, -0.2, 1.0]) + T[1] @ jnp.array([1.0, 0.5, -0.4])

        grads[k] = jax.jit(jax.grad(load, argnums=(0, 1)))(st.x, st.q)
    assert np.any(np.asarray(grads[0][1]) != 0)
    for a, b in zip(grads[None], grads[0]):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-10, atol=1e-10 * float(np.abs(b).max()))
    with pytest.raises(ValueError, match=field):
        make_blocks(shapes, **{field: -1}, **kw)
    return make_blocks(shapes, **kw)[0]


@pytest.mark.slow  # five compiles (~95 s on 2 cores); the same checks on fcp_crosses stay in the default suite
def test_support_edges_overflow_flagged_and_grown(x64):
    """Two random rocks pressed together (``_rock_pair``): ``make_blocks``' default
    ``support_edges`` (the most edge directions touching a face,
    ``ConvexPolyhedron.support_directions``) gives the plane, points and loads of rounds over
    every direction (0); 2 is fewer than any support set touches, which sets
    SUPPORT_EDGE_OVERFLOW (a growable bit), and the driver's ``_grow`` doubles it (at most
    ``max_edges``). The loads' gradients with respect to the poses agree too."""
    shapes, _ = _rock_pair()
    cfg = _check_fcp_buffer("support_edges", 2, Status.SUPPORT_EDGE_OVERFLOW)
    assert cfg.support_edges == max(p.support_directions() for p in shapes) < cfg.max_edges
    cfg2 = cfg.grown(support_edges=2)
    assert grown_by_driver(cfg2, Status.SUPPORT_EDGE_OVERFLOW).support_edges == 4
    assert grown_by_driver(cfg2.grown(support_edges=24),
                           Status.SUPPORT_EDGE_OVERFLOW).support_edges == cfg2.max_edges


def test_fcp_crosses_overflow_flagged_and_grown(x64):
    """The rock pair: ``make_blocks``' default ``fcp_crosses`` (128, fewer slots than
    ``support_edges^2``) gives the plane, points, loads and gradients of every slot (0); 4 slots
    are fewer than the crosses of two vertices' directions, which sets FCP_CROSS_OVERFLOW (a
    growable bit), and the driver's ``_grow`` doubles it (at most ``support_edges^2``)."""
    cfg = _check_fcp_buffer("fcp_crosses", 4, Status.FCP_CROSS_OVERFLOW)
    assert 0 < cfg.fcp_crosses < cfg.support_edges ** 2
    assert grown_by_driver(cfg.grown(fcp_crosses=4), Status.FCP_CROSS_OVERFLOW).fcp_crosses == 8
    assert grown_by_driver(cfg.grown(fcp_crosses=cfg.support_edges ** 2 - 8),
                           Status.FCP_CROSS_OVERFLOW).fcp_crosses == cfg.support_edges ** 2
