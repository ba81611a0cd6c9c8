"""``scenes.settle``: the water of a wave flume relaxed before its run, the clock restarted.

A tiny piston flume (dx = 0.05 m, depth 0.2 m, a 0.3 beach) starts as a cubic lattice that slumps
along the sloping walls. After ``settle`` the water must be nearer rest than the same flume left
to run as long without it (kinetic energy), the clock at zero, the Params and the paddle's pose
those of the input, and the run from it must start cleanly. Bad input is refused early.
"""

from __future__ import annotations

import jax
import numpy as np
import pytest

import rockjax as rj

T_SETTLE = 0.6


def _flume(stroke=1e-9):
    return rj.scenes.piston_wavemaker(dx=0.05, stroke=stroke, period=1.0, water_depth=0.2, flat_length=0.6,
                                      beach_slope=0.3, coupling=rj.Coupling.BOUNDARY_PARTICLES,
                                      wall_viscosity=0.0)


@pytest.fixture(scope="module")
def settled():
    scene = _flume()
    return scene, rj.scenes.settle(scene, t_settle=T_SETTLE)


def test_settled_water_is_nearer_rest(settled):
    scene, out = settled
    free = rj.simulate(scene, t_end=T_SETTLE, frame_dt=T_SETTLE, progress=False)  # no damping, paddle still
    ke = {}
    for name, state in (("settled", out.state), ("free", free.state)):
        fluid = np.asarray(state.particles.kind) == rj.Kind.FLUID
        ke[name] = 0.5 * float(np.sum(np.asarray(state.particles.v)[fluid] ** 2))  # per unit particle mass
    print(f"kinetic energy after {T_SETTLE} s, m^2/s^2 summed over particles: {ke}")
    assert ke["free"] > 0  # the lattice does move when left alone
    assert ke["settled"] < 0.25 * ke["free"], ke
    assert int(out.state.step) == 0 and int(out.state.status) == 0
    n_water = [int(np.sum(np.asarray(s.particles.kind) == rj.Kind.FLUID)) for s in (scene.state, out.state)]
    assert n_water[0] == n_water[1]


def test_params_and_paddle_unchanged(settled):
    scene, out = settled
    for a, b in zip(jax.tree.leaves(out.params), jax.tree.leaves(scene.params)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    np.testing.assert_allclose(np.asarray(out.state.blocks.x), np.asarray(scene.state.blocks.x), atol=1e-9)
    res = rj.simulate(_flume(stroke=0.02).replace(config=out.config, state=out.state), t_end=0.1, frame_dt=0.05,
                      progress=False)
    assert int(res.state.status) == 0 and res.stats["steps"] > 0


@pytest.mark.parametrize("kw, field", [(dict(t_settle=0.0), "t_settle"), (dict(t_settle=float("nan")), "t_settle"),
                                       (dict(t_settle=1.0, alpha=0.0), "alpha")])
def test_bad_input_is_refused(kw, field):
    with pytest.raises(ValueError, match=field):
        rj.scenes.settle(_flume(), **kw)


def test_dynamic_blocks_are_refused():
    scene = rj.scenes.floating_box(dx=0.04)
    with pytest.raises(ValueError, match="DYNAMIC"):
        rj.scenes.settle(scene, t_settle=1.0)
