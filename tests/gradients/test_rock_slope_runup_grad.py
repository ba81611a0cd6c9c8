"""Gradient of a rock slide's run-up w.r.t. the joint friction angle, with water (float64), checked
with ``rockjax.gradcheck`` at the steps a calibration moves.

Scene: ``scenes.rock_slope(failure="planar")`` at dx = 0.05 m: a 0.12 x 0.2 x 0.05 m slab on a 40
degree plane (friction 20 degrees on every contact, the joints' included), its front 1 cm up-slope
of the shoreline, cut by one cross joint (0.06 m) into 2 blocks (``blocks.cutting``; one column
across, one bed), 0.2 m of water, 0.4 m flat, a 20 degree far beach, a 0.3 m wide flume (348 water
particles; seed penalty coupling; joint water on), with the smooth physics settings
(``calibrate.smooth_config``). The blocks' penalty stiffness (``rock_slope``'s rule) sets the step,
7.85e-5 s.

Horizon: 2400 steps = 0.19 s. The blocks slide ~6 cm down the plane into the water; the smooth
run-up on the far beach dips and has started to rise again (~1.3 mm above its lowest, ~0.6 mm
above its start), but that motion is the water settling from its initial lattice: the slide's own
wave has not reached the beach (with a 60 degree friction, the blocks slipping only 5 mm, the
run-up at the end differs by only ~2e-8 m). The run-up's sensitivity to the friction is therefore small (~1e-6
m/rad), carried from the blocks through the water (the pressure waves), not the slide's run-up.
Longer horizons fail the check: at 3200 steps (0.25 s) the run-up's secants at 1e-3 and 1e-4
disagree (+3.4e-5 vs +1.9e-5, AD +1.84e-5 = the 1e-5 secant: exact but local), at 4000 steps
(0.31 s) no two secants agree; with a 0.1 m flat (the slide's signal at the beach by 0.2 s, still
only ~1e-5 m) the check fails at 2800 steps (0.22 s: AD +5.9e-5, secants +2.7e-5 and +4.0e-5). At this
horizon the blocks' own down-slope position is not checked: its 1e-3 secant is 3.5 % off AD (the
1e-4 and 1e-5 secants agree with AD).

Checked: the smooth run-up (``observables.smooth_runup``, band 2 dx, temperature dx / 4) at the
end; for ``blocks.friction_angle`` the central secants at relative steps 1e-3 and 1e-4 must agree
with each other and with AD within 2 % (``gradcheck`` verdict "ok"). Slow: ~4 min on 2 cores
(~1.5 min with the compilation cache warm).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax import Status, scenes
from rockjax.calibrate import smooth_config
from rockjax.gradcheck import gradcheck
from rockjax.observables import runup_kwargs, smooth_runup

pytestmark = pytest.mark.slow

SLOPE_DEG = 40.0
N_STEPS = 2400  # 300 blocks of 8 steps x 7.85e-5 s = 0.19 s
LEAVES = ["blocks.friction_angle"]


def tiny_rock_slope():
    return scenes.rock_slope(failure="planar", dx=0.05, slope_angle_deg=SLOPE_DEG, friction_angle_deg=20.0,
                             rock_length=0.12, rock_width=0.2, rock_thickness=0.05, bed_spacing=0.1,
                             column_spacing=0.06, lateral_spacing=0.2, start_distance=0.01, water_depth=0.2,
                             flat_length=0.4, flume_width=0.3)


def observer(scene):
    """``observe(state, params) -> [2]``: the rock blocks' mean down-slope coordinate [m] and the
    smooth run-up on the far beach [m]."""
    th = math.radians(SLOPE_DEG)
    s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])
    kw = dict(runup_kwargs(scene.meta), temperature=0.25 * float(scene.meta.dx))  # band 2 dx on the far beach
    n = scene.state.blocks.x.shape[0] - 2  # the rock blocks (then the fixed slope and floor)

    def observe(state, params):
        return jnp.stack([jnp.mean(state.blocks.x[:n] @ s_dir), smooth_runup(state, **kw)])

    return observe


@pytest.fixture(scope="module")
def event(x64):
    scene = tiny_rock_slope()
    assert scene.state.blocks.x.shape[0] - 2 == 2
    config = smooth_config(scene.config)
    return gc.event_rollout(scene, config, N_STEPS, observer(scene), 2)


def test_the_event_happens(event):
    assert event["status"] == 0, Status.describe(event["status"])
    obs = event["obs"]
    print(f"slid {obs[-1, 0] - obs[0, 0]:.4f} m; run-up {obs[0, 1]:.5f} -> min {np.min(obs[:, 1]):.5f} "
          f"-> {obs[-1, 1]:.5f} m")
    assert obs[-1, 0] - obs[0, 0] > 0.04  # the blocks slid > 4 cm down the plane, into the water
    assert obs[-1, 1] > np.min(obs[:, 1]) + 0.001  # rising (the water settling), 1 mm above its lowest
    assert obs[-1, 1] > obs[0, 1] + 0.0003  # and above its start


def test_runup_gradient_holds_at_calibration_steps(event):
    scene, f, vg, nb = event["scene"], event["f"], event["vg"], event["nb"]
    w = jnp.zeros((nb, 2)).at[-1, 1].set(1.0)
    rep = gradcheck(lambda p: f(p, w)[0], scene.params, LEAVES, steps=(1e-3, 1e-4), calibration_steps=(1e-3, 1e-4),
                    rtol=0.02, jit=False, value_and_grad=lambda p: vg(p, w))
    print("smooth run-up\n", rep)
    for c in rep.leaves:
        assert c.ad != 0.0
        assert c.verdict == "ok", f"smooth run-up d/d {c.path}: {c.row()}"
