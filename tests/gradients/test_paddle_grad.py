"""The gradient w.r.t. a paddle's stroke through a coupled wave flume (float64).

A small ``scenes.wave_flume`` (dx = 0.06 m, depth 0.3 m, boundary-particle paddle) driven by a
regular-wave table (``blocks.paths.regular``: period 0.6 s, ramped over one period); the
paddle's path is scaled by ``Params.blocks.stroke / BlockConfig.path_stroke``. Loss: the
kinetic energy of the water after 0.3 s plus the squared elevation at a gauge 0.3 m from the
paddle. ``rockjax.gradcheck`` compares ``jax.grad`` with central secants at relative steps
1e-3 and 1e-4: both secants and AD must agree within 2 % (verdict "ok").
"""

from __future__ import annotations

import jax.numpy as jnp
import pytest

import rockjax as rj
from rockjax.blocks import paths
from rockjax.calibrate import make_loss
from rockjax.gradcheck import gradcheck
from rockjax.observables import energies, gauge_elevation

pytestmark = pytest.mark.slow


def test_stroke_gradient_through_the_flume(x64):
    sig = paths.regular(period=0.6, water_depth=0.3, duration=3.0, stroke=0.04, ramp_periods=1)
    scene = rj.scenes.wave_flume(dx=0.06, water_depth=0.3, wave="table", wave_times=list(sig.times),
                                 wave_displacement=list(sig.displacement), flat_length=1.2, period=0.6)
    n_steps = int(round(0.3 / scene.config.dt / scene.config.rebuild_every)) * scene.config.rebuild_every
    still = scene.meta["still_level"]

    def objective(state, params):
        e = energies(state, params, scene.config)
        eta = gauge_elevation(state, params, scene.config, jnp.asarray([[0.3, scene.meta["gauges"]["xy"][0][1]]]),
                              bottom_z=jnp.zeros(1), still_level=still)
        return e["kinetic"] + 100.0 * jnp.sum(eta ** 2)

    loss = make_loss(scene, n_steps, objective)
    rep = gradcheck(loss, scene.params, ["blocks.stroke"], steps=(1e-2, 1e-3, 1e-4, 1e-5))
    print(rep)
    leaf = rep["blocks.stroke"]
    assert leaf.verdict == "ok", rep
    assert abs(leaf.ad) > 0
