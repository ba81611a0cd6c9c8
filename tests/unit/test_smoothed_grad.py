"""``ensembles.perturbed`` / ``smoothed_value_and_grad`` on a loss with dense kinks, against the
closed form of the smoothed objective's gradient.

``f(a; e) = sum_k |a + e - c_k|`` over kinks ``c_k = k delta`` (k < K) is piecewise linear in a
with a kink every ``delta``: its exact derivative is an integer that jumps by 2 at each kink. With
``e ~ N(0, sigma^2)`` the smoothed objective's derivative is ``sum_k erf((a - c_k) / (sigma
sqrt 2))``, smooth in a; the ensemble mean of the members' exact gradients must match it within
its own standard error, and the standard error must fall as 1/sqrt(n).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rockjax.ensembles import perturbed, smoothed_value_and_grad


def _register(cls):
    cls = dataclasses.dataclass(frozen=True)(cls)
    cls.replace = lambda self, **kw: dataclasses.replace(self, **kw)
    jax.tree_util.register_dataclass(cls, data_fields=[f.name for f in dataclasses.fields(cls)], meta_fields=[])
    return cls


@_register
class Par:
    a: jax.Array


@_register
class St:
    e: jax.Array
    x: jax.Array


DELTA, K, SIGMA, A = 1e-3, 200, 1e-2, 0.1003
C = jnp.arange(K) * DELTA


def loss(p, s):
    return jnp.sum(jnp.abs(p.a + s.e - C))


def closed_form_grad(a):
    return sum(math.erf((a - c) / (SIGMA * math.sqrt(2))) for c in np.arange(K) * DELTA)


def test_smoothed_gradient_matches_the_closed_form(x64):
    p = Par(jnp.asarray(A))
    s0 = St(jnp.asarray(0.0), jnp.zeros(3))
    exact = float(jax.grad(loss)(p, s0).a)
    assert exact == pytest.approx(2 * 101 - K)  # 101 kinks below a: an integer, -> sign count
    g_ref = closed_form_grad(A)
    sems = {}
    for n in (64, 256):
        states = perturbed(s0, jax.random.PRNGKey(0), n, {"e": SIGMA})
        assert states.e.shape == (n,) and not np.any(np.asarray(states.x))  # only e is perturbed
        out = smoothed_value_and_grad(loss, p, states, batch_size=None)
        g, sem = float(out.grad.a), float(out.grad_sem.a)
        assert out.n == n and sem > 0
        assert abs(g - g_ref) <= 4 * sem, (n, g, g_ref, sem)
        sems[n] = sem
    assert sems[64] / sems[256] == pytest.approx(2.0, rel=0.3)  # 1 / sqrt(n)
    assert abs(exact - g_ref) > 0.3  # the exact derivative (a step of the staircase) is not the smoothed one


def test_perturbed_indexed_leaf_and_bad_input(x64):
    s0 = St(jnp.asarray(0.0), jnp.asarray([1.0, 2.0, 3.0]))
    b = perturbed(s0, jax.random.PRNGKey(1), 5, {"x[1]": 0.5})
    x = np.asarray(b.x)
    assert x.shape == (5, 3) and np.all(x[:, [0, 2]] == [1.0, 3.0]) and np.std(x[:, 1]) > 0
    again = perturbed(s0, jax.random.PRNGKey(1), 5, {"x[1]": 0.5})
    np.testing.assert_array_equal(np.asarray(again.x), x)  # the key fixes the ensemble
    with pytest.raises(ValueError, match="n must be"):
        perturbed(s0, jax.random.PRNGKey(1), 1, {"e": 0.1})
    with pytest.raises(ValueError, match=r"sigma\['e'\]"):
        perturbed(s0, jax.random.PRNGKey(1), 4, {"e": -1.0})
    with pytest.raises(ValueError, match="no field"):
        perturbed(s0, jax.random.PRNGKey(1), 4, {"y": 1.0})
