"""The seed's sliding wedge (seed section 6) run until its wave reaches the far beach, with both
couplings: no instability (the driver raises on any fatal status bit), the wave recorded by the
gauges and as run-up on the beach, no water inside the wedge, the wedge down on the floor.

Slow (about 40 s per coupling on 2 cores): ``pytest -m slow tests/coupling/test_wedge_run.py``.

The wedge slides to the floor because its face on the slope carries the still water's
hydrostatic pressure (``blocks.joint_water``, on by default in ``sliding_wedge``; the particles
cannot enter a joint thinner than dx): without it both couplings stop it on the slope although
its friction angle (15 deg) is below the slope (25 deg). With boundary particles the guard
(``Config.coupling_guard``: the seed Eq 22 penalty within dx/4 of a face) keeps the water out of
the moving wedge. Known failures are strict xfails that carry their measured numbers; the
history of these checks is in docs/notes.md.
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
    the slope, one is (strict xfails, with the measured depths). ``Config.guard_fixed`` keeps it
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
    fixed slope or floor (closest water outside 0 dx). Not offered with the penalty coupling,
    where a guarded floor holds a landing block on a trapped film of water."""
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
