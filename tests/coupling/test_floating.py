"""Archimedes: a floating box settles at the draft rho_box / rho_water x height (issue 5: within 3 %).

Scene: a 0.12 x 0.12 x 0.08 m box of 500 kg/m^3 in a 0.36 x 0.36 m tank of 0.16 m water, released
at half its equilibrium draft (0.04 m); 3 s simulated, the draft averaged over t >= 1.65 s (about
three heave periods of ~0.45 s, so the weakly damped oscillation averages out).
The draft is measured from the water level the water volume gives once the box floats at
equilibrium (the tank is finite: the level rises as the box sinks), not from the initial level.
Slow: ~3 min per coupling on 2 busy cores.

Boundary particles (with the guard, ``Config.coupling_guard``) pass. The seed Eq 22 penalty is a
strict xfail: the spring carries what the SPH pressure sum pushes on the first fluid layer minus
that layer's weight, ~0.925 p_1 - rho g dx on a lattice (Wendland C2 over the half space,
h = 1.3 dx), so the box sinks deeper until that balances its weight -- the method's bias at this
resolution, not an implementation bug. ``Coupling.BOUNDARY_INTEGRAL`` is a non-strict xfail (its
heave is hardly damped, so the mean moves with the window): its wall term alone does not hold the
water off the face (its push grows little from dx/2 to dx/4), the dx/4 guard's kicks do, and the
load on a held box grows with the guard's stiffness and does not converge with resolution. The
measurements behind both are in RESULTS.md ("Buoyancy of a held box") and docs/notes.md.

The second Archimedes check, a block resting on the floor under water, is in
``test_floating_resting.py``, a file of its own so that pytest-xdist can give the two files to
different workers in the slow suite.
"""

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
    pytest.param(rj.Coupling.BOUNDARY_INTEGRAL, marks=pytest.mark.xfail(
        strict=False, raises=AssertionError,
        reason="measured 2026-11-27 at dx = 0.02: 0.0376 m vs 0.040 m (-6.0 %; the heave still bobs +-3 mm at 3 s, "
               "hardly damped); held still at the draft its load is +9.4 % (experiments/held_box_load.py; +1.9 % at "
               "t = 0), +15.9 % at dx = 0.01 m: the wall term alone does not hold the water off the face, the "
               "dx/4 guard's kicks do (module docstring)")),
])
def test_archimedes_draft(coupling):
    draft, eq = settled_draft(coupling)
    print(f"{coupling.value}: draft {draft:.4f} m, Archimedes {eq:.4f} m, error {(draft - eq) / eq:+.1%}")
    assert abs(draft - eq) <= 0.03 * eq
