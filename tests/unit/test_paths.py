"""Prescribed paths (``rockjax.blocks.paths``): spline tables and flaps against their closed forms,
the wave-maker generators against linear theory and Goring's ODE, and a PRESCRIBED block that
follows a path (with the gradient w.r.t. the stroke that scales it)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rockjax.blocks import Motion, box, make_blocks, paths
from rockjax.blocks.integrate import advance_blocks
from rockjax.blocks.rotation import quat_matrix


def _motion(path, t, scale=1.0, x0=(0.0, 0.0, 0.0), q0=(1.0, 0.0, 0.0, 0.0)):
    out = path.motion(jnp.asarray(t, jnp.float64), jnp.asarray(x0, jnp.float64), jnp.asarray(q0, jnp.float64),
                      jnp.asarray(scale, jnp.float64))
    return [np.asarray(o) for o in out]


def test_table_spline_interpolates_and_differentiates(x64):
    # a sine tabulated at 40 points per period: the clamped spline's value and velocity match the
    # sine to the spline's O(h^4) / O(h^3) error inside; velocity is the exact derivative of the
    # position (central FD); held still before and after the table
    T, A = 1.0, 0.03
    t = np.linspace(0.0, 3 * T, 121)
    u = A * np.sin(2 * np.pi * t / T) ** 2  # starts and ends at rest (clamped ends are exact)
    p = paths.Table(t, u, direction=(2.0, 0.0, 0.0))
    assert p.direction == (1.0, 0.0, 0.0) and p.stroke == pytest.approx(A, rel=1e-6)
    for tt in (0.13, 0.5, 1.27, 2.9):
        x, q, v, w = _motion(p, tt)
        exact = A * np.sin(2 * np.pi * tt / T) ** 2
        dexact = A * 2 * np.sin(2 * np.pi * tt / T) * np.cos(2 * np.pi * tt / T) * 2 * np.pi / T
        assert abs(x[0] - exact) < 2e-5 * A and abs(v[0] - dexact) < 2e-3 * A * 2 * np.pi / T
        eps = 1e-6
        fd = (_motion(p, tt + eps)[0][0] - _motion(p, tt - eps)[0][0]) / (2 * eps)
        assert v[0] == pytest.approx(fd, rel=1e-6, abs=1e-9)
        np.testing.assert_array_equal(q, [1, 0, 0, 0])
        np.testing.assert_array_equal(w, 0.0)
        np.testing.assert_array_equal(x[1:], 0.0)
    for tt in (-1.0, 3 * T + 0.5):
        x, _, v, _ = _motion(p, tt)
        assert abs(x[0]) < 1e-12 and v[0] == 0.0
    # a 3D table and the scale
    u3 = np.stack([u, 0.5 * u, -u], 1)
    p3 = paths.Table(t, u3)
    x, _, v, _ = _motion(p3, 0.4, scale=2.0)
    x1, _, v1, _ = _motion(p3, 0.4)
    np.testing.assert_allclose(x, 2 * x1, rtol=1e-14)
    np.testing.assert_allclose(x1[1], 0.5 * x1[0], rtol=1e-12)


def test_paths_compare_by_value_and_refuse_bad_tables():
    t = np.linspace(0, 1, 11)
    a, b = paths.Table(t, t ** 2), paths.Table(t.copy(), (t ** 2).copy())
    assert a == b and hash(a) == hash(b) and a != paths.Table(t, 2 * t ** 2)
    with pytest.raises(ValueError, match="strictly increasing"):
        paths.Table(t[::-1], t)
    with pytest.raises(ValueError, match="non-finite"):
        paths.Table(t, np.where(t > 0.5, np.nan, t))
    with pytest.raises(ValueError, match="one per time"):
        paths.Table(t, t[:-1])
    with pytest.raises(ValueError, match="stroke"):
        paths.Table(t, np.zeros_like(t))
    with pytest.raises(ValueError, match="Flap.angles"):
        paths.Flap(t, np.full_like(t, 2.0), hinge=(0, 0, 0))


def test_flap_rotates_about_its_hinge(x64):
    t = np.linspace(0.0, 2.0, 201)
    th = 0.2 * np.sin(np.pi * t) ** 2
    hinge = (0.1, 0.0, -0.05)
    p = paths.Flap(t, th, hinge=hinge, axis=(0, 1, 0), lever=0.3)
    assert p.stroke == pytest.approx(0.3 * np.tan(0.2), rel=1e-6)
    x0 = np.array([0.1, 0.2, 0.4])
    for tt in (0.3, 0.5, 1.1):
        x, q, v, w = _motion(p, tt, x0=x0)
        ang = 0.2 * np.sin(np.pi * tt) ** 2
        r = x0 - hinge
        # right-handed about +y: (x, z) -> (x cos + z sin, -x sin + z cos)
        expect = np.array(hinge) + [r[0] * np.cos(ang) + r[2] * np.sin(ang), r[1],
                                    -r[0] * np.sin(ang) + r[2] * np.cos(ang)]
        np.testing.assert_allclose(x, expect, atol=1e-6)
        np.testing.assert_allclose(np.asarray(quat_matrix(jnp.asarray(q))) @ r, x - hinge, atol=1e-12)
        eps = 1e-6
        fd = (_motion(p, tt + eps, x0=x0)[0] - _motion(p, tt - eps, x0=x0)[0]) / (2 * eps)
        np.testing.assert_allclose(v, fd, rtol=1e-6, atol=1e-9)
        dang = 0.2 * 2 * np.sin(np.pi * tt) * np.cos(np.pi * tt) * np.pi
        np.testing.assert_allclose(w, [0, dang, 0], atol=1e-4)


def test_linear_wavemaker_theory():
    # dispersion; Biesel's piston and flap transfer functions: H/S = kh and kh/2 in shallow water,
    # 2 in deep water; 0.982 and 0.528 at kh = 1 (linear theory's numbers quoted in the issue)
    w = np.array([1.0, 5.0, 12.0])
    k = paths.wavenumber(w, 0.3)
    np.testing.assert_allclose(w ** 2, 9.81 * k * np.tanh(k * 0.3), rtol=1e-12)
    assert paths.piston_transfer(1e-3) == pytest.approx(1e-3, rel=1e-5)
    assert paths.flap_transfer(1e-3) == pytest.approx(0.5e-3, rel=1e-3)
    assert paths.piston_transfer(20.0) == pytest.approx(2.0, rel=1e-8)
    assert paths.flap_transfer(20.0) == pytest.approx(2.0, rel=0.06)  # 2 (1 - 1/kh): slow approach
    assert paths.piston_transfer(1.0) == pytest.approx(0.982, abs=5e-4)
    assert paths.flap_transfer(1.0) == pytest.approx(0.528, abs=5e-4)


def test_regular_signal_gives_the_target_height():
    sig = paths.regular(period=1.0, water_depth=0.3, duration=8.0, wave_height=0.03, ramp_periods=2)
    kh = sig.info["kh"]
    assert sig.stroke == pytest.approx(0.03 / paths.piston_transfer(kh), rel=1e-3)
    assert sig.displacement[0] == 0.0 and abs(sig.displacement[-1]) < 1e-9
    flap = paths.regular(period=1.0, water_depth=0.3, duration=8.0, wave_height=0.03, kind="flap")
    assert flap.info["stroke"] == pytest.approx(0.03 / paths.flap_transfer(kh), rel=1e-9)
    with pytest.raises(ValueError, match="exactly one"):
        paths.regular(period=1.0, water_depth=0.3, duration=8.0)


def test_goring_solitary_paddle_follows_the_water(x64):
    # Goring (1978): the paddle moves with the depth-mean velocity under eta = H sech^2(K(ct - X)):
    # dX/dt = c eta / (d + eta); stroke 2H / (K d)
    H, d = 0.06, 0.3
    sig = paths.solitary(wave_height=H, water_depth=d)
    K, c = sig.info["K"], sig.info["celerity"]
    assert K == pytest.approx(np.sqrt(3 * H / (4 * d ** 3))) and c == pytest.approx(np.sqrt(9.81 * (d + H)))
    assert sig.stroke == pytest.approx(2 * H / (K * d), rel=1e-3)
    p = sig.piston()
    i0 = len(sig.times) // 2
    for tt in np.linspace(0.2, 0.8, 7) * sig.times[-1]:
        x, _, v, _ = _motion(p, tt)
        tc, Xc = tt - sig.times[i0], x[0] - sig.displacement[i0]
        eta = H / np.cosh(K * (c * tc - Xc)) ** 2
        assert v[0] == pytest.approx(c * eta / (d + eta), rel=2e-3)
    with pytest.raises(ValueError, match="wave_height"):
        paths.solitary(wave_height=0.25, water_depth=0.3)


def test_focused_group_focuses_and_jonswap_has_its_height():
    A, xf, tf = 0.04, 3.0, 12.0
    sig = paths.focused_group(amplitude=A, water_depth=0.4, f_min=0.6, f_max=1.4, x_focus=xf, t_focus=tf)
    f, a, ph = sig.info["freqs"], sig.info["amplitudes"], sig.info["phases"]
    k = paths.wavenumber(2 * np.pi * f, 0.4)
    t = np.linspace(0, 20, 20001)
    eta = (a[:, None] * np.cos(k[:, None] * xf - 2 * np.pi * f[:, None] * t - ph[:, None])).sum(0)
    assert t[np.argmax(eta)] == pytest.approx(tf, abs=1e-3) and eta.max() == pytest.approx(A, rel=1e-9)
    # the paddle between the tapers is the linear sum of a_n / F_n sin(omega t + phase)
    F = paths.piston_transfer(k * 0.4)
    mid = (sig.times > 4.0) & (sig.times < 10.0)
    tm = sig.times[mid]
    X = ((a / F)[:, None] * np.sin(2 * np.pi * f[:, None] * tm + ph[:, None])).sum(0)
    np.testing.assert_allclose(sig.displacement[mid] - sig.displacement[mid][0], X - X[0], atol=1e-12)
    # JONSWAP: 4 sqrt(m0) of the components is hs (less the tails outside 0.5-3 f_p); a seed
    # repeats its sea
    s1 = paths.jonswap(hs=0.05, tp=1.5, water_depth=0.4, duration=60.0, seed=3)
    s2 = paths.jonswap(hs=0.05, tp=1.5, water_depth=0.4, duration=60.0, seed=3)
    s3 = paths.jonswap(hs=0.05, tp=1.5, water_depth=0.4, duration=60.0, seed=4)
    hm0 = 4 * np.sqrt(0.5 * np.sum(s1.info["amplitudes"] ** 2))
    assert hm0 == pytest.approx(0.05, rel=0.03)
    np.testing.assert_array_equal(s1.displacement, s2.displacement)
    assert not np.allclose(s1.displacement, s3.displacement)


def test_read_csv(tmp_path):
    f = tmp_path / "paddle.csv"
    t = np.linspace(1.0, 3.0, 21)
    f.write_text("t,x\n" + "\n".join(f"{a},{0.1 + 0.01 * np.sin(a)}" for a in t))
    sig = paths.read_csv(f, water_depth=0.3)
    assert sig.times[0] == 0.0 and sig.displacement[0] == 0.0 and len(sig.times) == 21
    with pytest.raises(ValueError, match="cannot read"):
        paths.read_csv(tmp_path / "missing.csv", water_depth=0.3)


def test_block_follows_its_path_and_the_stroke_scales_it(x64):
    # a PRESCRIBED block on a Table path moves to x0 + u(t) (the advance's pose at t + dt, its
    # velocity at the mid-step); d x / d stroke = u(t) / path_stroke (a scaling), by jax.grad
    sig = paths.regular(period=0.5, water_depth=0.3, duration=2.0, stroke=0.04, ramp_periods=1)
    cfg, par, st = make_blocks([box(0.1, 0.1, 0.3)], motion=[Motion.PRESCRIBED], paths=sig.piston())
    assert cfg.path_stroke == pytest.approx(sig.stroke) and float(par.stroke) == pytest.approx(sig.stroke)
    assert hash(cfg) == hash(make_blocks([box(0.1, 0.1, 0.3)], motion=[Motion.PRESCRIBED], paths=sig.piston())[0])
    dt, t = 1e-3, 0.7

    def x_after(stroke):
        s, _ = advance_blocks(st, par.replace(stroke=stroke), cfg, dt=dt, t=t, gravity=jnp.array([0, 0, -9.81]))
        return s.x[0, 0], s.v[0, 0]

    x, v = x_after(par.stroke)
    u, _, du, _ = _motion(sig.piston(), t + dt)
    assert float(x - st.x0[0, 0]) == pytest.approx(u[0], rel=1e-12)
    assert float(v) == pytest.approx(_motion(sig.piston(), t + 0.5 * dt)[2][0], rel=1e-12)
    g = jax.grad(lambda s: x_after(s)[0])(par.stroke)
    assert float(g) == pytest.approx(u[0] / cfg.path_stroke, rel=1e-10)
    with pytest.raises(ValueError, match="paths"):
        make_blocks([box(0.1, 0.1, 0.3)], motion=[Motion.DYNAMIC], paths=[sig.piston()])
