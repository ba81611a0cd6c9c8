"""The candidate-pair list is kept from step to step and rebuilt only when a block's box has moved
by more than half the AABB margin (``contact._kept_or_rebuilt``), and that changes no load.

Checked here (float64):

* on two rows of boxes sliding into each other on a floor (GRID broad phase), at states along
  the rollout with the kept list, the loads equal those after a forced rebuild of the list
  (forces, torques, status, the shear history per pair and contact feature, the planes), and the
  list really was kept over most steps and rebuilt over some;
* the rule's closed form: a box sliding without friction at speed v is rebuilt every
  ``floor(m / (2 v dt)) + 1`` steps (m the AABB margin), and a box at rest after the first step
  never.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.blocks as rb
from rockjax.blocks import Broadphase, Motion, box, make_blocks, slab

GRAV = (0.0, 0.0, -9.81)


def _rebuilt(h0, h1):
    """Whether the step from history h0 to h1 rebuilt the list (the boxes of a build renewed)."""
    return bool(np.any(np.asarray(h0.box_lo) != np.asarray(h1.box_lo)))


def _forced(s):
    """The state with its list marked stale: the next step rebuilds it (the history carried over)."""
    h = s.history
    return s.replace(history=h.replace(box_lo=jnp.full_like(h.box_lo, jnp.inf), box_hi=jnp.full_like(h.box_hi, -jnp.inf)))


def _by_pair_feature(h):
    """{(i, j, feature): shear [3]} of the live pairs' active law slots (independent of the slot order)."""
    live = np.flatnonzero(np.asarray(h.pair_mask))
    pairs, feat, shear = np.asarray(h.pairs), np.asarray(h.contact_feature), np.asarray(h.shear)
    return {(int(pairs[p, 0]), int(pairs[p, 1]), int(feat[p, k])): shear[p, k]
            for p in live for k in np.flatnonzero(feat[p] >= 0)}


@pytest.fixture(scope="module")
def rows(x64):
    """Two rows of 5 boxes (0.2 m, 2 mm apart in each row) on a floor slab, the rows 5 cm apart and
    closing at 3 m/s, tall boxes (0.4 m) in the second row: they collide after ~0.017 s."""
    polys, pos, vel = [slab(3.0, 1.0, 0.3)], [[0.0, 0.0, -0.15]], [[0.0, 0.0, 0.0]]
    for r, (x0, v, h) in enumerate(((-0.125, 1.5, 0.2), (0.125, -1.5, 0.4))):
        for k in range(5):
            polys.append(box(0.2, 0.2, h))
            pos.append([x0, (k - 2) * 0.202, 0.5 * h])
            vel.append([v, 0.0, 0.0])
    cfg, par, st = make_blocks(polys, positions=np.asarray(pos), velocities=np.asarray(vel),
                               motion=[Motion.FIXED] + [Motion.DYNAMIC] * 10, normal_stiffness=1e7,
                               friction_angle_deg=10.0, broadphase=Broadphase.GRID)
    return cfg, par, st


def test_kept_list_changes_no_load(rows):
    cfg, par, st = rows
    dt = 0.5 * float(rb.stable_dt(cfg, par, st))
    g = jnp.asarray(GRAV)
    forces = jax.jit(lambda s: rb.contact_forces(s, par, cfg, dt=dt, gravity=g))

    @jax.jit
    def advance(s):
        def body(s, _):
            s2, stat = rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=g)
            return s2, (stat, jnp.any(s2.history.box_lo != s.history.box_lo))
        s, (stat, rebuilt) = jax.lax.scan(body, s, None, length=20)
        return s, jnp.bitwise_or.reduce(stat), jnp.sum(rebuilt)

    s, rebuilds, contacts, across = st, 0, 0, 0
    for _ in range(40):  # 800 steps (0.05 s): the rows meet after ~260
        s, stat, k = advance(s)
        assert int(stat) == 0
        rebuilds += int(k)
        kept, fresh = forces(s), forces(_forced(s))
        assert not _rebuilt(s.history, kept[2]) and _rebuilt(s.history, fresh[2])  # one kept, one rebuilt
        for a, b in zip(kept[:2], fresh[:2]):  # forces, torques
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-12, atol=1e-9)
        assert int(kept[3]) == int(fresh[3]) == 0
        ka, kb = _by_pair_feature(kept[2]), _by_pair_feature(fresh[2])
        assert ka.keys() == kb.keys()
        for key in ka:
            np.testing.assert_allclose(ka[key], kb[key], rtol=0, atol=1e-15)
        contacts += len(ka)
        across += sum(1 for (i, j, _) in ka if 1 <= i <= 5 < j)  # a box of each row
    assert contacts > 0 and across > 0  # the rows collided
    # the list was rebuilt as the blocks moved, and kept over most steps
    assert 5 <= rebuilds <= 400, rebuilds


def test_rebuilds_follow_the_rule(x64):
    """A box sliding without friction at v = 0.7 m/s with dt = 1e-4 s and margin m = 0.01 m: its
    box moves 0.07 mm a step, the list is rebuilt when it has moved more than m/2 = 5 mm, so every
    floor(5 / 0.07) + 1 = 72 steps: at steps 0, 72, 144, 216, 288 of 300. At rest: at step 0 only."""
    dt, margin, v = 1e-4, 0.01, 0.7
    for speed, expected in ((v, [0, 72, 144, 216, 288]), (0.0, [0])):
        cfg, par, st = make_blocks([slab(4.0, 1.0, 0.3), box(0.2, 0.2, 0.2)],
                                   positions=np.array([[0.0, 0.0, -0.15], [-1.0, 0.0, 0.1]]),
                                   velocities=np.array([[0.0, 0.0, 0.0], [speed, 0.0, 0.0]]),
                                   motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e7,
                                   friction_angle_deg=0.0, aabb_margin=margin, broadphase=Broadphase.GRID)
        assert dt < rb.stable_dt(cfg, par, st)

        @jax.jit
        def run(s):
            def body(s, _):
                s2, stat = rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=jnp.asarray(GRAV))
                return s2, (stat, jnp.any(s2.history.box_lo != s.history.box_lo))
            return jax.lax.scan(body, s, None, length=300)

        s, (stat, rebuilt) = run(st)
        assert int(np.bitwise_or.reduce(np.asarray(stat))) == 0
        assert np.flatnonzero(np.asarray(rebuilt)).tolist() == expected
        assert abs(float(s.v[1, 0]) - speed) < 1e-6  # frictionless: the speed kept
