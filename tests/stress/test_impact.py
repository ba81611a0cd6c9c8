"""Stress: a block thrown into shallow water at 20 m/s, hitting the water and then the floor.

Scene (``stress_common.impact_scene``): a 0.1 m cube (2500 kg/m^3) 2 cm above 0.1 m of water in
a 0.3 x 0.3 m tank (dx = 0.025 m, 576 fluid particles), moving down at 20 m/s; a FIXED floor slab
under the tank floor (z = 0); c0 = 200 m/s (10 x the impact speed), dt = 0.25 h / c0 = 4.1e-5 s.
It crosses the water in ~5 ms and strikes the floor. Run 25 ms (~600 steps), both couplings.

What must hold: the run either ends cleanly or stops with a documented fatal bit (the block
penetrating the floor beyond 10 % of its size, a particle leaving the domain) naming the step;
every value finite; no water leaks through the tank walls (every fluid particle stays inside the
tank, within its half-spacing); the block never tunnels through the floor.
"""

from __future__ import annotations

import numpy as np
import pytest

import rockjax as rj

from stress_common import finite_blocks, finite_particles, impact_scene

pytestmark = pytest.mark.stress

DX = 0.025
T_END = 0.025


@pytest.mark.parametrize("coupling", [rj.Coupling.PENALTY, rj.Coupling.BOUNDARY_PARTICLES],
                         ids=lambda c: c.value)
def test_block_at_20_m_per_s_into_water_and_floor(coupling):
    scene = impact_scene(speed=20.0, dx=DX, coupling=coupling)
    L, W = scene.meta["tank"]
    try:
        res = rj.simulate(scene, t_end=T_END, frame_dt=T_END / 25, progress=False)
    except rj.SimulationError as e:
        fatal = e.status & ~int(rj.Status.growable())
        print(f"\nimpact ({coupling.value}): stopped: {e}")
        allowed = rj.Status.BLOCK_PENETRATION | rj.Status.OUT_OF_DOMAIN
        assert fatal and not fatal & ~int(allowed), rj.Status.describe(e.status)
        assert not e.status & rj.Status.NON_FINITE
        assert e.step > 0 and f"step {e.step}" in str(e)
        return
    F = res.frames
    fluid = F["kind"][0] == rj.Kind.FLUID
    x = F["x"][:, fluid]
    bz = F["block_x"][:, 0, 2]
    bv = F["block_v"][:, 0, 2]
    vmax = np.linalg.norm(F["v"][:, fluid], axis=-1).max()
    h = DX / 2
    inside = ((x[..., 0] > -h) & (x[..., 0] < L + h) & (x[..., 1] > -h) & (x[..., 1] < W + h) & (x[..., 2] > -h))
    print(f"\nimpact ({coupling.value}): clean, {res.stats['steps']} steps, wall {res.stats['wall_s']:.1f} s; block z "
          f"{bz[0]:.3f} -> min {bz.min():.4f} m (rest on floor: 0.05), v_z {bv[0]:.1f} -> {bv[-1]:.2f} m/s; "
          f"fluid v_max {vmax:.1f} m/s; leaked {int((~inside).any(0).sum())} particles; "
          f"regrows {res.stats['regrows']}")
    assert int(res.state.status) == 0
    assert finite_blocks(res.state) and finite_particles(res.state)
    assert bz.min() > 0.05 - 0.1 * 0.0866, bz.min()  # bottom face above the floor by < penetration limit
    assert bv[-1] > -10.0  # it was stopped (or rebounds), not still falling at 20 m/s
    assert inside.all(), f"{int((~inside).any(0).sum())} fluid particles left the tank"
