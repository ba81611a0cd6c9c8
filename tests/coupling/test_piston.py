"""Piston wave maker against linear wave-maker theory (seed section 6's first example).

Theory: H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh) (Dean & Dalrymple 1991), tabulated in
``data/validation/piston_wavemaker_transfer.csv`` (source in its header;
``rockjax.validation.piston_transfer``). Scene: kh = 1, depth 0.3 m, stroke 0.04 m, a 2D periodic
slab, paddle with boundary particles, free-slip walls (``wall_viscosity = 0``: a lab flume's bed
boundary layer is millimetres thick), dx = 0.03 m (10 particles per depth, 63 per wavelength).
H is fitted (``rockjax.validation.wave_height``: first and second harmonic, mean and drift) at a
gauge 2 depths from the paddle (beyond the evanescent modes) over the whole periods from the
front's arrival x / c_g plus 2 periods (the train develops over a few periods after the paddle
starts: fits from the arrival itself read 2-5 % lower) until the beach reflection returns.

Tolerance: 5 % (what a wave-maker user expects of the generated height). Measured 2026-11-23
(``experiments/piston_decay.py``, this scene to 6.4 s, results in ``experiments/RESULTS.md``):
H/S = 0.871 at 2 depths (-11 %); 0.933 / 0.871 / 0.865 / 0.868 / 0.80 at 1 / 2 / 3 / 4 / 6 depths.
Neither free-slip walls (vs viscous: +0.01) nor alpha = 0.005 (vs 0.02) closes the gap; resolution
does: at dx = 0.02 m (82 min on 2 cores, too slow for a test) H/S = 0.928 / 0.909 / 0.918 / 0.851 /
0.855, the error at 2 and 3 depths falling from -11 % to -7 %, about first order in dx (Richardson
extrapolation at 2 depths: 0.985). The wave height here is 1.2 dx, far below the ~10 particles per
wave height SPH wave studies use. The train is also ~3-4 % too long: the first-harmonic phases
over the gauges at 2-6 depths (``rockjax.validation.wave_phase``, ``piston_decay.py``'s ``k_fit``)
give k = 3.24 / 3.20 1/m at dx = 0.03 / 0.02 m against linear theory's 3.33 (Stokes' third-order
speed-up at ka = 0.06 is ~1 %). Kept as a strict xfail with the number.

Slow (~17 min on 2 quiet cores): ``pytest -m slow tests/coupling/test_piston.py``.
"""

import pytest

import rockjax as rj
from rockjax.observables import scene_observer
from rockjax.validation import linear_wave, piston_transfer, wave_height

pytestmark = pytest.mark.slow

KH, DEPTH, STROKE, DX, FLAT = 1.0, 0.3, 0.04, 0.03, 4.0


@pytest.mark.xfail(strict=True, reason="measured H/S 0.871 vs 0.982 (-11 %) at 2 depths, dx = 0.03 m")
def test_piston_wave_height_matches_linear_theory():
    wave = linear_wave(KH, DEPTH)
    T, cg = wave["period"], wave["cg"]
    x_g = 2 * DEPTH
    scene = rj.scenes.piston_wavemaker(dx=DX, stroke=STROKE, period=T, water_depth=DEPTH, flat_length=FLAT,
                                       beach_slope=0.3, flume_width=7 * DX, wall_viscosity=0.0,
                                       coupling=rj.Coupling.BOUNDARY_PARTICLES, gauge_x=[x_g])
    t_reflect = (2 * FLAT - x_g) / cg  # the beach reflection is back at the gauge
    res = rj.simulate(scene, t_end=t_reflect, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    H, H2, n = wave_height(res.times, res.observed["gauges"][:, 0], period=T, t_start=x_g / cg + 2 * T,
                           t_stop=t_reflect)
    ratio, theory = H / STROKE, piston_transfer(KH)
    print(f"H/S = {ratio:.4f} over {n} periods (theory {theory:.4f}); second harmonic H2/S = {H2 / STROKE:.4f}")
    assert n >= 2
    assert abs(ratio - theory) <= 0.05 * theory, (ratio, theory)
