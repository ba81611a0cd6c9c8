"""Archimedes: a floating box settles at the draft rho_box / rho_water x height (issue 5: within 3 %).

Scene: a 0.12 x 0.12 x 0.08 m box of 500 kg/m^3 in a 0.36 x 0.36 m tank of 0.16 m water, released
at half its equilibrium draft (0.04 m); 3 s simulated, the draft averaged over t >= 1.65 s (about
three heave periods of ~0.45 s, so the weakly damped oscillation averages out).
The draft is measured from the water level the water volume gives once the box floats at
equilibrium (the tank is finite: the level rises as the box sinks), not from the initial level.
Slow: ~3 min per coupling on 2 busy cores (measured 2026-11-27).

``Coupling.BOUNDARY_INTEGRAL`` (semi-analytical wall term, 2026-11-27): measured -6.0 % (xfail, not
strict: the heave is hardly damped, so the mean moves with the window); the box twice as wide
-15.7 % (mean over 2.5-5 s): the bias is over the face, not at its edges. Held still at the draft
(``experiments/held_box_load.py``, 2026-11-27) its load is +9.4 % (+18.8 % twice as wide), of which the
wall term gives 4.82 N of 6.18 N (12.2 of 26.9 N twice as wide): the rest comes from the dx/4 guard, which
5.7 (13.2) water particles touch on average; under the wide box the first layer's pressure sinks to
229 Pa where the far field has 518 Pa at that depth. Scaling the wall term's density rate by 0.9 / 1.1
moves the guard's share (32 % / 10 % of the load) but not the load (+12.7 % / +10.0 %): the excess is
not the guard's (the load on a held body in still water is fixed by where the water sits, however the
force is passed on); without that density rate the first layer's pressure goes negative. The 3 dx slab
under the face holds 0.97 of the lattice's water (penalty 1.01 / 1.08 twice as wide; boundary particles
0.99): signs as the loads', sizes not (a slab short by e would carry only e x 3 dx / draft more load:
+4.4 % vs +9.4 %), so where the water sits does not explain it alone; the pressure under the face is
not hydrostatic (under the wide box the penalty's first layer has 678 Pa vs 518 Pa far away).
Resolution (held box, 2026-11-28): at dx = 0.01 m the load is +15.9 % (boundary particles +0.5 %, the
penalty -12.2 %, against +3.9 % / -18.3 % at 0.02 m), with the guard carrying 53 % of it: the wall
term alone does not hold the water off the face (its push grows only 21 % from dx/2 to dx/4), the
guard's kicks do, and the load grows with the guard's stiffness (x4: +64 %). README, "Coupling".

Penalty (seed Eq 22) coupling: measured +34 % (strict xfail); with the box twice as wide (0.24 m,
tank 0.6 m) +19.7 % (2026-11-27): much of the bias comes from the box's edges. Why, from a diagnostic run
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

The second Archimedes check, a block resting on the floor under water, is in
``test_floating_resting.py``, a file of its own so that pytest-xdist can give the two files to
different workers in the slow suite (together they took 18.6 min of one worker, cold
compilation cache, 2026-11-27: the draft runs ~3 min each, the resting ones ~6.5 min).
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
