"""A layer of water at rest: does the particle lattice stay, and how steady is the pressure? (h = 1.3 vs 1.5 dx)

The benchmark-resolution hydrostatic scene of ``tests/physics/test_hydrostatic.py`` (20 particle
layers, dx = 0.01 m, an infinite layer: periodic x and y, 8 dx period; WCSPH, Adami walls), run to
``--t-end`` with frames every 0.02 s. Per smoothing length (and density diffusion) it records:

* the probe pressure over rho0 g d at depths 0.05 ... 0.17 m (``observables.probe_pressure``):
  its time mean, min and max from 0.4 s on (the test reads one frame at 0.4 s);
* the fluid's rms and max speed and the mean particle displacement from the initial lattice
  [dx], every 0.2 s -- whether the cubic lattice stays or rearranges.

JSON lines out (``--out`` appends). Nothing here is a test.

    python experiments/hydrostatic_rest.py --out experiments/results/hydrostatic_rest.jsonl
"""

from __future__ import annotations

import argparse
import datetime
import os
import time

import numpy as np

from jsonl_out import emit

DEPTH = 0.2
DEPTHS = [0.05, 0.08, 0.11, 0.14, 0.17]


def run(h_factor: float, diffusion: str, t_end: float) -> dict:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import probe_pressure

    dx = DEPTH / 20
    L = 8 * dx
    scene = rj.scenes.hydrostatic_tank(dx=dx, length=L, width=L, depth=DEPTH, h_factor=h_factor, periodic_xy=True,
                                       scheme=rj.sph.from_names("wcsph", diffusion=diffusion))
    pts = jnp.asarray([[L / 2, L / 2, DEPTH - d] for d in DEPTHS], scene.state.particles.x.dtype)
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=0.02, progress=False,
                      observe=lambda s, p, c: {"p": probe_pressure(s, p, c, pts)})
    wall = time.perf_counter() - t0
    t = np.asarray(res.times)
    ratio = np.asarray(res.observed["p"]) / (1000.0 * 9.81 * np.asarray(DEPTHS))
    fl = np.asarray(res.frames["kind"][0]) == rj.Kind.FLUID
    v = np.asarray(res.frames["v"])[:, fl]
    x = np.asarray(res.frames["x"])[:, fl]
    every = max(1, int(round(0.2 / 0.02)))
    late = t >= 0.4 - 1e-9
    at04 = int(np.argmin(np.abs(t - 0.4)))
    return {"h_factor": h_factor, "diffusion": diffusion, "dx": dx, "n_fluid": scene.config.n_fluid,
            "t_end": float(t[-1]), "wall_s": wall, "depths": DEPTHS,
            "p_ratio_at_0.4s": np.round(ratio[at04], 4).tolist(),
            "p_ratio_mean_from_0.4s": np.round(ratio[late].mean(0), 4).tolist(),
            "p_ratio_min_from_0.4s": np.round(ratio[late].min(0), 4).tolist(),
            "p_ratio_max_from_0.4s": np.round(ratio[late].max(0), 4).tolist(),
            "t_samples": np.round(t[::every], 3).tolist(),
            "v_rms": np.sqrt((v ** 2).sum(-1).mean(-1))[::every].round(5).tolist(),
            "v_max": np.abs(v).max(axis=(1, 2))[::every].round(4).tolist(),
            "mean_displacement_dx": (np.sqrt(((x - x[0]) ** 2).sum(-1)).mean(-1) / dx)[::every].round(4).tolist()}


def main():
    import rockjax as rj

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--h-factor", type=float, nargs="*", default=[1.3, 1.5])
    ap.add_argument("--diffusion", nargs="*", default=["fourtakas"], choices=rj.sph.names("diffusion"))
    ap.add_argument("--t-end", type=float, default=1.6)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    stamp = {"date": datetime.date.today().isoformat(), "load": os.getloadavg()[0]}
    for d in a.diffusion:
        for hf in a.h_factor:
            emit({**run(hf, d, a.t_end), **stamp}, a.out)


if __name__ == "__main__":
    main()
