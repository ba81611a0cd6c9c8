"""A linear progressive wave in a periodic box (``scenes.wave_box``) against the dispersion relation.

Scene: one wavelength (kd ~ 1) of water 0.3 m deep at dx = 0.05 m (6 layers, a = 0.4 dx, k a =
0.066), WCSPH at the wave flumes' settings (h = 1.5 dx, alpha 0.02, Fourtakas diffusion), two
periods. Closed forms: the start is linear theory's surface ``a cos(kx)`` (the gauges' first Fourier
mode within 3 % of a: the lattice's layers quantise the displaced surface); the mode turns at
``omega = sqrt(g k tanh kd)``. Stokes' second order raises omega by ~1 % at this k a; measured
+2.6 % here (+1.4 to +2.2 % at dx 0.03: ``experiments/wave_box.py``), so the check is 3 %. The
wave's decay (~9 % per period at this resolution) is reported by the experiment, not asserted.
"""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import scene_observer
from rockjax.validation import wave_mode


@pytest.fixture(scope="module")
def box():
    return rj.scenes.wave_box(dx=0.05)


def test_starts_as_the_linear_wave(box):
    m = box.meta
    assert m["kd"] == pytest.approx(1.0, abs=0.01) and m.still_level == 0.3
    obs = scene_observer(m)(box.state, box.params, box.config)
    gx = np.asarray(m.gauges.xy)[:, 0]
    fit = wave_mode([0.0, 1e-3], np.stack([obs["gauges"]] * 2), gx, k=m["k"])
    assert fit["amplitude"][0] == pytest.approx(m["amplitude"], rel=0.03)
    # the particles carry the orbit velocity: the fastest, in the top layer (z = d - dx/2) under a
    # crest, a omega cosh(k z) / sinh(kd) (the lattice's nearest column within cos(pi dx / L) of it)
    k, d, dx = m["k"], 0.3, 0.05
    u_top = m["amplitude"] * m["omega"] * math.cosh(k * (d - dx / 2)) / math.sinh(k * d)
    assert float(np.max(np.abs(np.asarray(box.state.particles.v)))) == pytest.approx(u_top, rel=4e-3)


def test_turns_at_the_dispersion_relation(box):
    m = box.meta
    T = 2 * math.pi / m["omega"]
    res = rj.simulate(box, t_end=2 * T, frame_dt=T / 16, observe=scene_observer(m), progress=False)
    gx = np.asarray(m.gauges.xy)[:, 0]
    fit = wave_mode(res.times, res.observed["gauges"], gx, k=m["k"], t_start=0.5 * T)
    print({"omega/theory": fit["omega"] / m["omega"], "decay/T": 1 - math.exp(-fit["mu"] * T)})
    assert fit["omega"] == pytest.approx(m["omega"], rel=0.03)
    assert 0.0 < fit["mu"] * T < 0.5  # it decays, and it is still a wave after two periods


def test_refuses_what_it_cannot_build():
    with pytest.raises(ValueError, match=r"wave_box: depth = 0.3 m is not a whole number of dx = 0.04 m.*0.28 m deep"):
        rj.scenes.wave_box(dx=0.04)
    with pytest.raises(ValueError, match=r"wave_box: amplitude = 0.15 m is not a linear wave"):
        rj.scenes.wave_box(dx=0.05, amplitude=0.15)


def test_settled_start_is_the_linear_wave_too():
    """``settle`` relaxes the still water first and puts the wave on the relaxed particles: the
    start is still linear theory's surface (first mode within 3 % of a) with the orbit speeds."""
    sb = rj.scenes.wave_box(dx=0.05, settle=0.2)
    m = sb.meta
    obs = scene_observer(m)(sb.state, sb.params, sb.config)
    fit = wave_mode([0.0, 1e-3], np.stack([obs["gauges"]] * 2), np.asarray(m.gauges.xy)[:, 0], k=m["k"])
    assert fit["amplitude"][0] == pytest.approx(m["amplitude"], rel=0.03)
    k, d = m["k"], 0.3
    assert float(np.max(np.abs(np.asarray(sb.state.particles.v)))) <= m["amplitude"] * m["omega"] / math.tanh(k * d)
    with pytest.raises(ValueError, match="wave_box: settle must be a time >= 0 s"):
        rj.scenes.wave_box(dx=0.05, settle=-1.0)
