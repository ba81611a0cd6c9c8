"""Stress: rock blocks without water (cheap, no SPH traced).

* a 10-block stack held for 10 s on a fixed floor: drift < 1 mm (issue 7);
* two blocks starting in deep overlap: the driver stops in the first chunk with BLOCK_PENETRATION;
  stepped on by hand the values stay finite and the blocks separate (explosively: see the test);
* random blocks-only scenes (hypothesis): random convex blocks, densities and speeds thrown at a
  floor and at each other end with finite values and honest status bits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rockjax as rj
from rockjax.blocks import Broadphase, Motion, box, slab
from rockjax.scenes.coupled import coupled_scene

from stress_common import finite_blocks, random_block

pytestmark = pytest.mark.stress

G = 9.81


def test_ten_block_stack_held_10s():
    """10 cubes (0.2 m, 2650 kg/m^3) on a fixed floor, 10 s through ``simulate`` (float32,
    dt = blocks.stable_dt = 1.27e-4 s, 78.6k steps; sorted-grid broad phase with 16 pair slots, 2.2x
    cheaper than all 55 pairs; an overflow would be regrown by the driver). Bound: every block within
    1 mm of its start (issue 7). The bound includes the settlement under the column: the penalty spring carries n m g on 4 corner
    points of k_n = 1e7 N/m, so the top block sinks sum_{n=1..10} n m g / (4 k_n) = 0.29 mm."""
    n, a, k = 10, 0.2, 1e7
    polys = [slab(2.0, 2.0, 0.3)] + [box(a, a, a) for _ in range(n)]
    pos = [[0.0, 0.0, -0.15]] + [[0.0, 0.0, a / 2 + a * i] for i in range(n)]
    scene = coupled_scene(name="stack", dx=None, polyhedra=polys, positions=pos,
                          motion=(Motion.FIXED,) + (Motion.DYNAMIC,) * n, block_density=2650.0,
                          friction_angle_deg=30.0,
                          block_kwargs=dict(normal_stiffness=k, shear_stiffness=k, broadphase=Broadphase.GRID,
                                            pair_capacity=16))
    res = rj.simulate(scene, t_end=10.0, frame_dt=0.5, progress=False)
    x = res.frames["block_x"][:, 1:]
    drift = np.linalg.norm(x - np.asarray(pos)[None, 1:], axis=-1)
    m = 2650 * a**3
    settle = sum(i * m * G / (4 * k) for i in range(1, n + 1))
    print(f"\n10-block stack: {res.stats['steps']} steps, dt {scene.config.dt:.3g} s, wall {res.stats['wall_s']:.1f} s; "
          f"max drift {drift.max() * 1e3:.4f} mm (top block {drift[-1, -1] * 1e3:.4f} mm, "
          f"expected settlement {settle * 1e3:.3f} mm); max lateral {np.abs(x[..., :2]).max() * 1e3:.4f} mm")
    assert res.times[-1] >= 10.0
    assert int(res.state.status) == 0, rj.Status.describe(int(res.state.status))
    assert finite_blocks(res.state)
    assert drift.max() < 1e-3, drift.max()


def _overlap_scene(depth_frac: float):
    """Two 0.2 m cubes on a floor, the upper one sunk ``depth_frac`` of its height into the lower."""
    a = 0.2
    polys = [slab(2.0, 2.0, 0.3), box(a, a, a), box(a, a, a)]
    pos = [[0.0, 0.0, -0.15], [0.0, 0.0, a / 2], [0.02, 0.01, a / 2 + a * (1 - depth_frac)]]
    return coupled_scene(name="overlap", dx=None, polyhedra=polys, positions=pos,
                         motion=(Motion.FIXED, Motion.DYNAMIC, Motion.DYNAMIC), block_density=2650.0,
                         friction_angle_deg=30.0, block_kwargs=dict(normal_stiffness=1e7, shear_stiffness=1e7,
                                                                    check_overlap=False))  # built to be run


@pytest.mark.parametrize("depth_frac", [0.3, 0.6])
def test_deep_overlap_is_reported_and_finite(depth_frac):
    """Blocks that start 30 % / 60 % inside each other: the first step must set BLOCK_PENETRATION
    (the contact is deeper than ``penetration_limit`` = 0.1 of the block radius) and the driver must
    stop with a SimulationError naming step 1 (it checks the status bits once per chunk, which
    carries the index of the first step that set them) -- never run on silently (``make_blocks``
    refuses such a start; ``check_overlap=False`` builds it to see the run stop). Then the same
    scene stepped by hand past the bit (0.3 s): values stay finite and the blocks separate -- violently: the
    penalty spring's stored energy flings the upper block off at tens of m/s. That is why the
    driver refuses to run on past the bit."""
    scene = _overlap_scene(depth_frac)
    frame_dt = 1e-3
    chunk = max(1, round(frame_dt / scene.config.dt))
    with pytest.raises(rj.SimulationError) as err:
        rj.simulate(scene, t_end=0.05, frame_dt=frame_dt, progress=False)
    assert err.value.status & rj.Status.BLOCK_PENETRATION, rj.Status.describe(err.value.status)
    assert chunk > 1  # the chunk's last step would be a different answer
    assert err.value.step == 1 and "step 1 " in str(err.value), str(err.value)
    print(f"\noverlap {depth_frac}: {err.value}")

    # past the bit, by hand: 0.3 s of free evolution
    import jax

    step = jax.jit(rj.make_step(scene.config))
    n = int(round(0.3 / scene.config.dt))
    s = scene.state
    bits = 0
    gap0 = float(s.blocks.x[2, 2] - s.blocks.x[1, 2])
    for _ in range(n):
        s = step(s, scene.params)
    bits = int(s.status)
    gap = float(s.blocks.x[2, 2] - s.blocks.x[1, 2])
    speed = float(np.max(np.linalg.norm(np.asarray(s.blocks.v), axis=-1)))
    print(f"overlap {depth_frac}: after {n} steps status {rj.Status.describe(bits)}, centre gap {gap0:.3f} -> "
          f"{gap:.3f} m (0.2 = touching), max speed {speed:.2f} m/s")
    assert finite_blocks(s)
    assert bits & rj.Status.BLOCK_PENETRATION
    assert not bits & rj.Status.NON_FINITE
    assert gap > 0.2 - 0.01, gap  # separated (within 5 % of a block) or flung apart


@settings(max_examples=6, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31 - 1), density=st.floats(1500.0, 4000.0), speed=st.floats(0.0, 10.0),
       size=st.floats(0.1, 0.4))
def test_random_block_scenes(seed, density, speed, size):
    """Three random convex blocks (box / wedge / hexagonal prism topologies, random affine shapes,
    ``size`` 0.1-0.4 m, density 1500-4000 kg/m^3) thrown at ``speed`` (0-10 m/s, random
    directions, random spin up to 10 rad/s) onto a floor and at each other from <= 0.35 m above it,
    0.3 s (dt = stable_dt rounded down to a power of 2: 1e4-3e4 steps). The run ends
    either cleanly (all finite, status 0) or with a SimulationError whose bits are among the
    documented fatal ones (BLOCK_PENETRATION for a contact deeper than 10 % of the block radius)
    with every value finite at the step it names -- never NaN, never silent."""
    rng = np.random.default_rng(seed)
    polys = [slab(4.0, 4.0, 0.3)] + [random_block(rng, kd, size) for kd in ("box", "wedge", "hexprism")]
    pos = [[0.0, 0.0, -0.15]] + [[(i - 1) * 1.5 * size, 0.0, 0.7 * size + 0.02 + 0.1 * i] for i in range(3)]
    dirs = rng.normal(size=(3, 3))
    dirs[:, 2] = -np.abs(dirs[:, 2])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    vel = np.concatenate([np.zeros((1, 3)), speed * dirs])
    om = np.concatenate([np.zeros((1, 3)), rng.uniform(-10, 10, (3, 3))])
    scene = coupled_scene(name="random_blocks", dx=None, polyhedra=polys, positions=pos,
                          motion=(Motion.FIXED,) + (Motion.DYNAMIC,) * 3, block_density=[2500.0] + [density] * 3,
                          friction_angle_deg=30.0, velocities=vel,
                          block_kwargs=dict(omegas=om, normal_stiffness=1e7, aabb_margin=0.005, grid_cell_size=1.0))
    # dt rounded down to a power of 2 (still <= the stable step): few distinct static configs, few compiles
    scene = scene.replace(config=scene.config.replace(dt=2.0 ** math.floor(math.log2(scene.config.dt))))
    try:
        res = rj.simulate(scene, t_end=0.3, frame_dt=0.1, progress=False)
    except rj.SimulationError as e:
        fatal = e.status & ~int(rj.Status.growable())
        print(f"\nrandom blocks seed {seed}: stopped: {e}")
        assert fatal and not fatal & ~int(rj.Status.BLOCK_PENETRATION | rj.Status.BLOCK_UNSTABLE), \
            rj.Status.describe(e.status)
        assert "step" in str(e) and e.step > 0
        return
    z = res.frames["block_x"][-1, 1:, 2]
    print(f"\nrandom blocks seed {seed}: clean, {res.stats['steps']} steps, final z {np.round(z, 3)}")
    assert int(res.state.status) == 0
    assert finite_blocks(res.state)
    assert np.all(z > -0.05), z  # nothing tunnelled through the floor
