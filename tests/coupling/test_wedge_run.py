"""The seed's sliding wedge (seed section 6) run until its wave reaches the far beach, with both
couplings: no instability (the driver raises on any fatal status bit), the wave recorded by the
gauges and as run-up on the beach, no water inside the wedge, the wedge down on the floor.

Slow (about 40 s per coupling on 2 cores, 2026-11-25): ``pytest -m slow tests/coupling/test_wedge_run.py``.

Measured failures are kept as strict xfails with their numbers (2026-11-23, dx 0.04; the first
and third were fixed on 2026-11-25, below):
* penalty (seed Eq 22): the wedge stops on the slope at z = -0.16 m (centroid; the floor is at
  -0.40 m) after ~1.45 s although its friction angle (15 deg) is below the slope (25 deg); with
  boundary particles it slides on to the floor (reached at ~1.56 s). Statics of the resting wedge
  explain it: the fluid load (-52, 0, -40) N pushes it up-slope (-30 N) and into the slope
  (+58 N), so the normal force is 221 N (weight part 163 N) and friction can hold 59 N > the
  46 N net driving force. The water presses on the top and front faces but none reaches the
  hypotenuse sealed against the slope (no uplift: real joints carry water pressure). With
  boundary particles the load is similar, (-69, 0, -85) N at 1.5 s, but the wedge, still moving
  (0.32 m/s), reaches the floor first.
* boundary particles, water inside the wedge: with the boundary-particle lattice of 2026-11-23
  (started at the bounding box's corner, points within dx/4 of a face dropped) water was found
  0.6 dx inside, and 0.44-0.54 dx below the top face with the wedge at rest: the 4.66 dx tall
  wedge's top layer sat 1.16 dx deep. Since 2026-11-25 the lattice is aligned with the top and
  front faces (``scenes.coupled.sample_block_particles``; ``experiments/wedge_inside.py``): worst
  0.376 dx (t = 1.04 s, against the slope face near the front-bottom edge, whose lattice cannot be
  aligned), 0.15 dx at rest. Still a strict xfail.
* boundary particles, sliding to the floor: with the 2026-11-23 lattice the wedge reached the floor
  still moving (0.32 m/s at 1.5 s). With the aligned lattice (2026-11-25) it decelerated from
  1.0 m/s at 0.7 s to rest at ~1.6 s with its centroid at z = -0.202 m (criterion < -0.213 m),
  under a fluid load (-67, 0, -80) N: the penalty case's mechanism.

Fixed 2026-11-25 by the joint water pressure (``blocks.joint_water``, on by default in
``sliding_wedge``): the face on the slope carries the still water's hydrostatic pressure, as real
joints do (the particles cannot enter a joint thinner than dx). Measured (dx 0.04, 2 s): both
couplings slide on (~0.6-0.85 m/s penalty, ~1.0 m/s boundary particles) and stop against the
floor, centroid z = -0.281 m (penalty, at ~1.7 s) and -0.292 m (boundary particles, ~1.5 s);
run-up 0.073 m with either. Water inside
the boundary-particle wedge: worst 0.452 dx (t = 0.97 s, against the slope face near the
front-bottom edge; 0.376 dx without joint water, the wedge being slower), still a strict xfail.

Later on 2026-11-25 the block's particles were resampled (``scenes.block_sampling``: an outer
layer exactly dx/2 inside every face, a lattice behind it, the 25 deg edge covered, each particle
with its share of the block's shell as volume; the lattice had the slope face's outer layer
anywhere 0.06-0.96 dx deep). ``experiments/wedge_inside.py`` with the final sampling: worst
0.309 dx, at t = 0.67 s at the front-top edge as the wedge enters the water (0.37 dx inside the
front face, 0.31 dx below the top: pressed between the edge's particles by the impact), no
particle past the outer layer; the slope-face and tip cases are gone. Runs with intermediate
samplings (same file) also showed a single slow particle slipping through the top face's outer
layer, between particles dx apart, at ~1.9-2.0 s with the wedge at rest (up to 1.04 dx deep):
the particle wall is not a tight barrier.

Fixed later on 2026-11-25 by the guard (``Config.coupling_guard``, on by default with boundary
particles): the seed Eq 22 penalty also acts within dx/4 of a face, where water at rest does not
sit (a spacing from the outer layer, dx/2 deep), and its reaction goes to the block. Measured
(``experiments/wedge_inside.py``, dx 0.04, 2 s, same session, guard on / off): the closest water
0.243 dx outside the faces / 0.309 dx inside; the guard's load at most 40.5 N (impact) and 0.9 N
of the 126 N load over the last 0.3 s (wedge at rest); the wedge ended at x = 0.772 / 0.808 m
(the water no longer leaking in at the impact brakes it more). The floating box still settles
within 3 % (``test_floating.py``: -2.8 % with the guard, -2.3 % without, same session).
"""

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import scene_observer

from test_coupling import _inside_distance  # same folder (pytest prepend import mode)

pytestmark = pytest.mark.slow

DX = 0.04
T_END = 2.0  # the wedge reaches the floor at ~1.45-1.7 s; the wave reaches the beach before


@pytest.fixture(scope="module", params=[rj.Coupling.PENALTY, rj.Coupling.BOUNDARY_PARTICLES], ids=lambda c: c.value)
def run(request):
    scene = rj.scenes.sliding_wedge(dx=DX, coupling=request.param)
    res = rj.simulate(scene, t_end=T_END, frame_dt=0.05, observe=scene_observer(scene.meta), progress=False)
    return request.param, scene, res


