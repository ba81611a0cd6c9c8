"""The jointed rock slope (``scenes.rock_slope``) run into its reservoir: how the mass fails (block
motion along and normal to the slope, rotation), the wave it makes (gauges, run-up) and what the
run costs (simulated s per wall s, block-steps/s).

    python experiments/rock_slope.py --failure planar [--dx 0.0375] [--t-end 1.5] [--out experiments/results/rock_slope.jsonl]

One JSON line per run (``jsonl_out.emit``).
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import sys
import tempfile
import time

import jax
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402

import rockjax as rj  # noqa: E402
from rockjax.observables import scene_observer  # noqa: E402


def tilt_deg(q) -> np.ndarray:
    """[B] rotation angle of each block from its start (quaternions (w, x, y, z), start = identity)."""
    return np.degrees(2.0 * np.arccos(np.clip(np.abs(q[:, 0]), 0.0, 1.0)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--failure", choices=("planar", "toppling"), default="planar")
    ap.add_argument("--dx", type=float, default=0.0375, help="a whole fraction of the 0.3 m depth")
    ap.add_argument("--t-end", type=float, default=1.5)
    ap.add_argument("--frame-dt", type=float, default=0.05)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    jax.config.update("jax_compilation_cache_dir", os.path.join(os.path.dirname(__file__), "..", ".jax_cache"))
    scene = rj.scenes.rock_slope(dx=args.dx, failure=args.failure)
    n_rock = scene.meta["rock_mass"]["blocks"]
    th = math.radians(scene.meta["slope_angle_deg"])
    down = np.array([math.cos(th), 0.0, -math.sin(th)])
    normal = np.array([math.sin(th), 0.0, math.cos(th)])
    rec = dict(experiment="rock_slope", failure=args.failure, dx=args.dx, t_end=args.t_end, n_rock=n_rock,
               regime=scene.meta["hoek_bray_regime"], n_fluid=scene.counts()["fluid"], dt=scene.config.dt,
               normal_stiffness=float(scene.params.blocks.normal_stiffness))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        try:
            res = rj.simulate(scene, t_end=args.t_end, frame_dt=args.frame_dt, out=os.path.join(tmp, "r.h5"),
                              progress=False, observe=scene_observer(scene.meta))
            rec["error"] = None
        except rj.SimulationError as e:
            rec["error"] = str(e).split(".")[0]
            res = None
        wall = time.perf_counter() - t0
        run = rj.io.read(os.path.join(tmp, "r.h5"))
    x, q = run.frames["block_x"][:, :n_rock], run.frames["block_q"][:, :n_rock]
    along = (x - x[0]) @ down
    rise = (x - x[0]) @ normal
    tilt = np.stack([tilt_deg(qf) for qf in q])
    sim = float(run.time[-1])
    rec.update(simulated_s=sim, wall_s=wall, sim_s_per_wall_s=sim / wall,
               block_steps_per_s=(n_rock * sim / scene.config.dt) / wall,
               along_slope_mean_m=float(along[-1].mean()), along_slope_min_m=float(along[-1].min()),
               along_slope_max_m=float(along[-1].max()), normal_mean_m=float(rise[-1].mean()),
               tilt_median_deg=float(np.median(tilt[-1])), tilt_max_deg=float(tilt[-1].max()),
               blocks_tilted_over_10deg=int((tilt[-1] > 10).sum()), frames=len(run.time),
               date=datetime.date.today().isoformat())
    if run.observed is not None:
        g = run.observed.get("gauges")
        if g is not None:
            rec["gauge_max_m"] = [float(v) for v in np.max(g, axis=0)]
        if "runup" in run.observed:
            rec["runup_max_m"] = float(np.max(run.observed["runup"]))
    if res is not None:
        rec["steps"] = res.stats["steps"]
    emit(rec, args.out)


if __name__ == "__main__":
    main()
