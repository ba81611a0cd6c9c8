"""Pairs whose stored common plane still separates them (``BlockConfig.skip_separated``) are not
evaluated, and that changes no load.

``contact_forces`` skips a candidate pair when the gap along its stored plane exceeds the margins
of ``contact.separated_pairs``: no point within the contact tolerance of one block can then lie
in the other, so the pair has no contact point and zero force. Checked here (float64):

* on a pile of random rocks closing into contact, at several states along its rollout, the loads
  with the skip equal those from evaluating every candidate pair (forces, torques, status, the
  shear history per contact feature, the planes of the evaluated pairs); a skipped pair keeps its
  stored plane; and the skip is real (pairs skipped, pairs evaluated, contacts present);
* the rule's closed form: two cubes one above the other, the stored plane their common face
  normal: skipped just above the margin sum ``2 tol r^2 / d`` (``r = a sqrt(3) / 2``, ``d = a / 2``),
  evaluated just below; with joint water, evaluated while the gap is below the joint aperture.
"""

from __future__ import annotations


import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.blocks as rb
from rockjax.blocks import ConvexPolyhedron, Motion, box, make_blocks, slab
from rockjax.blocks.contact import separated_pairs

GRAV = (0.0, 0.0, -9.81)


def _rock(rng, size=0.19, n_points=12):
    p = rng.normal(size=(n_points, 3))
    p *= rng.uniform(0.7, 1.0, (n_points, 1)) / np.linalg.norm(p, axis=1, keepdims=True)
    hull = ConvexPolyhedron.from_vertices(p)
    return ConvexPolyhedron.from_vertices(hull.vertices * (size / np.ptp(hull.vertices, axis=0).max()))


@pytest.fixture(scope="module")
def pile(x64):
    """Two columns of 3 random rocks on a floor slab, 1 mm apart, closing at 0.2-0.6 m/s."""
    rng = np.random.default_rng(3)
    polys, pos, vel = [slab(1.2, 1.0, 0.3)], [[0.1, 0.0, -0.15]], [[0.0, 0.0, 0.0]]
    for c in range(2):
        top = 0.0
        for k in range(3):
            p = _rock(rng)
            z0 = top + 1e-3
            pos.append([0.21 * c, 0.0, z0 - p.vertices[:, 2].min()])
            vel.append([0.0, 0.0, -0.2 * (k + 1)])
            top = z0 + np.ptp(p.vertices[:, 2])
            polys.append(p)
    cfg, par, st = make_blocks(polys, positions=np.asarray(pos), velocities=np.asarray(vel),
                               motion=[Motion.FIXED] + [Motion.DYNAMIC] * 6, normal_stiffness=1e7, pair_segment=4)
    assert cfg.skip_separated
    return cfg, par, st


def _by_feature(h):
    live = np.asarray(h.pair_mask)
    feat, shear = np.asarray(h.contact_feature), np.asarray(h.shear)
    return {(int(p), int(feat[p, k])): shear[p, k] for p in np.flatnonzero(live) for k in np.flatnonzero(feat[p] >= 0)}


