"""Absorbing end of a wave flume: the reflection coefficient of a sponge layer (issue: <= 5 %).

Regular waves (``blocks.paths.regular``: a target height, ramped over 2 periods) run down a
flat flume (``scenes.piston_wavemaker(signal=..., sponge_length=...)``, periodic 2D slab) into a
sponge (``sph.Sponge``) of ``--sponge-wavelengths`` wavelengths and damping ``--strength`` 1/s,
then a steep beach. Four gauges between the paddle and the sponge record the partial standing
wave; ``rockjax.validation.reflection`` (Mansard & Funke 1980) splits it into incident and
reflected heights over the whole periods after the reflection of the developed train has come
back to the gauges. ``--no-sponge`` measures the bare beach for comparison. One JSON line per
run, appended to ``results/wave_absorption.jsonl``.

    python experiments/wave_absorption.py --kh 1.0 --dx 0.04          # ~10 min on 2 cores
"""

from __future__ import annotations

import argparse
import os
import pathlib
import time

import numpy as np
from jsonl_out import emit

HERE = pathlib.Path(__file__).resolve().parent
DEPTH, HEIGHT = 0.3, 0.02


def run(kh: float, dx: float, *, sponge_wavelengths: float, strength: float, sponge: bool, height: float,
        periods_after: float, laminar: bool = False) -> dict:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.blocks import paths
    from rockjax.observables import scene_observer
    from rockjax.validation import linear_wave, reflection

    w = linear_wave(kh, DEPTH)
    T, L, cg = w["period"], 2 * np.pi / w["k"], w["cg"]
    x_gauges = 2 * DEPTH + np.array([0.0, 0.13, 0.29, 0.41]) * L  # Mansard-Funke spacing: not L/2
    x_sponge = x_gauges[-1] + max(0.5 * L, 3 * DEPTH)
    s_len = sponge_wavelengths * L if sponge else 0.0
    flat = x_sponge + (s_len if sponge else 0.5 * L)
    # the train's front returns to the first gauge after 2 (flat) / cg plus the ramp; measure then
    t_back = 2 * flat / cg + 2 * T
    t_end = t_back + periods_after * T
    sig = paths.regular(period=T, water_depth=DEPTH, duration=t_end + 2 * T, wave_height=height, ramp_periods=2)
    # the ramp at the signal's end lies beyond t_end (the paddle never stops within the run)
    scene = rj.scenes.piston_wavemaker(dx=dx, water_depth=DEPTH, flat_length=flat, beach_slope=0.5, signal=sig,
                                       gauge_x=list(x_gauges), sponge_length=s_len,
                                       sponge_strength=strength if sponge else 10.0)
    if laminar:  # the water's viscosity instead of Monaghan's artificial one (no numerical wave decay)
        import dataclasses

        scene = scene.replace(config=scene.config.replace(
            scheme=dataclasses.replace(scene.config.scheme, viscosity=rj.sph.Laminar())),
            params=scene.params.replace(fluid=scene.params.fluid.replace(
                nu=jnp.asarray(1e-6, scene.params.fluid.nu.dtype))))
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 25, observe=scene_observer(scene.meta), progress=False)
    wall = time.perf_counter() - t0
    eta = np.asarray(res.observed["gauges"])
    t = np.asarray(res.times)
    r = reflection(t, eta, x_gauges, period=T, depth=DEPTH, t_start=t_back, t_stop=t_end)
    # the incident train alone, before any reflection reaches the gauges (for the height error)
    t_first = x_gauges[-1] / cg + 3 * T
    t_stop0 = (2 * flat - x_gauges[-1]) / cg
    r0 = (reflection(t, eta, x_gauges, period=T, depth=DEPTH, t_start=t_first, t_stop=t_stop0)
          if t_stop0 - t_first >= T else None)
    return dict(kh=kh, depth=DEPTH, period=T, wavelength=L, dx=dx, target_height=height, sponge=sponge,
                viscosity="laminar 1e-6" if laminar else "artificial",
                sponge_wavelengths=sponge_wavelengths if sponge else 0.0, strength=strength if sponge else 0.0,
                sponge_strength_over_omega=strength * T / (2 * np.pi) if sponge else 0.0,
                flat_length=flat, gauges=[float(g) for g in x_gauges], t_end=t_end, t_window=[t_back, t_end],
                Kr=r["Kr"], H_incident=r["H_incident"], H_reflected=r["H_reflected"], condition=r["condition"],
                periods=r["periods"], H_incident_before_reflection=None if r0 is None else r0["H_incident"],
                n_fluid=scene.config.n_fluid, wall_s=wall, load=os.getloadavg()[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kh", type=float, default=1.0)
    ap.add_argument("--dx", type=float, default=0.0375, help="m; a whole fraction of the 0.3 m depth (the flume refuses others)")
    ap.add_argument("--height", type=float, default=HEIGHT, help="target wave height m")
    ap.add_argument("--sponge-wavelengths", type=float, default=1.0)
    ap.add_argument("--strength", type=float, default=None, help="sponge damping 1/s (default: 2 omega)")
    ap.add_argument("--laminar", action="store_true", help="sph.Laminar viscosity (nu 1e-6) instead of alpha")
    ap.add_argument("--no-sponge", action="store_true", help="the bare beach (slope 0.5) for comparison")
    ap.add_argument("--periods-after", type=float, default=5.0, help="periods measured after the reflection returns")
    ap.add_argument("--out", default=str(HERE / "results" / "wave_absorption.jsonl"))
    a = ap.parse_args()
    from rockjax.validation import linear_wave

    omega = linear_wave(a.kh, DEPTH)["omega"]
    strength = 2 * omega if a.strength is None else a.strength
    rec = run(a.kh, a.dx, sponge_wavelengths=a.sponge_wavelengths, strength=strength, sponge=not a.no_sponge,
              height=a.height, periods_after=a.periods_after, laminar=a.laminar)
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown=rec)


if __name__ == "__main__":
    main()
