"""Gradients through the incompressible scheme's solves (``rockjax.DFSPH``, float64), checked with
``rockjax.gradcheck``: reverse mode through the fixed Jacobi sweeps (``iterations=n``,
``gradient="unrolled"``), and by the implicit function theorem at the result of solves run to a
tight tolerance in a ``while_loop`` (``gradient="implicit"``).

Scene (``gradcases.tiny_dam_break`` with DFSPH): a 0.3 x 0.3 x 0.5 m column at dx = 0.1 m (45
fluid particles), laminar viscosity (the default artificial term switches on approaching pairs:
a kink the secants see at 1e-3), 8 sweeps per solve, 16 steps of 0.0128 s (0.20 s of the collapse). Observable: the fluid's kinetic energy at the end
[J]; leaves: the smoothing length ``fluid.h`` and gravity's vertical component ``gravity[2]``.
Checked: the central secants at relative steps 1e-3 and 1e-4 agree with each other and with AD
within 2 % (``gradcheck`` verdict "ok"); the implicit gradient also within 1e-4 of the secants
that agree (it is the derivative of the converged solve, which the tight tolerance reaches).

Slow: the coupled wedge of ``test_coupled_grad`` (``gradcases.tiny_wedge``'s geometry, 408 water
particles, boundary-particle coupling) with ``DFSPH(iterations=8)``, laminar viscosity, the list
rebuilt every step, 20 steps of 9.3 ms (0.19 s, 13 block steps per fluid step): the wedge's
down-slope position plus 10x the gauge elevation 0.15 m beyond the shoreline at the end, w.r.t.
the wedge density and the slope's friction angle.
"""

from __future__ import annotations

import jax
import pytest

import gradcases as gc
import rockjax as rj
from rockjax.calibrate import observed, trajectory_loss
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


def test_dfsph_implicit_gradients_match_secants(x64):
    scheme = rj.DFSPH(viscosity=rj.sph.Laminar(), gradient="implicit", tolerance=1e-10, divergence_tolerance=1e-10,
                      max_iterations=1000, adjoint_iterations=400)
    scene = gc.tiny_dam_break(scheme=scheme)

    def loss(params):
        final, _ = observed(scene.config, params, N_STEPS, None, state=scene.state)
        return energies(final, params, scene.config)["kinetic"]

    report = gradcheck(loss, scene.params, ["fluid.h", "gravity[2]"], steps=(1e-3, 1e-4, 1e-5))
    print(report)
    assert report.ok, str(report)
    for leaf in report.leaves:
        fd = leaf.converged_fd
        assert fd is not None and abs(leaf.ad - fd) <= 1e-4 * abs(fd), leaf.row()


def test_reverse_mode_through_a_while_loop_solve_names_the_fix(x64):
    scene = gc.tiny_dam_break(scheme=rj.DFSPH())  # iterations=None, gradient="unrolled"

    def loss(params):
        final, _ = observed(scene.config, params, 8, None, state=scene.state)
        return energies(final, params, scene.config)["kinetic"]

    with pytest.raises(ValueError, match=r"iterations=n.*gradient='implicit'"):
        jax.grad(loss)(scene.params)


@pytest.mark.slow
def test_dfsph_coupled_wedge_gradients_match_secants(x64):
    import jax.numpy as jnp

    scene = rj.scenes.sliding_wedge(dx=0.05, slope_angle_deg=gc.WEDGE_SLOPE_DEG, block_length=0.2, block_width=0.2,
                                    water_depth=0.2, flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                    coupling=rj.Coupling.BOUNDARY_PARTICLES,
                                    scheme=rj.DFSPH(iterations=8, viscosity=rj.sph.Laminar()))
    config = scene.config.replace(rebuild_every=1)  # DFSPH's particles move ~0.4 dx a step
    n_steps = 20
    loss = trajectory_loss(config, n_steps, gc.wedge_observe(scene))
    zero = jnp.zeros((n_steps, 3))
    w = zero.at[-1, 0].set(1.0).at[-1, 1].set(10.0)
    _, (obs, status) = jax.jit(lambda p: loss(p, scene.state, zero, w, zero))(scene.params)
    assert int(status) == 0, rj.Status.describe(int(status))
    assert float(obs[-1, 0] - obs[0, 0]) > 0.05  # the wedge slid into the water
    report = gradcheck(lambda p: loss(p, scene.state, zero, w, zero)[0], scene.params,
                       ["blocks.density[0]", "blocks.friction_angle"], steps=(1e-3, 1e-4, 1e-5))
    print(report)
    assert report.ok, str(report)
