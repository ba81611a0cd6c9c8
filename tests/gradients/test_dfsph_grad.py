"""Gradients through the incompressible scheme's solves (``rockjax.DFSPH(iterations=n)``, float64),
checked with ``rockjax.gradcheck``: reverse mode through the fixed, masked Jacobi sweeps (the
``while_loop`` form is forward-only).

Scene (``gradcases.tiny_dam_break`` with DFSPH): a 0.3 x 0.3 x 0.5 m column at dx = 0.1 m (45
fluid particles), laminar viscosity (the default artificial term switches on approaching pairs:
a kink the secants see at 1e-3), 8 sweeps per solve, 16 steps of 0.0128 s (0.20 s of the collapse). Observable: the fluid's kinetic energy at the end
[J]; leaves: the smoothing length ``fluid.h`` and gravity's vertical component ``gravity[2]``.
Checked: the central secants at relative steps 1e-3 and 1e-4 agree with each other and with AD
within 2 % (``gradcheck`` verdict "ok").
"""

from __future__ import annotations

import pytest

import gradcases as gc
import rockjax as rj
from rockjax.calibrate import observed
from rockjax.gradcheck import gradcheck
from rockjax.observables import energies

N_STEPS = 16


@pytest.fixture(scope="module")
def dam(x64):
    scene = gc.tiny_dam_break(scheme=rj.DFSPH(iterations=8, viscosity=rj.sph.Laminar()))
    config = scene.config

    def loss(params):
        final, _ = observed(config, params, N_STEPS, None, state=scene.state)
        return energies(final, params, config)["kinetic"]

    return scene, loss


def test_dfsph_gradients_match_secants(dam):
    scene, loss = dam
    report = gradcheck(loss, scene.params, ["fluid.h", "gravity[2]"])
    print(report)
    assert report.ok, str(report)
