"""Gradients over the wedge's whole entry with the smooth physics settings (``calibrate.smooth_config``),
checked with ``rockjax.gradcheck`` at the steps a calibration moves.

Scene: ``gradcases.tiny_wedge`` (a 0.2 m wedge on a 40 degree slope, front at the shoreline, 0.2 m
of water, 0.4 m flat, a 30 degree beach; 408 water particles; seed Eq 22 penalty coupling; joint
water on), float64, 528 steps = 0.40 s: the wedge travels 0.27 m down the slope into the water and
the wave crosses the flat and starts to run up the beach (not yet its peak: beyond ~0.45 s the
secants at these steps stop agreeing even with the smooth settings, see RESULTS.md). Observables at the end: the wedge's down-slope coordinate,
the free-surface elevation at x = 0.30 m, the smooth run-up on the beach. For the wedge's density
and friction angle and the water's artificial viscosity alpha, the central secants at relative
steps 1e-3 and 1e-4 must agree with each other and with AD within 2 % (``gradcheck`` verdict "ok").
With the sharp defaults the same checks fail at this horizon (most secants disagree by far more;
RESULTS.md "Gradients over the full event"). Slow: ~5 min on 2 cores.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax import Status
from rockjax.calibrate import smooth_config
from rockjax.gradcheck import gradcheck
from rockjax.observables import gauge_elevation, runup_kwargs, smooth_runup

pytestmark = pytest.mark.slow

N_STEPS = 528  # 66 blocks of 8 steps x 7.59e-4 s = 0.40 s
LEAVES = ["blocks.density[0]", "blocks.friction_angle", "fluid.alpha"]
OBS = ["wedge position", "gauge at 0.30 m", "smooth run-up"]


def observer(scene, config):
    meta = scene.meta
    th = math.radians(meta["slope_angle_deg"])
    s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])
    pts = jnp.asarray([[0.30, 0.5 * meta["flume_width"]]])
    bottom = jnp.asarray([max(-0.30 * math.tan(th), -meta["water_depth"])])
    kw = dict(runup_kwargs(meta), temperature=0.25 * float(meta.dx))  # band 2 dx on the far beach

    def observe(state, params):
        eta = gauge_elevation(state, params, config, pts, bottom_z=bottom, still_level=meta["still_level"])
        return jnp.stack([state.blocks.x[0] @ s_dir, eta[0], smooth_runup(state, **kw)])

    return observe


@pytest.fixture(scope="module")
def event(x64):
    scene = gc.tiny_wedge("penalty")
    config = smooth_config(scene.config)
    return gc.event_rollout(scene, config, N_STEPS, observer(scene, config), 3)


def test_the_event_happens(event):
    assert event["status"] == 0, Status.describe(event["status"])
    obs = event["obs"]
    assert obs[-1, 0] - obs[0, 0] > 0.2  # the wedge slid > 20 cm, into the water
    assert np.max(np.abs(obs[:, 1])) > 0.01  # a wave of > 1 cm passed the gauge
    assert obs[-1, 2] > obs[0, 2] + 0.004  # and is running up the beach (6 mm above its start)


@pytest.mark.parametrize("k", range(3), ids=OBS)
def test_gradient_holds_at_calibration_steps(event, k):
    scene, f, vg, nb = event["scene"], event["f"], event["vg"], event["nb"]
    w = jnp.zeros((nb, 3)).at[-1, k].set(1.0)
    rep = gradcheck(lambda p: f(p, w)[0], scene.params, LEAVES, steps=(1e-3, 1e-4), calibration_steps=(1e-3, 1e-4),
                    rtol=0.02, jit=False, value_and_grad=lambda p: vg(p, w))
    print(OBS[k], "\n", rep)
    for c in rep.leaves:
        assert c.ad != 0.0
        assert c.verdict == "ok", f"{OBS[k]} d/d {c.path}: {c.row()}"
