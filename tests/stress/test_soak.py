"""Stress: the long-run soak (issue 48) -- the coupled sliding wedge and a regular-wave flume, each
1e5 steps in float32 (``experiments/soak.py``'s ``soak``, the same runs as its record in
RESULTS.md; scenes, resolutions and the definitions of the checks in that module's docstring).

Per scene, at every one of the 1250 frames (80 steps apart):
* the run ends without a SimulationError, every particle and block value finite;
* mass: the number of FLUID particles never changes and their mass (float32 ``sum rho0 vol``,
  ``observables.fluid_mass``) equals the start bit for bit -- the fluid particles keep the first
  ``n_fluid`` slots and every one has the same volume dx^3, so the re-sorting at each list build
  feeds the sum the same values; the sum of the sorted masses (independent of any order) too;
* no particle left: zero FLUID particles more than dx/2 outside the walls (at or behind a wall's
  first particle layer; the flume's paddle face is a wall) and zero more than dx/2 inside the
  moving block (the wedge, the paddle);
* energy bounded: wedge, ``max_t E(t) - E(0) <= 1e-2 m_wedge g (z_wedge(0) + depth)`` (nothing adds
  energy); flume, ``max_t E(t) - E(0) - W(t) <= 1e-2 max |W|`` with ``W`` the paddle's work on the
  water; and the runs are not trivial (the wedge released most of its energy, the paddle put work in).

``ROCKJAX_STRESS_SOAK_STEPS`` overrides the step count (a multiple of 80).
"""

from __future__ import annotations

import os
import pathlib
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.stress

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "experiments"))
import soak as soak_mod  # noqa: E402

STEPS = int(os.environ.get("ROCKJAX_STRESS_SOAK_STEPS", str(soak_mod.STEPS)))


@pytest.fixture(scope="module", params=["wedge", "flume"])
def run(request):
    rec, series = soak_mod.soak(request.param, steps=STEPS)
    print("\n" + soak_mod.summary(rec))
    return rec, series


def test_soak_completes_finite(run):
    rec, s = run
    assert rec["steps"] == STEPS
    assert len(s["times"]) == STEPS // soak_mod.STEPS_PER_FRAME + 1
    assert bool(np.all(s["finite"])), np.nonzero(~s["finite"])[0][:5]


def test_soak_mass_exact(run):
    rec, s = run
    assert np.all(s["n_fluid"] == rec["n_fluid"]), (s["n_fluid"].min(), s["n_fluid"].max(), rec["n_fluid"])
    assert np.all(s["mass"] == s["mass"][0]), np.max(np.abs(s["mass"].astype(float) - float(s["mass"][0])))
    assert np.all(s["mass_sorted"] == s["mass_sorted"][0])


def test_soak_no_particle_leaves(run):
    rec, s = run
    bad = np.nonzero(s["outside"])[0]
    assert bad.size == 0, f"outside the walls at frames {bad[:5]} (t = {s['times'][bad[:5]]}): {s['outside'][bad[:5]]}"
    bad = np.nonzero(s["in_block"])[0]
    assert bad.size == 0, f"inside the block at frames {bad[:5]} (t = {s['times'][bad[:5]]}): {s['in_block'][bad[:5]]}"


def test_soak_energy_bounded(run):
    rec, s = run
    assert rec["growth"] <= soak_mod.GROWTH_TOL, (rec["growth"], rec["E_ref"])
    if rec["scene"] == "wedge":  # the wedge slid in and the water took and lost its energy
        assert rec["lost"] > 0.5, rec["lost"]
    else:  # the paddle made waves: net work in, and the water moved
        assert rec["paddle_work_end"] > 0.0, rec["paddle_work_end"]
        assert rec["vmax"] > 0.1, rec["vmax"]
