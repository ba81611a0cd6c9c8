"""3D dam break (Martin & Moyce 1952, tall column n^2 = 2) for BOTH schemes.

Geometry (``rockjax.validation.dam_break_3d`` on ``scenes.dam_break``): a column a x a x 2a
spanning a tank 5a long and a wide, with real side walls (no periodic axis), as in the experiment.
Reference: data/validation/martin_moyce_1952_surge_front_n2_2.csv (Table 2, src T2; sources in its
header and data/validation/SOURCES.md). Metric: RMS relative error of Z(T) = front/a at the 13
reference times 0 < T <= 3 (T = t sqrt(2 g / a)), unshifted and after the best time shift.

About 60 s per scheme on 2 CPU cores at a/dx = 10. WCSPH runs ahead of the experiment early (the experiment's gate release; the shift absorbs it),
the seed scheme behind it late. Slow: the 2D slab version (tests/physics/test_dam_break.py) is
the default-run check of the same physics.
"""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax.validation import dam_break_3d, front_error, front_history, martin_moyce_n2_2

A = 0.1  # column width [m]
RES = 10  # a / dx at test resolution

pytestmark = pytest.mark.slow


def _errors(scheme):
    scene = dam_break_3d(a=A, resolution=RES, scheme=scheme)
    t_end = 3.05 / math.sqrt(2 * 9.81 / A)
    result = rj.simulate(scene, t_end=t_end, frame_dt=t_end / 120, progress=False)
    T, Z = front_history(result, a=A)
    Tr, Zr = martin_moyce_n2_2()
    unshifted = front_error(T, Z, Tr, Zr)
    shifted = min(front_error(T, Z, Tr, Zr, shift=s) for s in np.arange(0, 0.41, 0.02))
    fluid = result.frames["kind"][0] == rj.Kind.FLUID
    x = result.frames["x"][:, fluid]
    inside = bool(np.all((x[..., 2] > 0) & (x[..., 1] > 0) & (x[..., 1] < A) & (x[..., 0] > 0)))
    return {"unshifted": unshifted, "shifted": shifted, "inside": inside,
            "Z": np.round(np.interp(Tr, T, Z), 3).tolist(), "n_fluid": scene.counts()["fluid"]}


@pytest.fixture(scope="module")
def errors():
    out = {s: _errors(s) for s in ("wcsph", "seed")}
    for s, e in out.items():
        print(f"3D dam break a/dx={RES} ({e['n_fluid']} fluid) {s}: front RMS rel. error "
              f"{e['unshifted']:.4f} unshifted, {e['shifted']:.4f} best shift; Z: {e['Z']}")
    return out


def test_both_schemes_follow_martin_moyce_3d(errors):
    w, s = errors["wcsph"], errors["seed"]
    report = (f"wcsph {w['unshifted']:.4f} / {w['shifted']:.4f} shifted; "
              f"seed {s['unshifted']:.4f} / {s['shifted']:.4f} shifted")
    # Stated bounds at a/dx = 10 (measured values: docs/notes.md): 0.12 unshifted for
    # both schemes; 0.04 after the best shift for WCSPH, 0.10 for seed (which is not early).
    assert w["unshifted"] < 0.12, report
    assert w["shifted"] < 0.04, report
    assert s["unshifted"] < 0.12, report
    assert s["shifted"] < 0.10, report


def test_no_particle_leaves_the_tank(errors):
    assert errors["wcsph"]["inside"] and errors["seed"]["inside"]
