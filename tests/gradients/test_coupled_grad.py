"""Gradients through the coupled water + block rollout (float64) against finite differences.

Scene (``gradcases.tiny_wedge``): a 0.2 m wedge sliding down a 40 degree slope into 0.2 m of
water at dx = 0.05 m (408 fluid, 4390 wall particles; WCSPH; each coupling: seed Eq 22 penalty,
and boundary particles),
248 steps (0.19 s). Observables: the wedge's down-slope coordinate at the end, and the
free-surface elevation at a gauge 0.15 m beyond the shoreline; gradients w.r.t. the wedge density, the wedge-slope friction angle and
the joint water level (the scene's joint water is on), whose pressure acts on
the wet part of the wedge's face on the slope as it enters the water.

Why the horizon is not chaotic: 0.19 s covers the entry of the wedge (it moves ~8 cm, at
< 1 m/s) and the first outgoing wave; there is no breaking, no impact with the floor, no
stick/slip switching (tan 15 < tan 40); neighbour lists are under stop_gradient with a C2
compact kernel, so list changes are smooth.

Tolerance 1 % relative; slow (about 2 min for both cases on 2 cores, most of it the compile).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax import Status
from rockjax.calibrate import get_leaf, set_leaf

pytestmark = pytest.mark.slow

REL_TOL = 0.01
FD_STEP = 1e-4
FIELDS = ["blocks.density[0]", "blocks.friction_angle", "blocks.joint_water_level"]


@pytest.fixture(scope="module", params=["penalty", "boundary_particles"])
def wedge(x64, request):
    scene = gc.tiny_wedge(request.param)
    observe = gc.wedge_observe(scene)
    vg = gc.wedge_functional(scene.config, observe)
    nb = gc.WEDGE_STEPS // scene.config.rebuild_every
    zero = jnp.zeros((nb, 3))
    return dict(scene=scene, vg=vg, zero=zero)


@pytest.mark.parametrize("obs_index,name", [(0, "wedge position"), (1, "gauge elevation")])
def test_coupled_gradient_matches_fd(wedge, obs_index, name):
    scene, vg, zero = wedge["scene"], wedge["vg"], wedge["zero"]
    w = zero.at[-1, obs_index].set(1.0)
    (value, (obs, status)), grads = vg(scene.params, scene.state, zero, w, zero)
    assert int(status) == 0, Status.describe(int(status))
    obs = np.asarray(obs)
    assert obs[-1, 0] - obs[0, 0] > 0.02  # the wedge slid into the water

    def f(p):
        return vg(p, scene.state, zero, w, zero)[0][0]

    for path in FIELDS:
        ad = float(get_leaf(grads, path))
        fd = gc.central_fd(f, scene.params, path, FD_STEP, get_leaf=get_leaf, set_leaf=set_leaf)
        print(f"{name} d/d {path}: AD {ad:.8e} FD {fd:.8e} rel {abs(ad - fd) / abs(fd):.2e}")
        assert np.isfinite(ad) and ad != 0.0
        assert abs(ad - fd) <= REL_TOL * abs(fd), f"{name} d/d {path}: AD {ad:.6e} vs FD {fd:.6e}"
