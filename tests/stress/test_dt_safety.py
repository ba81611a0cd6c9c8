"""Stress: time-step safety (issue 7).

* a Config.dt above the stability limit is refused on the host, before any step, with a
  ValueError naming the field (fluid CFL / viscous limit; blocks: seed Eq 8);
* a run made unstable by changing Params under a fixed dt -- a change the host check lets through
  because it depends on the flow speed reached later -- sets ``Status.UNSTABLE_DT`` inside jit and
  ``simulate`` stops with a SimulationError naming the step;
* Params that make the blocks' contact too stiff for the dt, stepped without the driver (e.g. by a
  user's own scan), set ``Status.BLOCK_UNSTABLE`` at the first step.
"""

from __future__ import annotations


import jax
import pytest

import rockjax as rj

pytestmark = pytest.mark.stress

A = 0.1


@pytest.fixture(scope="module")
def dam():
    dx = A / 4
    return rj.scenes.dam_break(dx=dx, column_length=A, column_width=7 * dx, column_height=2 * A,
                               tank_length=2 * A, tank_width=7 * dx, tank_height=4 * A, periodic_y=True)


def test_dt_above_limit_refused_on_host(dam):
    bad = dam.replace(config=dam.config.replace(dt=3.0 * dam.config.dt))
    with pytest.raises(ValueError, match=r"Config\.dt .* exceeds the stability limit"):
        rj.simulate(bad, t_end=0.01, progress=False)


def test_block_dt_above_limit_refused_on_host():
    scene = rj.scenes.block_on_incline()
    bad = scene.replace(config=scene.config.replace(dt=2.5 * scene.config.dt))
    with pytest.raises(ValueError, match=r"Config\.dt .* block stability limit"):
        rj.simulate(bad, t_end=0.01, progress=False)
    stiff = scene.replace(params=scene.params.replace(blocks=scene.params.blocks.replace(
        normal_stiffness=20.0 * scene.params.blocks.normal_stiffness)))
    with pytest.raises(ValueError, match=r"block stability limit"):
        rj.simulate(stiff, t_end=0.01, progress=False)


def test_params_change_under_fixed_dt_stops_with_step(dam):
    """Speed of sound raised x1.98 under the scene's dt (0.25 h / c0): the host check (which allows
    dt <= 0.5 h / c0 at rest) passes, but the in-jit limit dt <= 0.5 h / (c0 + v_max) fails as soon
    as the collapsing column reaches 0.02 c0 = 0.4 m/s. The driver must stop with a SimulationError
    naming the step and UNSTABLE_DT -- not run on. The step named is the first that set the bit
    (each chunk carries the index of its first fatal step): checked here by stepping by hand from the
    start -- the step before it is clean."""
    f = dam.params.fluid
    params = dam.params.replace(fluid=f.replace(c0=1.98 * f.c0))
    scene = dam.replace(params=params)
    rj.scenes.check_params(scene.config, scene.params)  # the host lets it through
    with pytest.raises(rj.SimulationError) as err:
        rj.simulate(scene, t_end=0.2, progress=False)
    e = err.value
    print(f"\nunstable run: {e}")
    assert e.status & rj.Status.UNSTABLE_DT, rj.Status.describe(e.status)
    assert 0 < e.step and f"step {e.step}" in str(e)
    t_stop = e.step * scene.config.dt
    assert 0.0 < t_stop < 0.1, t_stop  # stopped early in the collapse, not at the end
    # by hand: the bit first appears at e.step
    import jax

    one = jax.jit(rj.make_step(scene.config))
    s = rj.prime(scene.state, scene.params, scene.config)
    first = None
    for _ in range(e.step):
        s = one(s, scene.params)
        if int(s.status) & rj.Status.UNSTABLE_DT:
            first = int(s.step)
            break
    assert first == e.step, (first, e.step)


def test_block_params_too_stiff_set_status_in_jit():
    scene = rj.scenes.block_on_incline()
    stiff = scene.params.replace(blocks=scene.params.blocks.replace(
        normal_stiffness=20.0 * scene.params.blocks.normal_stiffness))
    s = jax.jit(rj.make_step(scene.config))(scene.state, stiff)
    bits = int(s.status)
    assert bits & rj.Status.BLOCK_UNSTABLE, rj.Status.describe(bits)
    s_ok = jax.jit(rj.make_step(scene.config))(scene.state, scene.params)
    assert not int(s_ok.status) & rj.Status.BLOCK_UNSTABLE
