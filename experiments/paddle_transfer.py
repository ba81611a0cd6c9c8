"""Piston and flap wave makers against Biesel's transfer functions, kh 0.5-2 (issue 45, item 4).

Runs ``scenes.wave_flume`` (regular waves of target height ``--height`` made by
``blocks.paths.regular``, whose stroke comes from Biesel's H/S of the paddle: piston
``2 (cosh 2kh - 1) / (sinh 2kh + 2kh)``, flap hinged on the bed
``4 (sinh kh / kh) (kh sinh kh - cosh kh + 1) / (sinh 2kh + 2kh)``; ramped over 2 periods; water
0.3 m deep, a 2D periodic slab, boundary-particle paddle, laminar viscosity nu = 1e-6) with gauges
at 1, 2, 3, 4 and 6 depths and a sponge one wavelength long before a 0.3 beach, so the train can be
measured for several periods without the beach's reflection. At each gauge the first-harmonic
height H (``validation.wave_height``) over whole periods from the front's arrival (x / c_g) + 2
periods to the end; ``H / target`` is then the measured H/S over Biesel's (the issue's target:
within 3 %). Along the flume: ``decay / L``, the height lost per wavelength from the slope of ln H
over the gauges from 2 depths (beyond the evanescent modes; target <= 1 %), and ``k fit / k``, the
wavenumber from the slope of the first-harmonic phases over the same gauges against the
dispersion relation (target within 1 %). One JSON line per run to ``results/paddle_transfer.jsonl``.

    python experiments/paddle_transfer.py --paddle flap --kh 1 --dx 0.03      # ~10 min on 2 cores
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
GAUGE_DEPTHS = (1, 2, 3, 4, 6)


def build(*, paddle: str, kh: float, dx: float, height: float, periods_measured: float, shifting: str = "none"):
    """The flume for ``kh`` (flat = gauges + one wavelength of sponge + 0.3 m) and its run time;
    ``shifting``: the particle-shifting law by name (``sph.shifting``)."""
    import rockjax as rj
    from rockjax.validation import linear_wave

    w = linear_wave(kh, DEPTH)
    L = 2 * math.pi / w["k"]
    x_last = GAUGE_DEPTHS[-1] * DEPTH
    flat = math.ceil((x_last + 0.3 + L) / dx) * dx
    t_end = x_last / w["cg"] + (2 + periods_measured) * w["period"]
    scene = rj.scenes.wave_flume(dx=dx, water_depth=DEPTH, wave="regular", paddle=paddle, wave_height=height,
                                 period=w["period"], duration=t_end + 3 * w["period"], flat_length=flat, beach_slope=0.3,
                                 sponge_length=L, sponge_strength=2 * w["omega"],
                                 gauge_x=[g * DEPTH for g in GAUGE_DEPTHS],
                                 scheme=rj.WCSPH(viscosity=rj.sph.Laminar(),
                                                 shifting=rj.sph.by_name("shifting", shifting)))
    return scene, w, t_end


def along_flume(gauges: list[dict], k: float) -> tuple[float | None, float | None]:
    """``(decay per wavelength, k fit / k)`` from the gauges at 2 depths and beyond (records of
    ``run``): the slope of ln H, and the slope of the first-harmonic phases. The phases are
    unwrapped about linear theory's ``k x`` (the gauges may stand more than half a wavelength
    apart: 0.6 m at kh 2 is 0.64 L), so a fitted k within ~half a wavelength's phase of it is found."""
    far = [q for q in gauges if q["x_over_depth"] >= 2 and q["periods"] > 0]
    if len(far) < 2:
        return None, None
    xs = np.array([q["x_over_depth"] * DEPTH for q in far])
    L = 2 * math.pi / k
    decay = float(1 - math.exp(np.polyfit(xs, np.log([q["H"] for q in far]), 1)[0] * L))
    resid = np.angle(np.exp(1j * (np.array([q["phase"] for q in far]) - k * xs)))  # wrapped to (-pi, pi]
    k_fit = k + float(np.polyfit(xs, np.unwrap(resid), 1)[0])
    return decay, k_fit / k


