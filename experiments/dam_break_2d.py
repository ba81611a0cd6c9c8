"""2D dam break (Martin & Moyce n^2 = 2) as a periodic slab: surge-front error vs wall time.

Prints one JSON line per (scheme, resolution). Usage:
    python experiments/dam_break_2d.py [--res 10 20] [--schemes wcsph seed] [--h-factor 1.5] [--3d]
``--3d`` runs the walled 3D tank of ``validation.dam_break_3d`` (column spanning the width a).

Measured 2026-11-23 (2-core CPU shared with other jobs, so wall times are upper bounds):
  2D a/dx = 10: wcsph 0.050 (0.026 shifted); seed 0.067 (the paper's scheme as printed: 0.40)
  2D a/dx = 20: seed 0.050
  3D a/dx = 10: wcsph 0.082 (0.026 shifted); seed 0.064.   3D a/dx = 8: wcsph 0.074 (0.022); seed 0.075
"""

import argparse
import json
import math
import time

import numpy as np

import rockjax as rj
from rockjax.validation import dam_break_2d, dam_break_3d, front_error, front_history, martin_moyce_n2_2


def run(scheme: str, res: int, a: float = 0.1, *, h_factor: float = 1.3, three_d: bool = False,
        seed_gradient: str = "spiky"):
    build = dam_break_3d if three_d else dam_break_2d
    # seed_gradient: the seed scheme's pressure-gradient kernel (WCSPH has none)
    fluid_scheme = rj.sph.from_names(scheme, **({"gradient": seed_gradient} if scheme == "seed" else {}))
    scene = build(a=a, resolution=res, scheme=fluid_scheme, h_factor=h_factor)
    t_end = 3.05 / math.sqrt(2 * 9.81 / a)
    t0 = time.perf_counter()
    result = rj.simulate(scene, t_end=t_end, frame_dt=t_end / 120, progress=False)
    wall = time.perf_counter() - t0
    T, Z = front_history(result, a=a)
    Tr, Zr = martin_moyce_n2_2()
    shifts = np.arange(0, 0.41, 0.02)
    errs = [front_error(T, Z, Tr, Zr, shift=s) for s in shifts]
    k = int(np.argmin(errs))
    return {"case": "dambreak3d_mm_n2_2" if three_d else "dambreak2d_mm_n2_2", "scheme": scheme, "h_factor": h_factor, "a_over_dx": res, "n_fluid": scene.counts()["fluid"],
            "n_wall": scene.counts()["wall"], "steps": result.stats["steps"], "wall_s": round(wall, 2),
            "front_rms_rel_err": round(errs[0], 4), "front_rms_rel_err_best_shift": round(errs[k], 4),
            "best_shift_T": round(float(shifts[k]), 2), "Z_sim_at_ref": np.round(np.interp(Tr, T, Z), 3).tolist(),
            "final_config": {"K": result.scene.config.neighbour_capacity, "rebuild_every": result.scene.config.rebuild_every}}


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--res", type=int, nargs="+", default=[10, 20])
    ap.add_argument("--schemes", nargs="+", default=["wcsph", "seed"])
    ap.add_argument("--h-factor", type=float, default=1.3)
    ap.add_argument("--3d", dest="three_d", action="store_true")
    args = ap.parse_args()
    for res in args.res:
        for scheme in args.schemes:
            print(json.dumps(run(scheme, res, h_factor=args.h_factor, three_d=args.three_d)), flush=True)
