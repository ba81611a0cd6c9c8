"""Archimedes: a floating box settles at the draft rho_box / rho_water x height (issue 5: within 3 %).

Scene: a 0.12 x 0.12 x 0.08 m box of 500 kg/m^3 in a 0.36 x 0.36 m tank of 0.16 m water, released
at half its equilibrium draft (0.04 m); 3 s simulated, the draft averaged over t >= 1.65 s (about
three heave periods of ~0.45 s, so the weakly damped oscillation averages out).
The draft is measured from the water level the water volume gives once the box floats at
equilibrium (the tank is finite: the level rises as the box sinks), not from the initial level.
Slow: ~5-10 min per coupling on 2 cores.

Penalty (seed Eq 22) coupling: measured +34 % (strict xfail). Why, from a diagnostic run
(2026-11-23, dx = 0.02, 2 s): at equilibrium the penalty load equals the box weight (5.63 vs
5.65 N), the first fluid layer sits 0.41-0.50 dx below the bottom face, and its pressure is
680-770 Pa where the box weight needs only 392 Pa over the face. The spring carries what the SPH
pressure sum pushes on that layer minus the layer's own weight: on a lattice the Wendland C2 sum
over the half space below (h = 1.3 dx) gives 0.925 p dx^2 per particle, and the weight is
rho g dx^3, so the face pressure transmitted is ~0.925 p_1 - rho g dx (p_1 at the layer,
0.45 dx below the face). Solving 0.925 rho g (draft + 0.45 dx) - rho g dx = 392 Pa gives a draft
of 0.056 m (+40 %; measured 0.053 m): the bias is the method's at this resolution (the rho g dx
part shrinks with dx, the 0.925 does not), not a bug of the implementation. Boundary particles
carry the wall pressure instead and pass (with the guard, ``Config.coupling_guard``: the same
penalty within dx/4 of a face, where no water sits at rest: measured -2.8 %, its load over the
last 1.35 s 2e-4 N; -2.3 % without it, when water at the waterline crept within dx/4).

Second check (``test_archimedes_resting_on_the_floor``): a block resting on the floor under water
is buoyed by rho g V too, through the joint water pressure on the face on the floor.
"""

import numpy as np
import pytest

import rockjax as rj

DX = 0.02
BOX = (0.12, 0.12, 0.08)
TANK = (0.36, 0.36)
DEPTH = 0.16


def settled_draft(coupling, dx=DX, t_end=3.0):
    scene = rj.scenes.floating_box(dx=dx, box_size=BOX, tank_size=TANK, water_depth=DEPTH, coupling=coupling)
    res = rj.simulate(scene, t_end=t_end, frame_dt=0.05, progress=False)
    eq = scene.meta["equilibrium_draft"]
    level = (scene.config.n_fluid * dx**3 + eq * BOX[0] * BOX[1]) / (TANK[0] * TANK[1])
    z = res.frames["block_x"][:, 0, 2]
    draft = level - (z - 0.5 * BOX[2])
    return float(draft[res.times >= 1.65].mean()), eq


@pytest.mark.slow
@pytest.mark.parametrize("coupling", [
    rj.Coupling.BOUNDARY_PARTICLES,
    pytest.param(rj.Coupling.PENALTY, marks=pytest.mark.xfail(
        strict=True, raises=AssertionError,
        reason="measured 2026-11-23 at dx = 0.02: 0.0536 m vs 0.040 m (+34 %; 0.0533 m, +33 %, on 2026-11-25); the seed Eq 22 "
                            "penalty transmits ~0.925 p - rho g dx of the pressure p (module docstring)")),
])
def test_archimedes_draft(coupling):
    draft, eq = settled_draft(coupling)
    print(f"{coupling.value}: draft {draft:.4f} m, Archimedes {eq:.4f} m, error {(draft - eq) / eq:+.1%}")
    assert abs(draft - eq) <= 0.03 * eq


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
                            "bias above)")),
])
def test_archimedes_resting_on_the_floor(coupling):
    """Archimedes for a block *on* the floor under water: the water's total load on it (particles
    on the top and sides + the joint water on the face on the floor) is rho g V upwards, within
    3 %, although no particle is under it.  Without the joint water it is the top face's
    downward push alone (about -10 N here, measured 2026-11-25: the block is pressed onto the
    floor instead of buoyed).  Measured 2026-11-25, boundary particles: 9.72 N vs 9.81 N
    (-1.0 %; fluid -10.30 N, joint 20.01 N, the tank's level raised 4 mm by the cube)."""
    fluid, joint, vol, z = resting_load(coupling)
    total = fluid + joint
    archimedes = 1000.0 * 9.81 * vol
    print(f"{coupling.value}: water load {total} N (fluid {fluid}, joint {joint}), Archimedes {archimedes:.3f} N")
    assert np.ptp(z) < 1e-3 and abs(z.mean() - 0.05) < 1e-3  # at rest on the floor
    assert abs(total[2] - archimedes) <= 0.03 * archimedes
    assert np.all(np.abs(total[:2]) <= 0.03 * archimedes)
