"""The piston check's tools (``rockjax.validation``) against closed forms.

* ``linear_wave``: the dispersion relation omega^2 = g k tanh(kh) and the group speed
  c_g = d omega / d k (central difference of the dispersion relation, independent of the formula).
* ``piston_transfer``: the tabulated H/S against the formula 2 (cosh 2kh - 1) / (sinh 2kh + 2kh).
* ``wave_height``: a synthetic record with known first/second harmonic heights, offset and drift.
* ``wave_phase``: synthetic progressive-wave records at several gauges give back k x.
"""

import math

import numpy as np
import pytest

from rockjax.validation import linear_wave, piston_transfer, wave_height, wave_phase


@pytest.mark.parametrize("kh", [0.3, 1.0, 2.5])
def test_linear_wave_dispersion_and_group_speed(kh):
    depth = 0.4
    w = linear_wave(kh, depth)
    k = kh / depth
    assert w["omega"] ** 2 == pytest.approx(9.81 * k * math.tanh(kh), rel=1e-12)
    dk = 1e-6 * k
    om = lambda kk: math.sqrt(9.81 * kk * math.tanh(kk * depth))  # noqa: E731
    assert w["cg"] == pytest.approx((om(k + dk) - om(k - dk)) / (2 * dk), rel=1e-6)


@pytest.mark.parametrize("kh", [0.5, 1.0, 2.0])
def test_piston_transfer_table_matches_formula(kh):
    exact = 2 * (math.cosh(2 * kh) - 1) / (math.sinh(2 * kh) + 2 * kh)
    assert piston_transfer(kh) == pytest.approx(exact, rel=2e-3)


def test_wave_height_recovers_synthetic_train():
    T = 1.3
    w = 2 * math.pi / T
    t = np.arange(0.0, 8.0, T / 24)
    eta = 0.02 * np.sin(w * t + 0.4) + 0.003 * np.cos(2 * w * t - 1.0) + 0.001 + 0.0005 * t
    H, H2, n = wave_height(t, eta, period=T, t_start=1.0, t_stop=7.0)
    assert n == 4
    assert H == pytest.approx(0.04, rel=1e-9)
    assert H2 == pytest.approx(0.006, rel=1e-9)
    assert wave_height(t, eta, period=T, t_start=1.0, t_stop=2.0)[2] == 0


def test_wave_phase_gives_the_wavenumber():
    T, k, H = 1.3, 2.7, 0.02
    w = 2 * math.pi / T
    t = np.arange(0.0, 12.0, T / 24)
    xs = np.array([0.3, 0.6, 0.9, 1.5])
    phases = []
    for x in xs:
        eta = 0.5 * H * np.cos(w * t - k * x) + 0.1 * H * np.cos(2 * (w * t - k * x)) + 1e-3 + 1e-4 * t
        phases.append(wave_phase(t, eta, period=T, t_start=2.0, t_stop=11.0))
    phases = np.unwrap(phases)
    np.testing.assert_allclose(np.diff(phases) / np.diff(xs), k, rtol=1e-6)
    assert math.isnan(wave_phase(t, np.zeros_like(t), period=T, t_start=2.0, t_stop=2.5))


def test_reflection_splits_incident_and_reflected_waves():
    # synthetic partial standing wave: incident H_I = 0.04 m, reflected 0.006 m with an arbitrary
    # phase, plus a second harmonic and noise; Mansard-Funke least squares over 4 gauges returns
    # both heights (the second harmonic and the noise are orthogonal over whole periods)
    from rockjax.validation import linear_wave, reflection

    depth, kh = 0.3, 1.0
    w = linear_wave(kh, depth)
    k, om, T = w["k"], w["omega"], w["period"]
    t = np.arange(0, 12 * T, T / 50)
    x = np.array([1.0, 1.17, 1.41, 1.6])
    rng = np.random.default_rng(0)
    eta = (0.02 * np.cos(k * x - om * t[:, None]) + 0.003 * np.cos(k * x + om * t[:, None] + 0.7)
           + 0.002 * np.cos(2 * (k * x - om * t[:, None])) + 1e-4 * rng.standard_normal((t.size, x.size)))
    r = reflection(t, eta, x, period=T, depth=depth, t_start=T, t_stop=11 * T)
    assert r["H_incident"] == pytest.approx(0.04, rel=2e-3)
    assert r["H_reflected"] == pytest.approx(0.006, rel=1e-2)
    assert r["Kr"] == pytest.approx(0.15, rel=1e-2)
    assert r["k"] == pytest.approx(k, rel=1e-9) and r["condition"] < 10
    with pytest.raises(ValueError, match="gauges"):
        reflection(t, eta[:, :1], x[:1], period=T, depth=depth, t_start=T, t_stop=11 * T)


def test_solitary_closed_forms():
    # the profile's crest moves at c = sqrt(g (d + H)); Synolakis' law at H/d = 0.02 on a 1:19.85
    # beach (his experiments' slope): R/d = 2.831 sqrt(19.85) 0.02^1.25 = 0.0949
    from rockjax.validation import solitary_profile, synolakis_runup

    x = np.linspace(0, 20, 200001)
    e0 = solitary_profile(x, 0.0, wave_height=0.03, depth=0.3, x0=5.0)
    e1 = solitary_profile(x, 2.0, wave_height=0.03, depth=0.3, x0=5.0)
    assert x[np.argmax(e0)] == pytest.approx(5.0, abs=1e-4) and e0.max() == pytest.approx(0.03)
    assert (x[np.argmax(e1)] - 5.0) / 2.0 == pytest.approx(math.sqrt(9.81 * 0.33), abs=1e-4)
    assert synolakis_runup(wave_height=0.02, depth=1.0, beach_slope=1 / 19.85) == pytest.approx(0.0949, abs=2e-4)
