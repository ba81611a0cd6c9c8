"""Dam break (Martin & Moyce 1952, tall column n^2 = 2) as a 2D periodic slab of the 3D code.

Reference: data/validation/martin_moyce_1952_surge_front_n2_2.csv (Table 2, src T2; sources in
its header and data/validation/SOURCES.md). Metric as in shared/peers: RMS relative error of
Z(T) = front/a at the 13 reference times 0 < T <= 3, T = t sqrt(2 g / a), unshifted and after
the best time shift (gate release). Peers on this machine (PySPH, SPlisHSPlasH, dx = a/25..a/80):
0.08-0.13 unshifted, 0.026-0.030 shifted.
"""

import math

import numpy as np

import rockjax as rj
from rockjax.validation import dam_break_2d, front_error, front_history, martin_moyce_n2_2

A = 0.1  # column width [m]
RES = 10  # a / dx at test resolution


def _errors(scheme, res=RES):
    scene = dam_break_2d(a=A, resolution=res, scheme=scheme)
    t_end = 3.05 / math.sqrt(2 * 9.81 / A)
    result = rj.simulate(scene, t_end=t_end, frame_dt=t_end / 120, progress=False)
    T, Z = front_history(result, a=A)
    Tr, Zr = martin_moyce_n2_2()
    unshifted = front_error(T, Z, Tr, Zr)
    shifted = min(front_error(T, Z, Tr, Zr, shift=s) for s in np.arange(0, 0.41, 0.02))
    print(f"{scheme}: front RMS rel. error {unshifted:.4f} unshifted, {shifted:.4f} best shift; "
          f"Z at reference T: {np.round(np.interp(Tr, T, Z), 3).tolist()}")
    return unshifted, shifted


def test_wcsph_surge_front():
    unshifted, shifted = _errors("wcsph")
    # Stated bounds at a/dx = 10 (measured values: RESULTS.md "Time vs error").
    assert unshifted < 0.10
    assert shifted < 0.04


def test_seed_surge_front():
    unshifted, shifted = _errors("seed")
    # Stated bound at a/dx = 10: 0.10 unshifted (the seed scheme's front lags the experiment late).
    assert unshifted < 0.10


def test_dfsph_surge_front():
    unshifted, shifted = _errors("dfsph", res=20)
    # Stated bounds at a/dx = 20 (its default artificial viscosity, alpha c0 h, shrinks with dx):
    # shifted as WCSPH's; unshifted 0.16, the peer DFSPH's own range (SPlisHSPlasH 0.119-0.139 at
    # a/dx 25..100: its front also leads by ~0.25 in T).
    assert unshifted < 0.16
    assert shifted < 0.04