def test_stable_and_wave_reaches_beach(run):
    coupling, scene, res = run
    assert int(res.state.status) == 0
    assert np.all(np.isfinite(res.frames["x"]))
    # the wave (criteria well above the ~1 mm noise of the kernel estimates): the near gauge rose by
    # more than a quarter spacing, and the run-up on the far beach by more than half a spacing
    gauges = res.observed["gauges"]
    assert gauges[:, 0].max() > 0.25 * DX, gauges[:, 0].max()
    runup = res.observed["runup"]
    assert runup.max() - runup[0] > 0.5 * DX, (runup.max(), runup[0])
    assert np.all(np.isfinite(res.observed["smooth_runup"]))


def test_no_water_inside_wedge(run):
    coupling, scene, res = run
    if coupling == rj.Coupling.BOUNDARY_PARTICLES:
        assert scene.config.coupling_guard  # the default (without it: the module docstring)
    fluid = res.frames["kind"][0] == rj.Kind.FLUID
    B0 = scene.state.blocks
    worst = np.inf
    for k in range(len(res.times)):
        Bk = B0.replace(x=jnp.asarray(res.frames["block_x"][k]), q=jnp.asarray(res.frames["block_q"][k]))
        worst = min(worst, float(_inside_distance(res.frames["x"][k][fluid], Bk, 0).min()))
    assert worst > 0.0, f"a water particle {-worst:.3g} m inside the wedge"


def _closest_to_fixed(scene, res):
    """Closest water to each FIXED block (the slope, the floor) over all frames [m], negative inside."""
    fluid = res.frames["kind"][0] == rj.Kind.FLUID
    B0 = scene.state.blocks
    fixed = [b for b, m in enumerate(scene.config.blocks.motion) if m == rj.blocks.Motion.FIXED]
    assert len(fixed) == 2  # the slope and the floor
    worst = {b: np.inf for b in fixed}
    for k in range(len(res.times)):
        for b in fixed:  # fixed: the initial pose throughout
            worst[b] = min(worst[b], float(_inside_distance(res.frames["x"][k][fluid], B0, b).min()))
    return worst


def test_no_water_inside_fixed_blocks(run, request):
    """The fixed slope and floor are met by the water as wall particles, which keep it out only
    as long as nothing presses a particle between them: at the toe, between the resting wedge and
    the slope, one is (strict xfails, measured 2026-11-25, below). ``Config.guard_fixed`` keeps it
    out: ``test_guard_fixed_keeps_water_out_of_fixed_blocks``."""
    coupling, scene, res = run
    reason = {rj.Coupling.PENALTY: "measured 2026-11-25: water 0.208 dx inside the fixed slope at the toe (floor +0.171 dx)",
              rj.Coupling.BOUNDARY_PARTICLES: "measured 2026-11-25: water 0.303 dx inside the fixed slope at the toe "
                                              "(floor +0.059 dx; wedge_inside.py's frames: 0.338 dx); Config.guard_fixed "
                                              "(off by default) keeps it out"}
    request.applymarker(pytest.mark.xfail(strict=True, raises=AssertionError, reason=reason[coupling]))
    worst = _closest_to_fixed(scene, res)
    print(f"{coupling.value}: closest water to the fixed blocks / dx: "
          + ", ".join(f"{b}: {w / DX:+.3f}" for b, w in worst.items()))
    assert all(w > 0.0 for w in worst.values()), {b: w / DX for b, w in worst.items()}


def test_guard_fixed_keeps_water_out_of_fixed_blocks():
    """Boundary particles with ``Config.guard_fixed`` (the seed Eq 22 penalty within dx/4 of the
    fixed blocks' faces, a kick with no load; ``coupling.penalty.guard_fixed``): no water inside the
    fixed slope or floor. Measured 2026-11-25: closest 0.250 dx outside the slope, 0.272 dx above
    the floor (0.295 dx in ``experiments/wedge_inside.py --guard-fixed``'s frames). Not offered
    with the penalty coupling: guarded so, block_drop's box was held 0.75 dx above the floor on a
    trapped film of water (kept out of the slope: +0.248 / +0.261 dx)."""
    scene = rj.scenes.sliding_wedge(dx=DX, coupling=rj.Coupling.BOUNDARY_PARTICLES)
    scene = scene.replace(config=scene.config.replace(guard_fixed=True))
    res = rj.simulate(scene, t_end=T_END, frame_dt=0.05, progress=False)
    assert int(res.state.status) == 0
    worst = _closest_to_fixed(scene, res)
    print("closest water to the fixed blocks / dx: " + ", ".join(f"{b}: {w / DX:+.3f}" for b, w in worst.items()))
    assert all(w > 0.0 for w in worst.values()), {b: w / DX for b, w in worst.items()}


def test_wedge_slides_to_floor(run):
    """Friction angle 15 deg < slope 25 deg: the wedge must slide on until the floor stops it
    (its centroid ends within its height of the floor)."""
    coupling, scene, res = run
    assert scene.config.blocks.joint_water  # the scene's default (without it: the module docstring)
    z = res.frames["block_x"][:, 0, 2]
    floor = -scene.meta["water_depth"]
    assert z[-1] < floor + scene.meta["block_height"], (z[-1], floor)
