"""The host driver's rebuild period: ``simulate`` with the list rebuilt at least every 8 steps (the
scenes' ``rebuild_every``, the fixed schedule a vmapped or differentiated rollout needs) vs every
32 (the driver's default), the displacement trigger on in both. JSON lines, one per run.

Runs ``scenes.dam_break`` (the peers' 3D geometry) from rest to ``--t-end`` with output every
``--frame-dt``, alternating the periods (``--periods``) so both see the same machine state; each
(size, period) is run once to compile and then ``--reps`` times timed (compiled chunks are cached
by the driver). Reports the median wall seconds (compile excluded), fluid particle-steps/s, the
load average, and each period's speed-up over the shortest one measured in the same run.

    .venv/bin/python experiments/bench_driver.py [--sizes 5k 20k] [--periods 8 32] [--reps 2]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from jsonl_out import emit

SIZES = {"5k": (14, 0.3), "20k": (22, 0.1)}  # nx, default t_end [s]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["5k", "20k"], choices=list(SIZES))
    ap.add_argument("--periods", type=int, nargs="+", default=[8, 32])
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--t-end", type=float, default=None, help="simulated time [s] (default per size)")
    ap.add_argument("--frame-dt", type=float, default=0.02)
    ap.add_argument("--out", default=None, help="also append the JSON lines to this file")
    args = ap.parse_args(argv)

    import jax

    import rockjax as rj

    for size in args.sizes:
        nx, t_default = SIZES[size]
        t_end = args.t_end or t_default
        scene = rj.scenes.dam_break(dx=0.5 / nx)
        for period in args.periods:  # compile (and warm) each variant
            rj.simulate(scene, t_end=args.frame_dt, frame_dt=args.frame_dt, progress=False, rebuild_period=period)
        walls = {p: [] for p in args.periods}
        steps = {}
        for _ in range(args.reps):
            for period in args.periods:
                t0 = time.perf_counter()
                res = rj.simulate(scene, t_end=t_end, frame_dt=args.frame_dt, progress=False, rebuild_period=period)
                walls[period].append(time.perf_counter() - t0)
                steps[period] = res.stats["steps"]
        base = statistics.median(walls[min(args.periods)])
        for period in args.periods:
            w = statistics.median(walls[period])
            rec = dict(bench="driver_rebuild_period", size=size, n_fluid=scene.config.n_fluid, t_end=t_end,
                       frame_dt=args.frame_dt, rebuild_every=scene.config.rebuild_every, rebuild_period=period,
                       steps=steps[period], wall_s=w, walls=walls[period],
                       fluid_particle_steps_per_s=scene.config.n_fluid * steps[period] / w,
                       speedup_vs_shortest_period=base / w, load=os.getloadavg()[0],
                       device=str(jax.devices()[0].platform), date=time.strftime("%Y-%m-%d"))
            emit(rec, args.out)


if __name__ == "__main__":
    main()
