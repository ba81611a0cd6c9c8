"""The seed's sliding wedge (seed section 6) run until its wave reaches the far beach, with both
couplings: no instability (the driver raises on any fatal status bit), no water inside the wedge,
the wedge down on the floor, and the wave recorded by the gauges and as run-up on the beach.

Slow (about 2-4 min per coupling on 2 cores): ``pytest -m slow tests/coupling/test_wedge_run.py``.
"""

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import scene_observer

from test_coupling import _inside_distance  # same folder (pytest prepend import mode)

pytestmark = pytest.mark.slow

DX = 0.04
T_END = 2.0  # the wedge reaches the toe at ~1.56 s; the wave reaches the beach (1 m of flat) before


@pytest.mark.parametrize("coupling", [rj.Coupling.PENALTY, rj.Coupling.BOUNDARY_PARTICLES])
def test_wedge_reaches_floor_and_wave_reaches_beach(coupling):
    scene = rj.scenes.sliding_wedge(dx=DX, coupling=coupling)
    res = rj.simulate(scene, t_end=T_END, frame_dt=0.05, observe=scene_observer(scene.meta), progress=False)
    assert int(res.state.status) == 0
    fluid = res.frames["kind"][0] == rj.Kind.FLUID
    assert np.all(np.isfinite(res.frames["x"]))
    B0 = scene.state.blocks
    worst = np.inf
    for k in range(len(res.times)):
        Bk = B0.replace(x=jnp.asarray(res.frames["block_x"][k]), q=jnp.asarray(res.frames["block_q"][k]))
        worst = min(worst, float(_inside_distance(res.frames["x"][k][fluid], Bk, 0).min()))
    assert worst > 0.0, f"a water particle {-worst:.3g} m inside the wedge"
    # the wedge slid into the water and down to the floor: its centroid is within its height of the floor
    z = res.frames["block_x"][:, 0, 2]
    floor = -scene.meta["water_depth"]
    assert z[-1] < floor + scene.meta["block_height"], (z[-1], floor)
    # the wave (criteria well above the ~1 mm noise of the kernel estimates): the near gauge rose by
    # more than a quarter spacing, and the run-up on the far beach by more than half a spacing
    gauges = res.observed["gauges"]
    assert gauges[:, 0].max() > 0.25 * DX, gauges[:, 0].max()
    runup = res.observed["runup"]
    assert runup.max() - runup[0] > 0.5 * DX, (runup.max(), runup[0])
    assert np.all(np.isfinite(res.observed["smooth_runup"]))
