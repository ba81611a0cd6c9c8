"""Warm-started pairs without FCP iterations (``BlockConfig.fcp_warm_iterations``).

A pair whose plane from the previous step is stored starts the Fast Common Plane search from it;
the search's last, differentiable candidate round around that plane is then the whole search
(``fcp_warm_iterations = 0``, the default), while a segment holding a pair that starts cold runs
``fcp_iterations``. Checked here: (1) from the exact plane of a pose moved 1 % of the block size
and turned 0.01 rad, no iteration finds the minimum-penetration depth of a float64 separating-axis
test (SAT) on random overlapping polyhedra; (2) in a pile of random rocks falling into contact,
the trajectories, the contact history and a gradient are those of the run that iterates warm
pairs too, while the warm branch is taken.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax.blocks as rb
from rockjax.blocks import ConvexPolyhedron, Motion, make_blocks, quat_from_axis_angle, slab

from fcp_cases import fcp_fn, padded, place_at_gap, random_block, random_rotation, sat, support_edges_of

GRAV = (0.0, 0.0, -9.81)


def _qmul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


@pytest.mark.parametrize("seed", range(0, 40, 4))
def test_warm_plane_needs_no_iteration(seed):
    """Random overlap (1e-3 .. 0.1 L deep); the stored plane is the SAT axis of the pose one
    "step" earlier (j moved 0.01 L and turned 0.01 rad); 0 iterations give the SAT depth."""
    for k in range(4):  # four pairs per parametrised seed
        rng = np.random.default_rng(1000 * seed + k)
        pi = random_block(rng, int(rng.integers(5, 13)), rng.uniform(0.5, 2.0))
        pj = random_block(rng, int(rng.integers(5, 13)), rng.uniform(0.5, 2.0))
        qi, qj = random_rotation(rng), random_rotation(rng)
        L = min(pi.bounding_radius, pj.bounding_radius)
        xj = place_at_gap(pi, qi, pj, qj, rng.normal(size=3), -rng.uniform(1e-3, 0.1) * L)
        d = rng.normal(size=3)
        d *= 0.01 * L / np.linalg.norm(d)
        ax = rng.normal(size=3)
        q_prev = _qmul(np.asarray(quat_from_axis_angle(ax / np.linalg.norm(ax), 0.01)), qj)
        _, axis_prev, _ = sat(pi, qi, np.zeros(3), pj, q_prev, xj - d)
        g, _, _ = sat(pi, qi, np.zeros(3), pj, qj, xj)
        assert g < 0
        f = fcp_fn(0, True, 0, support_edges_of(pi, pj))
        o = f(padded(pi), jnp.asarray(qi, jnp.float32), jnp.zeros(3), padded(pj), jnp.asarray(qj, jnp.float32),
              jnp.asarray(xj, jnp.float32), jnp.asarray(axis_prev, jnp.float32), jnp.bool_(True))
        assert abs(float(o["gap"]) - g) <= 2e-5 * L, (seed, k, g, float(o["gap"]))


def _rock(rng, size=0.19):
    p = rng.normal(size=(12, 3))
    p *= rng.uniform(0.7, 1.0, (12, 1)) / np.linalg.norm(p, axis=1, keepdims=True)
    hull = ConvexPolyhedron.from_vertices(p)
    return ConvexPolyhedron.from_vertices(hull.vertices * (size / np.ptp(hull.vertices, axis=0).max()))


def _pile(warm: int):
    """Six rocks in two columns on a floor slab, each 1 mm above the one below; segments of 4."""
    rng = np.random.default_rng(3)
    polys, pos = [slab(2.0, 2.0, 0.1)], [[0.0, 0.0, -0.05]]
    for c, x0 in enumerate((-0.15, 0.15)):
        top = 0.0
        for _ in range(3):
            r = _rock(rng)
            lo = float(r.vertices[:, 2].min())
            pos.append([x0 + 0.01 * c, 0.01 * c, top + 1e-3 - lo])
            top = pos[-1][2] + float(r.vertices[:, 2].max())
            polys.append(r)
    return make_blocks(polys, positions=np.asarray(pos), motion=[Motion.FIXED] + [Motion.DYNAMIC] * 6,
                       normal_stiffness=1e7, shear_stiffness=4e6, pair_segment=4, fcp_iterations=1,
                       fcp_warm_iterations=warm)


def _run(cfg, par, st, n, dt):
    def body(s, _):
        s, stat = rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=jnp.asarray(GRAV))
        h = s.history
        return s, (stat, jnp.sum(h.pair_mask & h.plane_valid), jnp.sum(h.pair_mask & ~h.plane_valid))

    return jax.lax.scan(body, st, None, length=n)


@pytest.fixture(scope="module")
def piles(x64):
    """Both piles run 1500 steps of the stable dt (the rocks fall 1 mm, ~14 ms, strike and rest on
    each other): ``(configs, params, start, dt, ends, per-step (status, warm pairs, cold pairs))``."""
    (cfg0, par, st), (cfg1, _, _) = _pile(0), _pile(1)
    dt = float(rb.stable_dt(cfg0, par, st))
    runs = [jax.jit(lambda s, c=c: _run(c, par, s, 1500, dt))(st) for c in (cfg0, cfg1)]
    return (cfg0, cfg1), par, st, dt, [r[0] for r in runs], [r[1] for r in runs]


def test_warm_segments_change_nothing_in_a_rock_pile(piles):
    (cfg0, cfg1), par, st, dt, (s0, s1), ((stat0, warm, cold), (stat1, _, _)) = piles
    assert (cfg0.fcp_iterations, cfg0.fcp_warm_iterations, cfg1.fcp_warm_iterations) == (1, 0, 1)
    assert int(np.bitwise_or.reduce(np.asarray(stat0))) == 0
    assert int(np.bitwise_or.reduce(np.asarray(stat1))) == 0
    warm, cold = np.asarray(warm), np.asarray(cold)
    assert warm[-1] >= 6 and cold[-1] == 0, (warm[-1], cold[-1])  # at rest: every candidate pair warm
    # the list is built in the first step (its pairs cold: the cold branch), warm from the second on
    assert not np.any(np.asarray(st.history.pair_mask)) and warm[0] > 0 and cold[0] == 0
    travel = np.linalg.norm(np.asarray(s0.x - st.x)[1:], axis=1)
    assert travel.max() > 1e-3  # they fell into contact
    np.testing.assert_allclose(np.asarray(s1.x), np.asarray(s0.x), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(s1.q), np.asarray(s0.q), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(s1.history.shear), np.asarray(s0.history.shear), rtol=0, atol=1e-9)


def test_warm_segments_gradient(piles):
    """Reverse mode through the per-segment ``lax.cond`` from the resting pile (every segment warm):
    d(final positions)/d(params) as with the iterating program."""
    (cfg0, cfg1), par, _, dt, (s0, _), _ = piles

    def grad(cfg):
        def f(p):
            s, _ = _run(cfg, p, s0, 30, dt)
            return jnp.sum(s.x[1:, 0] ** 2 + s.x[1:, 2])

        return jax.jit(jax.grad(f))(par)

    g0, g1 = grad(cfg0), grad(cfg1)
    for a, b in zip(jax.tree_util.tree_leaves(g0), jax.tree_util.tree_leaves(g1)):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-9, atol=1e-15)
    assert any(np.any(np.asarray(a) != 0) for a in jax.tree_util.tree_leaves(g0))
