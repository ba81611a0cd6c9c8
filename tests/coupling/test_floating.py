"""Archimedes: a floating box settles at the draft rho_box / rho_water x height (issue 5: within 3 %).

Scene: a 0.12 x 0.12 x 0.08 m box of 500 kg/m^3 in a 0.36 x 0.36 m tank of 0.16 m water, released
at half its equilibrium draft (0.04 m); 3 s simulated, the draft averaged over t >= 1.65 s (about
three heave periods of ~0.45 s, so the weakly damped oscillation averages out).
The draft is measured from the water level the water volume gives once the box floats at
equilibrium (the tank is finite: the level rises as the box sinks), not from the initial level.
Slow: ~5-10 min per coupling on 2 cores.
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
        strict=True, reason="measured 2026-11-23 at dx = 0.02: 0.0536 m vs 0.040 m (+34 %); the seed Eq 22 "
                            "penalty transmits too little of the pressure (one-sided kernel next to the block)")),
])
def test_archimedes_draft(coupling):
    draft, eq = settled_draft(coupling)
    print(f"{coupling.value}: draft {draft:.4f} m, Archimedes {eq:.4f} m, error {(draft - eq) / eq:+.1%}")
    assert abs(draft - eq) <= 0.03 * eq
