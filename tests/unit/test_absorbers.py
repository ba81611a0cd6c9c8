"""Absorbing zones (``rockjax.sph.absorbers``): the sponge's damping against its closed form,
its validation, and its place in a step (only what ``Config.absorbers`` lists is traced)."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.sph import Sponge
from rockjax.types import Kind


def test_sponge_damps_as_its_formula():
    # v <- v / (1 + sigma dt), sigma = strength s^2, s the fraction of the way from start to end
    sp = Sponge(start=(1.0, 0.0, 0.0), end=(3.0, 0.0, 0.0), strength=8.0)
    assert sp.length == 2.0
    x = jnp.array([[0.5, 0, 0], [1.0, 0, 0], [2.0, 0.3, -1], [2.5, 0, 0], [4.0, 0, 0], [2.0, 0, 0]])
    v = jnp.ones((6, 3))
    kind = jnp.array([Kind.FLUID] * 5 + [Kind.WALL], jnp.int32)

    class P:  # the fields apply() reads, and replace()
        def __init__(self, x, v, kind):
            self.x, self.v, self.kind = x, v, kind

        def replace(self, v):
            return P(self.x, v, self.kind)

    dt = 0.01
    out = sp.apply(P(x, v, kind), dt)
    sigma = 8.0 * np.array([0.0, 0.0, 0.5, 0.75, 1.0]) ** 2
    expect = 1.0 / (1.0 + sigma * dt)
    np.testing.assert_allclose(np.asarray(out.v[:5, 0]), expect, rtol=1e-6)
    np.testing.assert_array_equal(np.asarray(out.v[5]), 1.0)  # walls untouched
    np.testing.assert_allclose(np.asarray(sp.sigma(x))[:5], sigma, rtol=1e-6)


def test_sponge_and_config_refuse_bad_input():
    with pytest.raises(ValueError, match="end must differ"):
        Sponge(start=(1, 0, 0), end=(1, 0, 0))
    with pytest.raises(ValueError, match="strength"):
        Sponge(start=(0, 0, 0), end=(1, 0, 0), strength=-1.0)
    with pytest.raises(ValueError, match="Sponge.start"):
        Sponge(start=(0, 0), end=(1, 0, 0))
    scene = rj.scenes.piston_wavemaker(dx=0.1)
    with pytest.raises(ValueError, match="Config.absorbers"):
        scene.config.replace(absorbers=[Sponge(start=(0, 0, 0), end=(1, 0, 0))])
    with pytest.raises(ValueError, match="sponge_length"):
        rj.scenes.piston_wavemaker(dx=0.1, flat_length=2.0, sponge_length=2.5)
    s = rj.scenes.piston_wavemaker(dx=0.1, flat_length=2.0, sponge_length=0.8, sponge_strength=5.0)
    (sp,) = s.config.absorbers
    assert sp.start == (1.2, 0.0, 0.0) and sp.end == (2.0, 0.0, 0.0) and sp.strength == 5.0
    assert s.meta["sponge"] == dict(start=1.2, end=2.0, strength=5.0)
