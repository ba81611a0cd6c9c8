"""The seed's sliding wedge with each fluid scheme: DFSPH against WCSPH on the same scene.

``sliding_wedge`` with boundary-particle coupling at ``--dx``, run to ``--t-end`` with WCSPH and
with DFSPH (``--substeps``: block steps per DFSPH step, ``Config.block_substeps``; by default the
scene's, ~13, which keeps the rock stiffness WCSPH has on the scene).
Per run one JSON line: steps, dt, wall time (compiled run; the first run's compile excluded by
timing a second), the wedge's impact speed, gauge maxima on the flat, hard and smooth run-up
maxima on the far beach, the wedge's final position. Ratios against the WCSPH run of the same
invocation follow as ``kind = "ratio"`` lines.

    python experiments/wedge_dfsph.py --dx 0.04 --t-end 1.5 --out experiments/results/wedge_dfsph.jsonl
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from jsonl_out import emit  # noqa: E402


def run(dx: float, t_end: float, scheme: str, substeps: int | None, flat_length: float, cfl: float | None = None) -> dict:
    import rockjax as rj
    from rockjax.observables import impact_velocity, scene_observer

    scene = rj.scenes.sliding_wedge(dx=dx, coupling=rj.Coupling.BOUNDARY_PARTICLES, flat_length=flat_length,
                                    scheme=scheme, block_substeps=substeps, cfl=cfl)
    kw = dict(t_end=t_end, frame_dt=0.02, observe=scene_observer(scene.meta), progress=False)
    t0 = time.perf_counter()
    rj.simulate(scene, **kw)  # compiles
    cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = rj.simulate(scene, **kw)
    wall = time.perf_counter() - t0
    obs = res.observed
    v_imp = impact_velocity(res.times, res.frames["block_x"], res.frames["block_v"], block=0, still_level=0.0,
                            bottom_offset=2.0 * scene.meta["block_height"] / 3.0)
    c = scene.config
    return {"bench": "wedge_dfsph", "scheme": scheme, "kernel": c.scheme.kernel.name,
            **({"wall_pressure": c.scheme.wall_pressure} if scheme == "dfsph" else {}),
            "h_dx": round(float(scene.params.fluid.h) / dx, 3), "block_substeps": c.block_substeps, "dx": dx,
            "n_fluid": c.n_fluid, "n_wall": c.n_wall, "cfl": c.cfl, "dt": c.dt, "block_dt": c.block_dt,
            "rock_stiffness": float(scene.params.blocks.normal_stiffness),
            "t_end": float(res.times[-1]), "steps": res.stats["steps"], "regrows": res.stats["regrows"],
            "wall_s": round(wall, 2), "wall_s_with_compile": round(cold, 2),
            "sim_s_per_wall_s": round(float(res.times[-1]) / wall, 4),
            "impact_speed": None if v_imp is None else round(float(np.linalg.norm(v_imp)), 4),
            "max_gauge": np.round(np.max(obs["gauges"], axis=0), 4).tolist(),
            "t_max_gauge": np.round(res.times[np.argmax(obs["gauges"], axis=0)], 3).tolist(),
            "t_max_smooth_runup": round(float(res.times[int(np.argmax(obs["smooth_runup"]))]), 3),
            "max_runup": round(float(np.max(obs["runup"])), 4),
            "max_smooth_runup": round(float(np.max(obs["smooth_runup"])), 4),
            "final_wedge_x": np.round(res.frames["block_x"][-1, 0], 4).tolist()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.04)
    ap.add_argument("--t-end", type=float, default=1.5)
    ap.add_argument("--substeps", type=int, default=None,
                    help="block steps per DFSPH step (default: the scene's, as many as make WCSPH's step)")
    ap.add_argument("--flat-length", type=float, default=0.5)
    ap.add_argument("--schemes", nargs="+", default=["wcsph", "dfsph"], choices=["wcsph", "dfsph"])
    ap.add_argument("--cfl", type=float, default=None, help="DFSPH's CFL number (default the scheme's, 0.4)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    meta = {"date": datetime.date.today().isoformat(), "host_cpus": os.cpu_count(), "machine": platform.machine()}
    recs = {}
    for scheme in a.schemes:
        n, cfl = (a.substeps, a.cfl) if scheme == "dfsph" else (None, None)
        try:
            recs[scheme] = dict(run(a.dx, a.t_end, scheme, n, a.flat_length, cfl), **meta)
        except Exception as exc:  # a failed run is a result too
            recs[scheme] = dict(bench="wedge_dfsph", scheme=scheme, block_substeps=n, cfl=cfl, dx=a.dx,
                                error=str(exc)[:400], **meta)
        emit(recs[scheme], a.out)
    w, d = recs.get("wcsph", {"error": "not run"}), recs.get("dfsph", {"error": "not run"})
    if "error" not in w and "error" not in d:
        rel = lambda k: round(d[k] / w[k], 4) if w.get(k) else None  # noqa: E731
        emit(dict(bench="wedge_dfsph", kind="ratio", dx=a.dx, block_substeps=d["block_substeps"], wall_time=rel("wall_s"),
                  impact_speed=rel("impact_speed"), max_runup=rel("max_runup"), max_smooth_runup=rel("max_smooth_runup"),
                  max_gauge=[round(x / y, 4) if y else None for x, y in zip(d["max_gauge"], w["max_gauge"])], **meta),
             a.out)


if __name__ == "__main__":
    main()