def test_skipping_separated_pairs_changes_no_load(pile):
    cfg, par, st = pile
    every = cfg.tuned(skip_separated=False)
    dt = 0.5 * float(rb.stable_dt(cfg, par, st))
    g = jnp.asarray(GRAV)
    forces = {c.skip_separated: jax.jit(lambda s, c=c: rb.contact_forces(s, par, c, dt=dt, gravity=g,
                                                                         return_info=True)) for c in (cfg, every)}

    @jax.jit
    def advance(s):
        def body(s, _):
            s, stat = rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=g)
            return s, stat
        s, stat = jax.lax.scan(body, s, None, length=60)
        return s, jnp.bitwise_or.reduce(stat)

    skipped = evaluated = contacts = 0
    s = st
    for _ in range(6):  # states along the rollout (the skip path's own history)
        s, stat = advance(s)
        assert int(stat) == 0
        a, b = forces[True](s), forces[False](s)
        for x, y in zip(a[:2], b[:2]):  # forces, torques
            np.testing.assert_allclose(np.asarray(x), np.asarray(y), rtol=1e-12, atol=1e-9)
        assert int(a[3]) == int(b[3])
        ka, kb = _by_feature(a[2]), _by_feature(b[2])
        assert ka.keys() == kb.keys()
        for k in ka:
            np.testing.assert_allclose(ka[k], kb[k], rtol=0, atol=1e-15)
        live, ev = np.asarray(a[4]["pair_mask"]), np.asarray(a[4]["evaluated"])
        assert np.array_equal(np.asarray(b[4]["evaluated"]), live)  # the reference evaluates every pair
        assert not np.any(ev & ~live)
        sk = live & ~ev
        np.testing.assert_allclose(np.asarray(a[2].plane)[ev], np.asarray(b[2].plane)[ev], rtol=0, atol=1e-12)
        assert np.array_equal(np.asarray(a[2].plane)[sk], np.asarray(s.history.plane)[sk])  # kept
        assert np.all(np.asarray(a[4]["n_contacts"]) == np.asarray(b[4]["n_contacts"]))
        assert np.all(np.asarray(b[4]["active"])[sk] == 0)  # what the rule promises, seen by the reference
        skipped += int(sk.sum())
        evaluated += int(ev.sum())
        contacts += int(a[4]["n_contacts"])
    print(f"pairs skipped {skipped}, evaluated {evaluated}, contact points {contacts} over 6 states")
    assert skipped > 0 and evaluated > 0 and contacts > 0


def _two_cubes(gap, a=0.2, **kw):
    return make_blocks([box(a, a, a), box(a, a, a)], positions=np.array([[0.0, 0.0, 0.0], [0.0, 0.0, a + gap]]),
                       motion=[Motion.FIXED, Motion.DYNAMIC], **kw)


def test_separated_rule_closed_form(x64):
    a = 0.2
    cfg, _, st = _two_cubes(0.0, a)
    margin = 2 * cfg.inside_tolerance * (a * np.sqrt(3) / 2) ** 2 / (a / 2)  # = 3e-4 a
    for factor, expect in ((1.01, True), (0.99, False)):
        _, _, s = _two_cubes(factor * margin, a)
        sep, gap = separated_pairs(rb.world_vertices(s), s.shape.vertex_mask, s.shape, jnp.array([[0, 1]]),
                                   jnp.array([[0.0, 0.0, 1.0]]), jnp.array([True]), tol_rel=cfg.inside_tolerance)
        np.testing.assert_allclose(float(gap[0]), factor * margin, rtol=1e-9)
        assert bool(sep[0]) is expect, (factor, margin)
    sep, _ = separated_pairs(rb.world_vertices(s), s.shape.vertex_mask, s.shape, jnp.array([[0, 1]]),
                             jnp.array([[0.0, 0.0, 1.0]]), jnp.array([False]), tol_rel=cfg.inside_tolerance)
    assert not bool(sep[0])  # no stored plane: evaluated


@pytest.mark.parametrize("gap, joint_water, evaluated", [(1e-3, False, False), (1e-3, True, True), (4e-3, True, False)])
def test_joint_water_pairs_within_the_aperture_are_evaluated(x64, gap, joint_water, evaluated):
    kw = dict(joint_water=True, joint_water_level=1.0, joint_aperture=2e-3) if joint_water else {}
    cfg, par, st = _two_cubes(gap, **kw)
    run = jax.jit(lambda s: rb.contact_forces(s, par, cfg, dt=1e-4, gravity=jnp.asarray(GRAV), return_info=True))
    first = run(st)  # stores the common plane
    assert bool(first[4]["evaluated"][0])
    second = run(st.replace(history=first[2]))
    assert bool(second[4]["evaluated"][0]) is evaluated
    np.testing.assert_allclose(np.asarray(second[0]), np.asarray(first[0]), rtol=1e-12, atol=1e-12)
