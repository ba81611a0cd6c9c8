"""Piston flume (tests/coupling/test_piston.py's scene): the gauge 2 depths from the paddle with
the beach's walls as a lattice staircase or following the beach (``scenes.shapes.shell``), with
the paddle driven and (all but) still, and H/S fitted from the raw record and from the record
minus the still run's (which removes the start transient of the water on the beach).

    python experiments/piston_walls.py --out experiments/results/piston_walls.jsonl   # ~4 x 5-8 min

``--walls staircase`` swaps ``shell`` for its ``follow_faces=False`` form (the only form before
2026-11-25) in the scene builders' module. JSON lines out: one per (walls, stroke) run with the
gauge record, then one summary per walls.
"""

from __future__ import annotations

import argparse
import datetime
import os

import numpy as np

from jsonl_out import emit


def run(walls: str, stroke: float) -> dict:
    import rockjax as rj
    import rockjax.scenes.coupled as builders
    from rockjax.observables import scene_observer
    from rockjax.scenes import shapes
    from rockjax.validation import linear_wave

    builders.shell = shapes.shell if walls == "face_following" else (
        lambda *a, **k: shapes.shell(*a, **k, follow_faces=False))
    KH, DEPTH, DX, FLAT = 1.0, 0.3, 0.03, 4.0
    wave = linear_wave(KH, DEPTH)
    T, cg = wave["period"], wave["cg"]
    x_g = 2 * DEPTH
    scene = rj.scenes.piston_wavemaker(dx=DX, stroke=stroke, period=T, water_depth=DEPTH, flat_length=FLAT,
                                       beach_slope=0.3, wall_viscosity=0.0, coupling=rj.Coupling.BOUNDARY_PARTICLES,
                                       gauge_x=[x_g])
    t_end = (2 * FLAT - x_g) / cg
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    return dict(walls=walls, stroke=stroke, period=T, t_start=x_g / cg + 2 * T, t_stop=t_end,
                n_fluid=scene.config.n_fluid, n_wall=scene.config.n_wall, times=np.asarray(res.times).tolist(),
                eta=np.asarray(res.observed["gauges"][:, 0]).tolist())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", nargs="+", default=["face_following", "staircase"])
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    from rockjax.validation import piston_transfer, wave_height

    for walls in a.walls:
        driven, still = run(walls, 0.04), run(walls, 1e-5)
        for r in (driven, still):
            emit(dict(bench="piston_walls_run", **r, date=datetime.date.today().isoformat()), a.out,
                 shown={k: v for k, v in r.items() if k not in ("times", "eta")})
        t, e, e0 = np.asarray(driven["times"]), np.asarray(driven["eta"]), np.asarray(still["eta"])
        win = (t >= driven["t_start"]) & (t <= driven["t_stop"])
        H_raw = wave_height(t, e, period=driven["period"], t_start=driven["t_start"], t_stop=driven["t_stop"])[0]
        H_rel = wave_height(t, e - e0, period=driven["period"], t_start=driven["t_start"], t_stop=driven["t_stop"])[0]
        emit(dict(bench="piston_walls", walls=walls, H_over_S_raw=H_raw / 0.04, H_over_S_minus_still=H_rel / 0.04,
                  theory=piston_transfer(1.0), still_ptp_window_mm=float(np.ptp(e0[win])) * 1e3,
                  still_std_window_mm=float(np.std(e0[win])) * 1e3, date=datetime.date.today().isoformat(),
                  load=os.getloadavg()[0]), a.out)


if __name__ == "__main__":
    main()
