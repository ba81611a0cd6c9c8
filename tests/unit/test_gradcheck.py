"""``rockjax.gradcheck``: the verdicts on losses whose derivatives are known in closed form.

* a smooth loss (``a^3 + sin b``): "ok", AD = 3 a^2 and cos b, every secant within its
  truncation error ``f''' h^2 / 6``;
* a loss with dense jumps (a staircase of height 1e-6 every 1e-7 added to ``a^2``): the
  derivative is 2a almost everywhere, but the secants over 1e-3 ... 1e-4 see the staircase's
  mean slope 10 more: "rough";
* a loss whose custom derivative is wrong by a factor 2: "wrong";
* float64 off: the report says so; the scan and its PNG; bad arguments are ValueErrors.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rockjax.gradcheck import VERDICTS, gradcheck


@dataclasses.dataclass(frozen=True)
class P:
    a: jax.Array
    b: jax.Array

    def replace(self, **kw):
        return dataclasses.replace(self, **kw)


jax.tree_util.register_dataclass(P, data_fields=["a", "b"], meta_fields=[])


def point():
    return P(jnp.asarray(1.3, jnp.float64), jnp.asarray(0.7, jnp.float64))


def test_smooth_loss_is_ok(x64):
    rep = gradcheck(lambda p: p.a ** 3 + jnp.sin(p.b), point(), ["a", "b"], scan_points=5)
    assert rep.x64 and rep.ok, str(rep)
    a, b = rep["a"], rep["b"]
    assert a.ad == pytest.approx(3 * 1.3 ** 2, rel=1e-12)
    assert b.ad == pytest.approx(math.cos(0.7), rel=1e-12)
    # central secant error: f''' h^2 / 6 (a: f''' = 6, h = r a)
    for r, g in zip(a.steps, a.fd):
        assert abs(g - a.ad) <= 1.0 * (r * 1.3) ** 2 + 1e-8
    assert a.converged_fd == pytest.approx(a.ad, rel=1e-6)
    assert len(a.scan[0]) == 5 and a.scan[1][2] == pytest.approx(rep.loss)
    assert "ok" in str(rep) and VERDICTS[0] == "ok"


def test_dense_jumps_are_rough(x64):
    # floor(a / 1e-7) * 1e-6: piecewise constant (derivative 0 between jumps), mean slope 10
    def loss(p):
        stairs = jax.lax.stop_gradient(jnp.floor(p.a / 1e-7) * 1e-6)
        return p.a ** 2 + stairs

    rep = gradcheck(loss, P(jnp.asarray(1.30000005), jnp.asarray(0.7)), ["a"], steps=(1e-3, 1e-4, 1e-9, 1e-10), calibration_steps=(1e-3, 1e-4))
    c = rep["a"]
    assert c.ad == pytest.approx(2.6000001, rel=1e-12)
    assert c.fd_at(1e-3) == pytest.approx(12.6, rel=1e-3)  # the staircase's slope 10 on top
    assert c.verdict == "rough", str(rep)
    assert not rep.ok


def test_wrong_derivative_is_wrong(x64):
    @jax.custom_jvp
    def cube(x):
        return x ** 3

    @cube.defjvp
    def _cube_jvp(primals, tangents):
        (x,), (t,) = primals, tangents
        return x ** 3, 6.0 * x ** 2 * t  # twice the true derivative

    rep = gradcheck(lambda p: cube(p.a) + p.b, point(), ["a", "b"])
    assert rep["a"].verdict == "wrong" and rep["b"].verdict == "ok", str(rep)
    assert rep["a"].converged_fd == pytest.approx(3 * 1.3 ** 2, rel=1e-6)


def test_float32_is_reported():
    rep = gradcheck(lambda p: p.a ** 3 + jnp.sin(p.b), P(jnp.float32(1.3), jnp.float32(0.7)), ["a"])
    assert not rep.x64 and "float32" in str(rep)


def test_plot_writes_png(x64, tmp_path):
    pytest.importorskip("matplotlib")
    rep = gradcheck(lambda p: p.a ** 3 + jnp.sin(p.b), point(), ["a"], scan_points=7, scan_width=1e-2)
    out = rep.plot(tmp_path / "scan.png")
    assert open(out, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("kwargs,match", [
    (dict(leaves=[]), "leaves is empty"),
    (dict(leaves=["a"], calibration_steps=(1e-3, 1e-7)), "calibration_steps"),
    (dict(leaves=["a"], steps=(1e-3, -1e-4)), "positive"),
    (dict(leaves=["a"], rtol=0.0), "rtol"),
    (dict(leaves=["c"]), "no field 'c'"),
])
def test_bad_arguments(x64, kwargs, match):
    with pytest.raises(ValueError, match=match):
        gradcheck(lambda p: p.a ** 2, point(), **kwargs)


def test_vector_leaf_needs_an_index(x64):
    p = P(jnp.ones(3), jnp.asarray(0.0))
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        gradcheck(lambda q: jnp.sum(q.a ** 2), p, ["a"])
    rep = gradcheck(lambda q: jnp.sum(q.a ** 2), p, ["a[1]"])
    assert rep.ok and rep["a[1]"].ad == pytest.approx(2.0)
    assert np.isfinite(rep.loss)


def test_classify_and_shared_value_and_grad(x64):
    from rockjax.gradcheck import classify

    steps = (1e-2, 1e-3, 1e-4, 1e-5)
    assert classify(2.0, steps, (2.01, 2.0001, 2.0, 2.0)) == "ok"
    assert classify(2.0, steps, (7.0, 3.0, 2.5, 2.0)) == "unresolved"  # no two successive secants agree
    assert classify(2.0, steps, (7.0, 3.0, 2.0, 2.0)) == "rough"  # the finest pair converged, to AD
    assert classify(2.0, steps, (4.0, 4.0, 4.0, 4.0)) == "wrong"
    assert classify(2.0, steps, (1.0, 3.0, -1.0, 5.0)) == "unresolved"
    with pytest.raises(ValueError, match="sorted"):
        classify(2.0, steps[::-1], (1.0, 1.0, 1.0, 1.0))
    calls = []

    def vg(p):
        calls.append(1)
        return jax.value_and_grad(lambda q: q.a ** 3 + q.b)(p)

    rep = gradcheck(lambda p: p.a ** 3 + p.b, point(), ["a", "b"], value_and_grad=vg, jit=False)
    assert rep.ok and len(calls) == 1


def test_secant_gradient_calibrates_through_a_sawtooth(x64):
    """``calibrate.secant_value_and_grad``: on ``(a - 2)^2`` plus a sawtooth of period and height
    1e-4 (local slope -1 everywhere), the exact gradient ``2 (a - 2) - 1`` leads a calibration
    astray (towards its zero a = 2.5), the secant over 1e-2 a sees the parabola's slope and finds a = 2 to within the
    loss's noise floor (|a - 2| = 0.01, where the parabola falls under the sawtooth's height)."""
    from rockjax.calibrate import calibrate, secant_value_and_grad

    def loss(p):
        saw = jax.lax.stop_gradient(jnp.floor(p.a / 1e-4) * 1e-4) - p.a
        return (p.a - 2.0) ** 2 + saw + p.b * 0.0

    vg = secant_value_and_grad(loss, ["a"], rel_step=1e-2)
    p0 = P(jnp.asarray(2.6), jnp.asarray(1.0))
    value, g = vg(p0)
    h = 1e-2 * abs(float(p0.a))
    # the secant, to within one sawtooth step (1e-4 / 2h: where x +- h falls on a step is round-off)
    fd = (float(loss(P(p0.a + h, p0.b))) - float(loss(P(p0.a - h, p0.b)))) / (2 * h)
    assert float(g.a) == pytest.approx(fd, abs=1e-4 / (2 * h) * 1.01)
    assert float(g.b) == 0.0 and float(value) == pytest.approx(float(loss(p0)))
    assert float(g.a) == pytest.approx(1.2, abs=0.01)  # 2 (a - 2); the exact derivative is 0.2
    exact = calibrate(loss, p0, ["a"], max_iter=40)
    secant = calibrate(None, p0, ["a"], value_and_grad=vg, max_iter=40)
    # the exact gradient points to its own zero a = 2.5; its line search stalls on the sawtooth's steps
    assert abs(exact.values["a"] - 2.0) > 0.05
    # to within the loss's noise floor: below |a - 2| = 0.01 the parabola (1e-4) is under the sawtooth's height
    assert abs(secant.values["a"] - 2.0) < 1e-2
    with pytest.raises(ValueError, match="rel_step"):
        secant_value_and_grad(loss, ["a"], rel_step=0.0)
