"""Solitary wave from Goring's piston path: shape and celerity after 10 depths, and run-up on a
plane beach against Synolakis (1987).

``scenes.wave_flume(wave="solitary")``: depth d = 0.3 m, a flat of 14 d, then a plane beach of
slope ``--beach-slope`` (default tan 20 deg, non-breaking up to H/d ~ 0.27 by Synolakis'
criterion H/d < 0.818 (cot beta)^(-10/9)). Gauges at 2, 5 and 10 depths record the wave:

* crest height at each gauge against the target H;
* celerity from the crest arrival times between 5 and 10 depths against c = sqrt(g (d + H));
* shape at 10 depths: the RMS difference, over |t - t_crest| < 2 / (K c), between the record and
  the Boussinesq profile H sech^2(K c (t - t_crest)) of the same height H, relative to H;
* maximum run-up (``observables.runup``: the highest water particle within 2 dx of the beach)
  against R / d = 2.831 sqrt(cot beta) (H / d)^1.25, for the target H and for the crest height
  measured at 10 depths (the wave that reaches the toe 4 depths later: the law's own check,
  apart from the generation).

One JSON line per run, appended to ``results/solitary_runup.jsonl``.

    python experiments/solitary_runup.py --dx 0.03 --height-ratio 0.2      # ~5 min on 2 quiet cores
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import time

import numpy as np
from jsonl_out import emit

HERE = pathlib.Path(__file__).resolve().parent
DEPTH = 0.3


def run(dx: float, ratio: float, beach_slope: float, alpha: float, t_after: float, *, laminar: bool = False,
        wall_viscosity: float = 1.0, settle: float = 0.0) -> dict:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.blocks import paths
    from rockjax.observables import scene_observer
    from rockjax.validation import solitary_profile, synolakis_runup

    H = ratio * DEPTH
    gx = [2 * DEPTH, 5 * DEPTH, 10 * DEPTH]  # the paddle itself advances 1 d (its stroke) at H/d = 0.2
    flat = 14 * DEPTH  # the last gauge 4 depths before the toe: clear of the beach's reflection
    # the water's laminar viscosity (nu 1e-6, wave_flume's default) or Monaghan's artificial one
    scheme = rj.WCSPH(viscosity=rj.sph.Laminar()) if laminar else rj.WCSPH()
    scene = rj.scenes.wave_flume(dx=dx, water_depth=DEPTH, wave="solitary", wave_height=H, flat_length=flat,
                                 beach_slope=beach_slope, gauge_x=gx, alpha=alpha, scheme=scheme)
    fl = scene.params.fluid
    fl = fl.replace(wall_viscosity=jnp.asarray(wall_viscosity, fl.alpha.dtype), nu=jnp.asarray(1e-6, fl.nu.dtype))
    scene = scene.replace(params=scene.params.replace(fluid=fl))
    if settle > 0:  # relax the start lattice first (its slump sends a depression wave along the flat)
        scene = rj.scenes.settle(scene, t_settle=settle)
    sig = paths.solitary(wave_height=H, water_depth=DEPTH)
    K, c = sig.info["K"], sig.info["celerity"]
    # the crest leaves the paddle at about t_crest_at_paddle and reaches the toe flat / c later
    t_toe = sig.info["t_crest_at_paddle"] + flat / c
    t_end = t_toe + t_after
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=0.01, observe=scene_observer(scene.meta), progress=False)
    wall = time.perf_counter() - t0
    t = np.asarray(res.times)
    eta = np.asarray(res.observed["gauges"])
    ru = np.asarray(res.observed["runup"])
    crests, t_crest = [], []
    for j, x in enumerate(gx):
        # the incident crest: the maximum before the beach reflection could return to the gauge
        t_back = t_toe + (flat - x) / c
        m = t < t_back
        i = int(np.argmax(np.where(m, eta[:, j], -np.inf)))
        # parabolic refinement of the crest time and height on the 0.01 s frames
        if 0 < i < len(t) - 1:
            y0, y1, y2 = eta[i - 1, j], eta[i, j], eta[i + 1, j]
            den = y0 - 2 * y1 + y2
            s = 0.5 * (y0 - y2) / den if den != 0 else 0.0
            crests.append(float(y1 - 0.25 * (y0 - y2) * s))
            t_crest.append(float(t[i] + s * (t[1] - t[0])))
        else:
            crests.append(float(eta[i, j]))
            t_crest.append(float(t[i]))
    cel = (gx[2] - gx[1]) / (t_crest[2] - t_crest[1])
    win = np.abs(t - t_crest[2]) < 2.0 / (K * c)
    Hm = crests[2]
    prof = solitary_profile(0.0, -(t[win] - t_crest[2]), wave_height=Hm, depth=DEPTH)
    shape_rms = float(np.sqrt(np.mean((eta[win, 2] - prof) ** 2)) / Hm)
    R = float(np.max(ru))
    R_theory = synolakis_runup(wave_height=H, depth=DEPTH, beach_slope=beach_slope)
    R_measured_H = synolakis_runup(wave_height=Hm, depth=DEPTH, beach_slope=beach_slope)
    return dict(dx=dx, depth=DEPTH, H=H, H_over_d=ratio, beach_slope=beach_slope, alpha=alpha,
                viscosity="laminar 1e-6" if laminar else "artificial", wall_viscosity=wall_viscosity, settle_s=settle,
                H_over_dx=H / dx, depth_over_dx=DEPTH / dx,
                gauges=gx, crest=crests, crest_over_H=[cr / H for cr in crests], t_crest=t_crest,
                celerity=cel, celerity_theory=c, celerity_rel_error=cel / c - 1,
                shape_rms_over_H=shape_rms, runup=R, runup_synolakis=R_theory, runup_rel_error=R / R_theory - 1,
                runup_synolakis_measured_H=R_measured_H, runup_rel_error_measured_H=R / R_measured_H - 1,
                flat_length=flat,
                breaking_limit_H_over_d=0.818 * (1 / beach_slope) ** (-10 / 9),
                n_fluid=scene.config.n_fluid, t_end=t_end, wall_s=wall, load=os.getloadavg()[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--height-ratio", type=float, default=0.2, help="H / d")
    ap.add_argument("--beach-slope", type=float, default=math.tan(math.radians(20.0)))
    ap.add_argument("--alpha", type=float, default=0.02, help="artificial viscosity")
    ap.add_argument("--laminar", action="store_true", help="sph.Laminar viscosity (nu 1e-6) instead of alpha")
    ap.add_argument("--wall-viscosity", type=float, default=1.0, help="FluidParams.wall_viscosity (0: free slip)")
    ap.add_argument("--settle", type=float, default=0.0, help="s of lattice settling before the run (scenes.settle)")
    ap.add_argument("--t-after", type=float, default=1.5, help="s simulated after the crest reaches the toe")
    ap.add_argument("--out", default=str(HERE / "results" / "solitary_runup.jsonl"))
    a = ap.parse_args()
    rec = run(a.dx, a.height_ratio, a.beach_slope, a.alpha, a.t_after, laminar=a.laminar,
              wall_viscosity=a.wall_viscosity, settle=a.settle)
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown=rec)


if __name__ == "__main__":
    main()
