"""Piston wave maker against linear wave-maker theory (seed section 6's first example).

Theory: H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh) (Dean & Dalrymple 1991), tabulated in
``data/validation/piston_wavemaker_transfer.csv`` (source in its header). Scene: kh = 1, depth
0.3 m, stroke 0.04 m, a 2D periodic slab, paddle with boundary particles, dx = 0.03 m (10
particles per depth, 63 per wavelength). H is fitted by least squares (sinusoid at the paddle
frequency + offset) over one-period windows at a gauge 2 depths from the paddle (beyond the
evanescent modes), from the front's arrival until t_end (before the beach reflection returns).

Tolerance: 5 % (what a wave-maker user expects of the generated height). Measured 2026-11-23
(``experiments/piston_decay.py``, same scene to 6 s): H/S = 0.845 at 2 depths (-14 %); the height
decays with distance, 0.884 / 0.845 / 0.807 / 0.764 / 0.694 at 1 / 2 / 3 / 4 / 6 depths
(~4 % per depth of travel): numerical damping of the wave (artificial viscosity alpha = 0.02 and
density diffusion at h/dx = 1.3 and 10 particles per depth). Kept as a strict xfail with the number.

Slow (~15-30 min on 2 cores): ``pytest -m slow tests/coupling/test_piston.py``.
"""

import math
import pathlib

import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import scene_observer

pytestmark = pytest.mark.slow

DATA = pathlib.Path(__file__).resolve().parents[2] / "data" / "validation" / "piston_wavemaker_transfer.csv"
KH, DEPTH, STROKE, DX = 1.0, 0.3, 0.04, 0.03
G = 9.81


def _theory(kh):
    rows = [ln for ln in DATA.read_text().splitlines() if ln and not ln.startswith("#") and not ln.startswith("kh")]
    tab = np.array([[float(v) for v in ln.split(",")[:2]] for ln in rows])
    return float(np.interp(kh, tab[:, 0], tab[:, 1]))


@pytest.mark.xfail(strict=True, reason="measured H/S 0.845 vs 0.982 (-14 %) at 2 depths: numerical wave damping")
def test_piston_wave_height_matches_linear_theory():
    k = KH / DEPTH
    omega = math.sqrt(G * k * math.tanh(KH))
    T = 2 * math.pi / omega
    cg = 0.5 * omega / k * (1 + 2 * KH / math.sinh(2 * KH))
    x_g = 2 * DEPTH
    scene = rj.scenes.piston_wavemaker(dx=DX, stroke=STROKE, period=T, water_depth=DEPTH, flat_length=4.0,
                                       beach_slope=0.3, flume_width=7 * DX,
                                       coupling=rj.Coupling.BOUNDARY_PARTICLES, gauge_x=[x_g])
    t_end = 4.5  # the beach reflection returns to the gauge at (2 * 4 - 0.6) / c_g = 6.4 s
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    t, eta = res.times, res.observed["gauges"][:, 0]
    heights = []
    t0 = x_g / cg
    while t0 + T <= t[-1]:
        m = (t >= t0) & (t < t0 + T)
        A = np.stack([np.sin(omega * t[m]), np.cos(omega * t[m]), np.ones(m.sum())], 1)
        c = np.linalg.lstsq(A, eta[m], rcond=None)[0]
        heights.append(2 * math.hypot(c[0], c[1]))
        t0 += 0.5 * T
    ratio = float(np.mean(heights)) / STROKE
    theory = _theory(KH)
    assert abs(ratio - theory) <= 0.05 * theory, (ratio, theory)
