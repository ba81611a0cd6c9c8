"""Energy in a closed tank: no spontaneous growth of total energy, both schemes.

Scene: a water column a x 2a (a = 0.1 m) collapsing in a tank 2a long and 4a high (the run-up on the far wall reaches 3.2a), as a 2D
periodic slab (``scenes.dam_break`` with ``periodic_y``). The surge hits the far wall at
T = t sqrt(2 g / a) ~ 1.5, runs up and falls back; the run ends at T = 3. No water leaves the
tank (checked), so the total energy E = kinetic + potential + elastic (+ the seed scheme's wall
springs; ``rockjax.validation.energy_history``) may only fall (viscosity, impact).

Bounds, in units of m g (2a) (m the fluid mass; the initial potential energy above the floor is
m g a): E(t) - E(0) <= 1e-3 and E(t) - min_{s <= t} E(s) <= ... (growth after a dip) as stated
below (3e-3 for both). The impact dissipates 0.11-0.15 m g (2a) by T = 3, so the bounds are
< 3 % of it.

Runtime ~70 s CPU for both.
"""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax.validation import energy_history

A = 0.1
#: a / dx per scheme (coarse: this runs in the default suite). The seed scheme needs 8: at a/dx = 6 its
#: energy jumped by 0.021 m g (2a) within one frame late in the run (kinetic, elastic and potential all
#: rising), a generation of energy by its non-variational pressure force (spiky gradient with a poly6
#: density, Mueller's (p_i + p_j) / 2 symmetrisation) that falls to ~1e-3 at a/dx = 8.
RES = {"wcsph": 6, "seed": 8}
T_END = 3.0


def _run(scheme):
    dx = A / RES[scheme]
    w = 7 * dx
    scene = rj.scenes.dam_break(dx=dx, column_length=A, column_width=w, column_height=2 * A, tank_length=2 * A,
                                tank_width=w, tank_height=4 * A, periodic_y=True, scheme=scheme)
    t_end = T_END / math.sqrt(2 * 9.81 / A)
    result = rj.simulate(scene, t_end=t_end, frame_dt=t_end / 32, progress=False)
    e = energy_history(result)
    m = scene.counts()["fluid"] * 1000.0 * dx**3
    scale = m * 9.81 * 2 * A
    tot = e["total"] / scale
    fluid = result.frames["kind"][0] == rj.Kind.FLUID
    x = result.frames["x"][:, fluid]
    return {"growth": float(np.max(tot - tot[0])), "rebound": float(np.max(tot - np.minimum.accumulate(tot))),
            "lost": float(tot[0] - tot[-1]), "max_kinetic": float(np.max(e["kinetic"]) / scale),
            # no particle centre behind the first wall-particle layer (dx/2 behind a wall surface)
            "inside": bool(np.all((x[..., 0] > -dx / 2) & (x[..., 0] < 2 * A + dx / 2) & (x[..., 2] > -dx / 2)
                                  & (x[..., 2] < 4 * A))),
            "z_min_dx": float(x[..., 2].min() / dx), "z_max_a": float(x[..., 2].max() / A),
            "x_out_dx": float(max(-x[..., 0].min(), x[..., 0].max() - 2 * A) / dx),
            "dE": np.round(tot - tot[0], 4).tolist()}


@pytest.fixture(scope="module", params=["wcsph", "seed"])
def run(request):
    out = _run(request.param)
    print(f"\n{request.param}: energy growth {out['growth']:.2e}, rebound {out['rebound']:.2e}, "
          f"lost {out['lost']:.3f}, lowest z {out['z_min_dx']:.3f} dx, highest z {out['z_max_a']:.2f} a, "
          f"x past a wall {out['x_out_dx']:.3f} dx, max kinetic {out['max_kinetic']:.3f} (units m g 2a); dE {out['dE']}")
    return request.param, out


def test_total_energy_never_exceeds_initial(run):
    scheme, out = run
    assert out["inside"]
    assert out["max_kinetic"] > 0.1  # the tank really sloshes (m g 2a units)
    assert out["lost"] > 0.05  # and the impact dissipates
    assert out["growth"] <= 1e-3, out["dE"]


def test_no_growth_after_a_dip(run):
    _, out = run
    assert out["rebound"] <= 3e-3, out["dE"]
