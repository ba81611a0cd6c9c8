"""Archimedes for a block *resting on the floor* under water (issue 5): the water's total load on it
is rho g V upwards within 3 %, through the joint water pressure on the face on the floor
(``blocks.joint_water``), although no particle is under it.

The companion of ``test_floating.py`` (a floating box's draft; its module docstring has the
analysis of the penalty coupling's bias, which shows here too). Slow: ~6.5 min per coupling on
2 busy cores.
"""

import numpy as np
import pytest

import rockjax as rj

DX = 0.02


def resting_load(coupling, dx=DX, t_end=2.5):
    """``block_drop`` (a 0.1 m cube of 2500 kg/m^3 dropped 0.2 m into 0.2 m of water onto a fixed
    floor): the water's load on the cube at rest on the floor, fluid (its particles, on the top
    and sides) + joint water (the face on the floor, ``blocks.joint_water``), time-averaged over
    the last 0.6 s; and the cube's volume."""
    import jax.numpy as jnp

    from rockjax.blocks import contact_forces

    scene = rj.scenes.block_drop(dx=dx, coupling=coupling)
    assert scene.config.blocks.joint_water

    def observe(s, p, c):
        _, _, _, _, info = contact_forces(s.blocks, p.blocks, c.blocks, dt=c.dt, gravity=p.gravity, return_info=True)
        return dict(fluid=s.coupling.force[0], joint=-jnp.sum(info["joint_water_force"], 0))  # pairs (box, floor)

    res = rj.simulate(scene, t_end=t_end, frame_dt=0.02, observe=observe, progress=False)
    assert int(res.state.status) == 0
    late = res.times >= t_end - 0.6
    z = res.frames["block_x"][late, 0, 2]
    fluid, joint = res.observed["fluid"][late].mean(0), res.observed["joint"][late].mean(0)
    return fluid, joint, float(np.prod(scene.meta["box_size"])), z


@pytest.mark.slow
@pytest.mark.parametrize("coupling", [
    rj.Coupling.BOUNDARY_PARTICLES,
    pytest.param(rj.Coupling.PENALTY, marks=pytest.mark.xfail(
        strict=True, raises=AssertionError, reason="measured 2026-11-25 at dx = 0.02: 12.0 N vs 9.81 N (+22 %): the penalty carries "
                            "~0.925 p - rho g dx of the pressure on the top face (8.0 N of 10.2 N; the draft "
                            "bias of test_floating.py)")),
])
def test_archimedes_resting_on_the_floor(coupling):
    """Archimedes for a block *on* the floor under water: the water's total load on it (particles
    on the top and sides + the joint water on the face on the floor) is rho g V upwards, within
    3 %, although no particle is under it.  Without the joint water it is the top face's
    downward push alone (the block is pressed onto the floor instead of buoyed)."""
    fluid, joint, vol, z = resting_load(coupling)
    total = fluid + joint
    archimedes = 1000.0 * 9.81 * vol
    print(f"{coupling.value}: water load {total} N (fluid {fluid}, joint {joint}), Archimedes {archimedes:.3f} N")
    assert np.ptp(z) < 1e-3 and abs(z.mean() - 0.05) < 1e-3  # at rest on the floor
    assert abs(total[2] - archimedes) <= 0.03 * archimedes
    assert np.all(np.abs(total[:2]) <= 0.03 * archimedes)
