"""Piston wave maker: wave height against distance from the paddle (numerical damping check).

Runs ``scenes.piston_wavemaker`` (kh = 1, depth 0.3 m, stroke 0.04 m, 4 m flat, periodic 2D
slab, boundary-particle paddle) with gauges at 1, 2, 3, 4 and 6 depths, and fits the wave
height H at each gauge by least squares (sinusoid at the paddle frequency + offset) over
one-period windows, shifted by half periods, from the front's arrival (x / c_g) until the beach
reflection could return. Compares H/S with linear theory (``piston_transfer.linear_theory``).
Prints one JSON line and writes ``experiments/results/piston_decay.json``.

    python experiments/piston_decay.py --dx 0.03 --t-end 6.0      # ~1.5 h CPU on 2 cores
    python experiments/piston_decay.py --from-npz run.npz          # re-analyse a saved run
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from piston_transfer import linear_theory, period_for  # noqa: E402

KH, DEPTH, STROKE, FLAT = 1.0, 0.3, 0.04, 4.0
GAUGES = [0.3, 0.6, 0.9, 1.2, 1.8]


def simulate(dx: float, coupling: str, t_end: float, npz: str, *, alpha=None, wall_viscosity=None) -> None:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import scene_observer

    T = period_for(KH, DEPTH)
    scene = rj.scenes.piston_wavemaker(dx=dx, stroke=STROKE, period=T, water_depth=DEPTH, flat_length=FLAT,
                                       beach_slope=0.3, flume_width=7 * dx, coupling=rj.Coupling(coupling),
                                       gauge_x=GAUGES)
    fl = scene.params.fluid
    fl = fl.replace(alpha=fl.alpha if alpha is None else jnp.asarray(alpha, fl.alpha.dtype),
                    wall_viscosity=fl.wall_viscosity if wall_viscosity is None
                    else jnp.asarray(wall_viscosity, fl.alpha.dtype))
    scene = scene.replace(params=scene.params.replace(fluid=fl))
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    np.savez(npz, t=res.times, eta=res.observed["gauges"], T=T, gx=GAUGES, theory=linear_theory(KH),
             wall=time.perf_counter() - t0, n=scene.config.n_fluid, dx=dx, coupling=coupling,
             load=os.getloadavg()[0], alpha=float(fl.alpha), wall_viscosity=float(fl.wall_viscosity))


def analyse(npz: str) -> dict:
    d = np.load(npz)
    t, eta, T = d["t"], d["eta"], float(d["T"])
    k = KH / DEPTH
    om = 2 * math.pi / T
    cg = 0.5 * om / k * (1 + 2 * KH / math.sinh(2 * KH))
    rows = []
    for j, x in enumerate(d["gx"]):
        t_arrive, t_reflect = x / cg, (2 * FLAT - x) / cg
        hs = []
        t0 = t_arrive
        while t0 + T <= min(t_reflect, t[-1]):
            m = (t >= t0) & (t < t0 + T)
            A = np.stack([np.sin(om * t[m]), np.cos(om * t[m]), np.ones(m.sum())], 1)
            c = np.linalg.lstsq(A, eta[m, j], rcond=None)[0]
            hs.append(2 * math.hypot(c[0], c[1]) / STROKE)
            t0 += 0.5 * T
        rows.append(dict(x=float(x), x_over_depth=float(x) / DEPTH, windows=len(hs),
                         H_over_S_mean=float(np.mean(hs)) if hs else None, H_over_S=[round(h, 4) for h in hs]))
    theory = float(d["theory"])
    for r in rows:
        r["rel_error"] = None if r["H_over_S_mean"] is None else (r["H_over_S_mean"] - theory) / theory
    return dict(kh=KH, depth=DEPTH, stroke=STROKE, period=T, dx=float(d["dx"]) if "dx" in d else None,
                coupling=str(d["coupling"]) if "coupling" in d else None, n_fluid=int(d["n"]),
                alpha=float(d["alpha"]) if "alpha" in d else 0.02,
                wall_viscosity=float(d["wall_viscosity"]) if "wall_viscosity" in d else 1.0,
                wall_s=float(d["wall"]), theory_H_over_S=theory, gauges=rows)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--t-end", type=float, default=6.0)
    ap.add_argument("--coupling", default="boundary_particles", choices=["penalty", "boundary_particles"])
    ap.add_argument("--alpha", type=float, default=None, help="artificial viscosity (default: the scene's)")
    ap.add_argument("--wall-viscosity", type=float, default=None,
                    help="viscous factor towards walls/blocks (default: the scene's; 0 = free slip)")
    ap.add_argument("--out", default=None, help="result JSON (default results/piston_decay.json)")
    ap.add_argument("--from-npz", default=None, help="analyse a saved run instead of simulating")
    ap.add_argument("--npz", default="piston_decay.npz", help="where to save the gauge records")
    a = ap.parse_args()
    npz = a.from_npz
    if npz is None:
        simulate(a.dx, a.coupling, a.t_end, a.npz, alpha=a.alpha, wall_viscosity=a.wall_viscosity)
        npz = a.npz
    rec = analyse(npz)
    print(json.dumps(rec))
    pathlib.Path(a.out or HERE / "results" / "piston_decay.json").write_text(json.dumps(rec, indent=1) + "\n")


if __name__ == "__main__":
    main()
