"""Calibration over the full event: the wedge's density and friction angle from 0.8 s of records.

Scene: ``gradcases.tiny_wedge`` with ``calibrate.smooth_config``, float64, 1056 steps = 0.80 s (the
wedge slides 0.36 m into the water, the wave runs up the far beach). Synthetic records of the
wedge's down-slope coordinate, the free-surface elevation at x = 0.30 m and the smooth run-up after
every 8 steps, from a truth of 2800 kg/m^3 and 10 degrees; the fit starts 20 % off (3360 kg/m^3,
8 degrees) and runs ``calibrate.calibrate`` (L-BFGS in log space) on the mean squared relative
misfit with ``calibrate.secant_value_and_grad`` (the slope over 1 % of each field: over this
horizon the exact gradient is local, see ``test_full_event.py``). Both fields must come within 2 %
of the truth. Slow: ~5 min on 2 cores (the fit takes ~30 evaluations of 5 forward runs each).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax.calibrate import calibrate, observed, secant_value_and_grad, set_leaf, smooth_config
from test_full_event import observer

pytestmark = pytest.mark.slow

N_STEPS = 1056
FIELDS = ["blocks.density[0]", "blocks.friction_angle"]


def test_density_and_friction_from_the_full_event(x64):
    scene = gc.tiny_wedge("penalty")
    config = smooth_config(scene.config)
    observe = observer(scene, config)
    run = jax.jit(lambda p: observed(config, p, N_STEPS, observe, state=scene.state)[1])
    truth = set_leaf(set_leaf(scene.params, FIELDS[0], 2800.0), FIELDS[1], math.radians(10.0))
    data = np.asarray(run(truth))
    s0 = np.asarray(observe(scene.state, scene.params))
    rms = np.sqrt(np.mean((data - s0[None, :]) ** 2, axis=0))
    assert data[-1, 0] - s0[0] > 0.3 and data[-1, 2] > s0[2] + 0.02  # the full event: slide and run-up
    w = jnp.asarray(np.broadcast_to(1.0 / (data.size * rms ** 2), data.shape))
    target = jnp.asarray(data)

    def loss(p):
        return jnp.sum(w * (run(p) - target) ** 2)

    start = set_leaf(set_leaf(truth, FIELDS[0], 1.2 * 2800.0), FIELDS[1], 0.8 * math.radians(10.0))
    res = calibrate(None, start, FIELDS, value_and_grad=secant_value_and_grad(loss, FIELDS, rel_step=1e-2),
                    max_iter=12, tol_loss=1e-14)
    err = {f: res.values[f] / v - 1 for f, v in ((FIELDS[0], 2800.0), (FIELDS[1], math.radians(10.0)))}
    print(res.n_iter, res.n_evals, err)
    assert res.loss_path[-1] < 1e-3 * res.loss_path[0]
    for f, e in err.items():
        assert abs(e) < 0.02, f"{f}: {e:+.2%} after {res.n_iter} iterations"
