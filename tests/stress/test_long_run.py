"""Stress: a long float32 run per scheme -- mass conserved exactly, energy within stated bounds.

Scene: a water column a x 2a (a = 0.08 m, dx = a / 4 = 0.02 m, 224 fluid particles) collapsing in
a closed-bottom tank 2a long and 4a high, as a periodic slab 7 dx wide (``scenes.dam_break`` with
``periodic_y``, the set-up of tests/physics/test_energy.py at a coarser resolution), float32,
``LONG_STEPS`` = 1e5 steps of dt = 0.25 h / c0 = 3.67e-4 s (36.7 s of physical time: the surge, the
sloshing, and ~35 s of water coming to rest). ``ROCKJAX_STRESS_LONG_STEPS`` overrides the count.

Checks, per run (WCSPH with the default Fourtakas diffusion, WCSPH with Antuono's, seed, and seed
with ``Poly6Gradient``):
* mass: the fluid mass (sum of rho0 vol over fluid particles, ``observables.fluid_mass``) at the
  end equals the start bit for bit, no particle changed kind, every fluid particle is finite and
  inside the tank (within half a spacing of its walls) -- nothing leaked or was dropped;
* energy (E = kinetic + potential + elastic, ``validation.energy_history``, in units of
  m g (2a), m the fluid mass): the impact dissipates 0.1-0.15 of it, so
  - growth above the initial energy, max_t E(t) - E(0) <= 1e-3 (as in test_energy.py);
  - rebound after a dip, max_t (E(t) - min_{s<=t} E(s)) <= 3e-3 (as in test_energy.py);
  - drift at rest over the last half of the run (the water is still): |E(end) - E(mid)| <= 1e-3,
    i.e. no slow float32 creep of energy over 5e4 steps.

What the four runs give (RESULTS.md, "WCSPH energy rebound" and "Seed scheme at rest"; the history
of the fixes in docs/notes.md): mass exact and no growth above E(0) everywhere; WCSPH with the
default ``sph.diffusion.Fourtakas`` levels off after the impact with a rebound at the 3e-3 bound (a
non-strict xfail, ``EDGE``), with ``Antuono`` well within it; the seed scheme with the paper's spiky
gradient never comes to rest (strict xfails, ``KNOWN``: the spiky gradient is not that of the poly6
summation density), with ``Poly6Gradient`` it settles within the bounds.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import fluid_mass
from rockjax.validation import energy_history

from stress_common import finite_particles

pytestmark = pytest.mark.stress

A = 0.08
DX = A / 4
LONG_STEPS = int(os.environ.get("ROCKJAX_STRESS_LONG_STEPS", "100000"))
FRAMES = 50


#: the runs: (id, scheme, WCSPH density diffusion or the seed scheme's pressure-gradient kernel)
RUNS = [("wcsph", rj.WCSPH(diffusion=rj.sph.Fourtakas())),
        ("wcsph-antuono", rj.WCSPH(diffusion=rj.sph.Antuono())),
        ("seed", rj.SeedScheme(gradient=rj.sph.SpikyGradient())),
        ("seed-poly6", rj.SeedScheme(gradient=rj.sph.Poly6Gradient()))]


def _scene(scheme):
    w = 7 * DX
    return rj.scenes.dam_break(dx=DX, column_length=A, column_width=w, column_height=2 * A, tank_length=2 * A,
                               tank_width=w, tank_height=4 * A, periodic_y=True, scheme=scheme)


@pytest.fixture(scope="module", params=RUNS, ids=lambda r: r[0])
def long_run(request):
    run, scheme = request.param
    scene = _scene(scheme)
    k = scene.config.rebuild_every
    per_frame = max(k, (LONG_STEPS // FRAMES) // k * k)
    n_frames = max(1, round(LONG_STEPS / per_frame))
    t_end = n_frames * per_frame * scene.config.dt
    res = rj.simulate(scene, t_end=t_end * (1 - 1e-9), frame_dt=per_frame * scene.config.dt, progress=False)
    e = energy_history(res)
    m = float(fluid_mass(scene.state, scene.params))
    scale = m * 9.81 * 2 * A
    tot = e["total"] / scale
    half = len(tot) // 2
    fluid = res.frames["kind"][0] == rj.Kind.FLUID
    x = res.frames["x"][-1, fluid]
    out = dict(run=run, scheme=scheme, res=res, steps=res.stats["steps"], wall=res.stats["wall_s"], m0=m,
               m1=float(fluid_mass(res.state, res.scene.params)),
               kinds_same=bool(np.array_equal(np.asarray(res.frames["kind"][0]), np.asarray(res.frames["kind"][-1]))),
               inside=bool(np.all((x[:, 0] > -DX / 2) & (x[:, 0] < 2 * A + DX / 2) & (x[:, 2] > -DX / 2)
                                  & (x[:, 2] < 4 * A))),
               growth=float(np.max(tot - tot[0])), rebound=float(np.max(tot - np.minimum.accumulate(tot))),
               late=float(abs(tot[-1] - tot[half])), lost=float(tot[0] - tot[-1]),
               ke_end=float(e["kinetic"][-1] / scale),
               rho_dev=float(np.mean(np.abs(res.frames["rho"][-1, fluid] / 1000.0 - 1.0))))
    print(f"\nlong run {run}: {out['steps']} steps ({out['steps'] * scene.config.dt:.1f} s), wall "
          f"{out['wall']:.0f} s, regrows {res.stats['regrows']}; mass {out['m0']!r} -> {out['m1']!r}; energy (m g 2a): "
          f"growth {out['growth']:.2e}, rebound {out['rebound']:.2e}, late drift {out['late']:.2e}, lost "
          f"{out['lost']:.3f}, kinetic at end {out['ke_end']:.2e}; mean |rho/rho0 - 1| at end {out['rho_dev']:.2e}; "
          f"E/(m g 2a) - E0 every {len(tot) // 10 or 1} frames: {np.round(tot - tot[0], 4)[::max(1, len(tot) // 10)].tolist()}")
    return out


def test_long_run_completes_finite(long_run):
    assert long_run["steps"] >= LONG_STEPS
    assert int(long_run["res"].state.status) == 0
    assert finite_particles(long_run["res"].state)


def test_mass_conserved_exactly(long_run):
    assert long_run["m1"] == long_run["m0"]
    assert long_run["kinds_same"]
    assert long_run["inside"]


#: measured failures (xfail strict: a fix turns them into XPASS -> failure, so this table is kept true)
KNOWN = {
    ("rebound", "wcsph"): "measured 2026-11-26 (float32, 1e5 steps): rebound 3.06e-3 > 3e-3 m g 2a (float64: 4.0e-3): "
    "after the impact the column rises into the rest state that the diffusion and the truncated kernel agree on and "
    "levels off (late drift 2.6e-4). Before the fix of 2026-11-26 (module docstring; "
    "``FourtakasSurface``) 5.6e-3 / 6.4e-3, climbing at ~1.5e-4 m g 2a per second to the end. "
    "Shrinks with resolution (float64, 16 s: 3.6e-3 / 1.9e-3 / 1.0e-3 at a/dx = 4 / 6 / 8)",
    ("rebound", "seed"): "measured 2026-11-23 (float32, 1e5 steps, two runs): rebound 2.1e-2 / 2.6e-2 > 3e-3 m g 2a: at a/dx = 4 "
    "the seed scheme's water never comes to rest in 36.7 s (kinetic 2.5e-2 m g 2a at the end, mean |rho/rho0 - 1| "
    "6.7e-2) and its total energy wanders by ~1e-2; at a/dx = 8 (2026-11-25, 18.3 s) still moving (kinetic 5.5e-3), "
    "rebound 5.9e-3. Cause (2026-11-28, module docstring): the paper's spiky pressure gradient is not the gradient "
    "of the poly6 summation density; the seed-poly6 run passes",
    ("late", "seed"): "measured 2026-11-23 (float32, 1e5 steps, two runs): |E(end) - E(mid)| = 9.7e-3 / 7.4e-3 > 1e-3 m g 2a: "
    "not at rest (kinetic 2.5e-2 / 3.0e-2 m g 2a at the end): the spiky pressure gradient (the seed-poly6 run passes)",
}


#: measured failures within rounding of their bound (a chaotic impact precedes them): non-strict xfails
EDGE = {("rebound", "wcsph")}


def _known(request, long_run, name):
    key = (name, long_run["run"])
    reason = KNOWN.get(key)
    if reason:
        request.applymarker(pytest.mark.xfail(strict=key not in EDGE, raises=AssertionError, reason=reason))


def test_energy_no_growth(long_run, request):
    _known(request, long_run, "growth")
    assert long_run["lost"] > 0.05  # the impact really dissipated (the scene is not trivial)
    assert long_run["growth"] <= 1e-3, long_run["growth"]


def test_energy_no_rebound(long_run, request):
    _known(request, long_run, "rebound")
    assert long_run["rebound"] <= 3e-3, long_run["rebound"]


def test_energy_no_drift_at_rest(long_run, request):
    _known(request, long_run, "late")
    assert long_run["late"] <= 1e-3, long_run["late"]
