"""``Config.block_substeps``: n block steps of dt / n inside one step of dt (the fluid load held).

Blocks only (``block_on_incline``: a box sliding on a 30 degree incline at friction angle 20
degrees, soft contact): m steps of dt with n sub-steps are the n m steps of dt / n (0.15 s), to
float32 round-off.
"""

import jax
import numpy as np
import pytest

import rockjax as rj
from rockjax.driver import check_block_dt
from rockjax.step import advance


def _run(state, params, config, steps):
    return jax.jit(lambda s: jax.lax.fori_loop(0, steps, lambda _, s: advance(s, params, config), s))(state)


def test_substeps_equal_the_short_steps():
    scene = rj.scenes.block_on_incline(block_kwargs=dict(penalty_modulus=1e7))  # dt 1.5e-4 s
    n, m = 4, 250
    short = scene.config  # dt at the block limit
    long = short.replace(dt=n * short.dt, block_substeps=n)
    assert long.block_dt == pytest.approx(short.dt, rel=1e-12)
    check_block_dt(long, scene.params, scene.state)  # the block step, not dt, meets the limit
    with pytest.raises(ValueError, match="exceeds the block stability limit"):
        check_block_dt(long.replace(block_substeps=1), scene.params, scene.state)
    a = _run(scene.state, scene.params, short, n * m).blocks
    b = _run(scene.state, scene.params, long, m).blocks
    moved = float(np.linalg.norm(np.asarray(a.x[0] - scene.state.blocks.x[0])))
    assert moved > 1e-4, f"the box should slide ({moved} m)"
    for name in ("x", "v", "q", "omega"):
        np.testing.assert_allclose(np.asarray(getattr(b, name)), np.asarray(getattr(a, name)), rtol=0,
                                   atol=1e-5 * max(1.0, float(np.max(np.abs(np.asarray(getattr(a, name)))))),
                                   err_msg=name)


def test_substeps_must_be_a_positive_integer():
    scene = rj.scenes.block_on_incline()
    for bad in (0, 2.0, True):
        with pytest.raises(ValueError, match="Config.block_substeps must be an integer >= 1"):
            scene.config.replace(block_substeps=bad)
