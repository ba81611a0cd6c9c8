"""Gradient through a rock mass cut from joint sets (float64, blocks only) against central finite
differences at two steps that agree.

Scene: a 0.2 x 0.2 x 0.1 m slab on a fixed 30 degree slope, cut by a bedding joint (parallel to
the slope, 0.05 m spacing) and a cross joint (normal to the slope, 0.1 m) into 4 blocks
(``blocks.cutting``); friction angle 20 degrees on every contact (the joints' and the slope's),
penalty modulus 1e7 Pa (a 10x larger stable step, as ``gradcases.incline``); 400 steps. The
observable: the mean down-slope displacement of the four blocks at the end. jax.grad w.r.t.
``blocks.friction_angle`` (the joint friction) must match central differences at relative steps
1e-3 and 1e-4, which must agree with each other (else the FD proves nothing).

The water and a run-up are left out here: over the horizon a run-up needs, the gradients are
local (issue 44); this checks that the cut blocks' many contacts (block on block across the
joints, block on slope) carry an exact gradient.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax import Status
from rockjax import blocks as B
from rockjax.blocks.cutting import JointSet, cut, region
from rockjax.calibrate import get_leaf, set_leaf, trajectory_loss
from rockjax.scenes.coupled import coupled_scene

SLOPE_DEG = 30.0
STEPS = 400
REL_TOL = 0.01


def rock_mass_on_slope():
    th = math.radians(SLOPE_DEG)
    n = np.array([math.sin(th), 0.0, math.cos(th)])
    s = np.array([math.cos(th), 0.0, -math.sin(th)])  # down-slope
    domain = region([-1.0, -0.1, -1.0], [1.0, 0.1, 1.0],
                    [(np.zeros(3), -n), (0.1 * n, n), (0.1 * s, s), (-0.1 * s, -s)])
    rock = cut(domain, [JointSet(SLOPE_DEG, 90.0, 0.05), JointSet(90.0 - SLOPE_DEG, 270.0, 0.1)])
    slope = B.geometry.slope(2.0, 1.0, 0.2, SLOPE_DEG)
    scene = coupled_scene(name="rock_mass_on_slope", dx=None, polyhedra=list(rock.polyhedra) + [slope],
                          positions=np.concatenate([rock.positions, [slope.centroid_world]]),
                          motion=(B.Motion.DYNAMIC,) * rock.n_blocks + (B.Motion.FIXED,), block_density=2500.0,
                          friction_angle_deg=20.0, block_kwargs=dict(penalty_modulus=1e7))
    return scene, rock, s


@pytest.fixture(scope="module")
def setup(x64):
    scene, rock, s = rock_mass_on_slope()
    assert rock.n_blocks == 4
    n = rock.n_blocks
    s_dir = jnp.asarray(s)

    def obs_fn(state, params):
        return jnp.mean(state.blocks.x[:n] @ s_dir)[None]

    vg = jax.jit(jax.value_and_grad(trajectory_loss(scene.config, STEPS, obs_fn), has_aux=True))
    zero = jnp.zeros((STEPS, 1))
    w = zero.at[-1, 0].set(1.0)
    (value, (obs, status)), grads = vg(scene.params, scene.state, zero, w, zero)
    assert int(status) & ~int(Status.OK) == 0, Status.describe(int(status))

    def f(p):
        return vg(p, scene.state, zero, w, zero)[0][0]

    return dict(scene=scene, f=f, grads=grads, value=float(value), x0=float(np.mean(rock.positions @ s)))


def test_joint_friction_gradient_matches_fd(setup):
    scene, f = setup["scene"], setup["f"]
    moved = setup["value"] - setup["x0"]
    th, ph, t = math.radians(SLOPE_DEG), math.radians(20.0), STEPS * scene.config.dt
    sliding = 0.5 * 9.81 * (math.sin(th) - math.cos(th) * math.tan(ph)) * t**2
    # it slides (tan 20 < tan 30): at least the Coulomb closed form (a little more: the springs
    # take some steps to build the normal load, with less friction meanwhile), less than frictionless
    assert 0.95 * sliding < moved < 0.5 * 9.81 * math.sin(th) * t**2, (moved, sliding)
    path = "blocks.friction_angle"
    ad = float(get_leaf(setup["grads"], path))
    fd3 = gc.central_fd(f, scene.params, path, 1e-3, get_leaf=get_leaf, set_leaf=set_leaf)
    fd4 = gc.central_fd(f, scene.params, path, 1e-4, get_leaf=get_leaf, set_leaf=set_leaf)
    assert abs(fd3 - fd4) <= 0.1 * REL_TOL * abs(fd4), (fd3, fd4)  # the FD has converged
    assert ad < 0  # more friction, less sliding
    assert abs(ad - fd4) <= REL_TOL * abs(fd4), f"AD {ad:.6e} vs FD {fd4:.6e} (1e-3: {fd3:.6e})"