def reanalyse(path: str) -> None:
    """Recompute ``decay_per_wavelength`` and ``k_fit_over_k`` of every record in ``path`` from its
    stored gauge heights and phases (``along_flume``), in place."""
    import json

    recs = [json.loads(line) for line in open(path) if line.strip()]
    for r in recs:
        r["decay_per_wavelength"], r["k_fit_over_k"] = along_flume(r["gauges"], 2 * math.pi / r["wavelength"])
    with open(path, "w") as f:
        f.writelines(json.dumps(r) + "\n" for r in recs)


def run(*, paddle: str, kh: float, dx: float, height: float, periods_measured: float = 4.0,
        shifting: str = "none") -> dict:
    import rockjax as rj
    from rockjax.blocks.paths import flap_transfer, piston_transfer
    from rockjax.observables import scene_observer
    from rockjax.validation import wave_height, wave_phase

    scene, w, t_end = build(paddle=paddle, kh=kh, dx=dx, height=height, periods_measured=periods_measured,
                            shifting=shifting)
    T, k, cg = w["period"], w["k"], w["cg"]
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    wall = time.perf_counter() - t0
    t, eta = np.asarray(res.times), np.asarray(res.observed["gauges"])
    stroke = float(scene.meta["signal"]["stroke"])
    theory = float((piston_transfer if paddle == "piston" else flap_transfer)(kh))
    gauges = []
    for j, g in enumerate(GAUGE_DEPTHS):
        x = g * DEPTH
        t_start = x / cg + 2 * T
        H, H2, n = wave_height(t, eta[:, j], period=T, t_start=t_start, t_stop=float(t[-1]))
        ph = wave_phase(t, eta[:, j], period=T, t_start=t_start, t_stop=float(t[-1]))
        gauges.append(dict(x_over_depth=g, periods=n, H=H, H_over_S=H / stroke, H_over_target=H / stroke / theory,
                           H2_over_H=H2 / H if H > 0 else None, phase=ph))
    decay, k_fit_over_k = along_flume(gauges, k)
    L = 2 * math.pi / k
    fl = scene.params.fluid
    return dict(experiment="paddle_transfer", paddle=paddle, scheme="wcsph", shifting=shifting, kh=kh, depth=DEPTH, dx=dx,
                h_over_dx=float(fl.h) / dx, target_height=height, H_over_dx=height / dx, kH_over_2=k * height / 2,
                stroke=stroke, theory_H_over_S=theory, period=T, wavelength=L, flat_length=scene.meta["flat_length"],
                t_end=t_end, gauges=gauges,
                H_over_target_2_4=float(np.mean([q["H_over_target"] for q in gauges if q["x_over_depth"] in (2, 3, 4)])),
                decay_per_wavelength=decay, k_fit_over_k=k_fit_over_k,
                n_fluid=scene.config.n_fluid, wall_s=wall, sim_s_per_wall_s=t_end / wall, load=os.getloadavg()[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--paddle", choices=["piston", "flap"], default="piston")
    ap.add_argument("--kh", type=float, default=1.0)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--height", type=float, default=0.04, help="target wave height m")
    ap.add_argument("--periods", type=float, default=4.0, help="periods measured at the last gauge")
    ap.add_argument("--shifting", default="none", help="particle shifting by name (sph.shifting): none, fickian")
    ap.add_argument("--out", default=str(HERE / "results" / "paddle_transfer.jsonl"))
    ap.add_argument("--reanalyse", action="store_true", help="recompute the along-flume fits of --out's records")
    a = ap.parse_args()
    if a.reanalyse:
        return reanalyse(a.out)
    rec = run(paddle=a.paddle, kh=a.kh, dx=a.dx, height=a.height, periods_measured=a.periods, shifting=a.shifting)
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown={k: v for k, v in rec.items() if k != "gauges"})


if __name__ == "__main__":
    main()
