"""Gradient of the semi-analytical wall term (``Coupling.BOUNDARY_INTEGRAL``) with respect to the
block's pose: ``jax.grad`` of the water's load on a half-submerged box against central finite
differences, in float64, through every face of the box (parallel faces included: no NaN)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.blocks.rotation import quat_mul
from rockjax.coupling import penalty
from rockjax.scenes.coupled import block_drop


@pytest.fixture(scope="module")
def submerged(x64):
    scene = block_drop(dx=0.04, box_size=(0.12, 0.12, 0.12), tank_size=(0.4, 0.4), water_depth=0.2,
                       drop_height=0.1, coupling=rj.Coupling.BOUNDARY_INTEGRAL)
    B = scene.state.blocks
    B = B.replace(x=B.x.at[0, 2].set(0.2), v=B.v.at[0].set([0.1, -0.2, -0.3]))  # centroid at the still level
    scene = scene.replace(state=scene.state.replace(blocks=B))
    return scene, rj.prime(scene.state, scene.params, scene.config)


def test_load_gradient_matches_finite_differences(submerged):
    scene, state = submerged
    config, params = scene.config, scene.params
    P, B = state.particles, state.blocks
    assert P.x.dtype == jnp.float64
    # the guard spring (within dx/4) has kinks where a particle crosses its range: off, so the
    # check sees the wall term alone (the spring's gradient is the penalty's, tested elsewhere)
    params = params.replace(coupling=params.coupling.replace(penalty_stiffness=jnp.zeros(()), penalty_damping=jnp.zeros(())))

    def load(pose):  # pose: centroid shift [3] and a rotation vector [3] (small)
        dq = jnp.concatenate([jnp.ones(1), 0.5 * pose[3:]])
        q = B.q.at[0].set(quat_mul(dq / jnp.linalg.norm(dq), B.q[0]))
        b = B.replace(x=B.x.at[0].add(pose[:3]), q=q)
        c = penalty.load(P, b, params, config)
        return jnp.concatenate([c.force[0], c.torque[0]])

    pose0 = jnp.array([0.003, -0.002, 0.004, 0.02, -0.03, 0.01])
    assert float(jnp.abs(load(pose0)[2])) > 1.0, "the box must be loaded"
    jac = np.asarray(jax.jit(jax.jacrev(load))(pose0))
    assert np.all(np.isfinite(jac))
    eps = 1e-6
    fd = np.stack([(np.asarray(load(pose0.at[k].add(eps))) - np.asarray(load(pose0.at[k].add(-eps)))) / (2 * eps)
                   for k in range(6)], axis=1)
    scale = np.abs(fd).max()
    np.testing.assert_allclose(jac, fd, rtol=1e-5, atol=1e-6 * scale)
