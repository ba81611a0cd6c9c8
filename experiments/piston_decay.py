"""Piston wave maker: wave height against distance from the paddle (numerical damping check).

Runs ``scenes.piston_wavemaker`` (kh = 1, depth 0.3 m, stroke 0.04 m or ``--stroke``, 4 m flat, periodic 2D
slab, boundary-particle paddle) with gauges at 1, 2, 3, 4 and 6 depths, and fits the wave
height H at each gauge (``rockjax.validation.wave_height``: first and second harmonic of the
paddle frequency, mean and drift) over the whole periods from the front's arrival (x / c_g) plus
0, 1 or 2 periods until the beach reflection could return. The wave train takes periods to
develop after the paddle starts (its front is spread by dispersion), so only the late windows
measure the steady height. Compares H/S with linear theory
(``rockjax.validation.piston_transfer``). Prints one JSON line and appends it to ``--out``.

    python experiments/piston_decay.py --dx 0.03 --t-end 6.4 --wall-viscosity 0   # ~20 min quiet
    python experiments/piston_decay.py --from-npz run.npz          # re-analyse a saved run
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import time

import numpy as np

from rockjax.validation import linear_wave, piston_transfer

HERE = pathlib.Path(__file__).resolve().parent

KH, DEPTH, STROKE, FLAT = 1.0, 0.3, 0.04, 4.0
GAUGES = [0.3, 0.6, 0.9, 1.2, 1.8]


VARIANTS = {
    "ramp2": "paddle ramped up over 2 periods (half cosine) instead of an impulsive start",
    "settle": "lattice settled 3 s (scenes.settle) before the paddle starts",
    "laminar": "sph.Laminar viscosity, nu = 1e-6 m^2/s (water) instead of Monaghan's artificial one",
    "laminar_eq": "sph.Laminar viscosity with Monaghan's equivalent nu = alpha h c0 / 10",
    "sps": "sph.LaminarSPS (nu = 1e-6 plus the Smagorinsky SPS stress)",
    "cubic": "cubic spline kernel instead of Wendland C2",
    "dynwalls": "sph.DynamicWalls instead of Adami walls",
    "sponge": "a 1.2 m sponge (sph.Sponge, 10 1/s) before the beach",
}


def simulate(dx: float, coupling: str, t_end: float, npz: str, *, alpha=None, wall_viscosity=None,
             h_factor: float = 1.5, diffusion: str = "fourtakas", stroke: float = STROKE, variant: str = "") -> None:
    import dataclasses

    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import scene_observer

    parts = set(filter(None, variant.split("+")))
    unknown = parts - set(VARIANTS)
    if unknown:
        raise SystemExit(f"unknown variant parts {sorted(unknown)}; choose from {sorted(VARIANTS)}")
    T = linear_wave(KH, DEPTH)["period"]
    scene = rj.scenes.piston_wavemaker(dx=dx, stroke=stroke, period=T, water_depth=DEPTH, flat_length=FLAT,
                                       beach_slope=0.3, flume_width=(7 if h_factor <= 1.3 else 8) * dx,
                                       coupling=rj.Coupling(coupling),
                                       gauge_x=GAUGES, h_factor=h_factor, ramp_periods=2.0 if "ramp2" in parts else 0.0,
                                       sponge_length=1.2 if "sponge" in parts else 0.0)
    scheme = scene.config.scheme.replace(diffusion=rj.sph.by_name("diffusion", diffusion))
    if parts & {"laminar", "laminar_eq"}:
        scheme = dataclasses.replace(scheme, viscosity=rj.sph.Laminar())
    if "sps" in parts:
        scheme = dataclasses.replace(scheme, viscosity=rj.sph.LaminarSPS())
    if "cubic" in parts:
        scheme = dataclasses.replace(scheme, kernel=rj.sph.CubicSpline())
    if "dynwalls" in parts:
        scheme = dataclasses.replace(scheme, walls=rj.sph.DynamicWalls())
    scene = scene.replace(config=scene.config.replace(scheme=scheme))
    fl = scene.params.fluid
    fl = fl.replace(alpha=fl.alpha if alpha is None else jnp.asarray(alpha, fl.alpha.dtype),
                    wall_viscosity=fl.wall_viscosity if wall_viscosity is None
                    else jnp.asarray(wall_viscosity, fl.alpha.dtype))
    if parts & {"laminar", "sps"}:
        fl = fl.replace(nu=jnp.asarray(1e-6, fl.nu.dtype))
    if "laminar_eq" in parts:
        fl = fl.replace(nu=fl.alpha * fl.h * fl.c0 / 10.0)
    scene = scene.replace(params=scene.params.replace(fluid=fl))
    if "settle" in parts:
        scene = rj.scenes.settle(scene, t_settle=3.0)
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    np.savez(npz, t=res.times, eta=res.observed["gauges"], T=T, gx=GAUGES, theory=piston_transfer(KH),
             wall=time.perf_counter() - t0, n=scene.config.n_fluid, dx=dx, coupling=coupling,
             load=os.getloadavg()[0], alpha=float(fl.alpha), wall_viscosity=float(fl.wall_viscosity),
             h_factor=h_factor, diffusion=diffusion, stroke=stroke, variant=variant, c0=float(fl.c0), h=float(fl.h),
             nu=float(fl.nu))


def analyse(npz: str, delays=(0, 1, 2)) -> dict:
    """Wave height at each gauge over the developed train: whole periods from the front's arrival
    (x / c_g) plus ``delay`` periods until the beach reflection could return (or the record ends),
    fitted by ``rockjax.validation.wave_height`` (first + second harmonic, mean and drift)."""
    from rockjax.validation import wave_height, wave_phase

    d = np.load(npz)
    t, eta, T = d["t"], d["eta"], float(d["T"])
    wave = linear_wave(KH, DEPTH)
    theory = float(d["theory"])
    stroke = float(d["stroke"]) if "stroke" in d else STROKE
    rows = []
    for j, x in enumerate(d["gx"]):
        t_stop = min((2 * FLAT - x) / wave["cg"], float(t[-1]))
        fits = []
        for delay in delays:
            t_start = x / wave["cg"] + delay * T
            H, H2, n = wave_height(t, eta[:, j], period=T, t_start=t_start, t_stop=t_stop)
            if n:
                fits.append(dict(delay_periods=delay, t_start=round(t_start, 3), periods=n, H_over_S=H / stroke,
                                 H2_over_S=H2 / stroke, rel_error=(H / stroke - theory) / theory))
        phase = wave_phase(t, eta[:, j], period=T, t_start=x / wave["cg"] + 2 * T, t_stop=t_stop)
        rows.append(dict(x=float(x), x_over_depth=float(x) / DEPTH, t_stop=round(t_stop, 3), fits=fits,
                         phase=phase))
    # wavenumber of the developed train: slope of the unwrapped first-harmonic phases over the
    # gauges beyond the evanescent modes (x >= 2 depths), against linear theory's k
    far = [(r["x"], r["phase"]) for r in rows if r["x"] >= 2 * DEPTH - 1e-9 and np.isfinite(r["phase"])]
    k_fit = None
    if len(far) >= 2:
        xs = np.array([a for a, _ in far])
        k_fit = float(np.polyfit(xs, np.unwrap([b for _, b in far]), 1)[0])
    # decay along the flume: slope of ln H over the gauges from 1 depth (delay-1 fits where there
    # are any, else delay 0), as a loss per wavelength; and what a viscosity nu predicts for a
    # progressive wave's amplitude (Lamb: e^{-2 nu k^2 t}, t = L / c_g per wavelength) with the
    # artificial viscosity's equivalent nu = alpha h c0 / 10 (3D, Monaghan) plus the laminar nu
    xs, lnH = [], []
    for r in rows:
        f = {q["delay_periods"]: q for q in r["fits"]}
        q = f.get(1) or f.get(0)
        if q is not None:
            xs.append(r["x"])
            lnH.append(np.log(q["H_over_S"]))
    L = 2 * np.pi / wave["k"]
    decay = float(1 - np.exp(np.polyfit(xs, lnH, 1)[0] * L)) if len(xs) >= 2 else None
    dxv = float(d["dx"]) if "dx" in d else 0.03
    hf = float(d["h_factor"]) if "h_factor" in d else 1.3
    h = float(d["h"]) if "h" in d else hf * dxv
    c0 = float(d["c0"]) if "c0" in d else 15.0 * np.sqrt(9.81 * DEPTH)
    variant = str(d["variant"]) if "variant" in d else ""
    laminar = "laminar" in variant or "sps" in variant
    nu_art = 0.0 if laminar else (float(d["alpha"]) if "alpha" in d else 0.02) * h * c0 / 10.0
    nu = nu_art + ((float(d["nu"]) if "nu" in d else 1e-6) if laminar else 0.0)
    predicted = float(1 - np.exp(-2 * nu * wave["k"] ** 2 * L / wave["cg"]))
    # a no-slip bed with that viscosity (FluidParams.wall_viscosity = 1): the Stokes layer's
    # dissipation (1/4) rho u_b^2 omega delta, delta = sqrt(2 nu / omega), u_b = a omega / sinh kh,
    # against the energy flux (1/2) rho g a^2 c_g: amplitude decay rate
    # k_i = omega^3 delta / (4 g c_g sinh^2 kh) (Hunt 1952's laminar bed friction)
    wv = float(d["wall_viscosity"]) if "wall_viscosity" in d else 1.0
    om = wave["omega"]
    delta = np.sqrt(2 * nu * wv / om)
    k_i = om ** 3 * delta / (4 * 9.81 * wave["cg"] * np.sinh(KH) ** 2)
    bed = float(1 - np.exp(-k_i * L))
    return dict(kh=KH, depth=DEPTH, stroke=stroke, period=T, dx=float(d["dx"]) if "dx" in d else None,
                decay_per_wavelength=decay, viscous_decay_per_wavelength=predicted, bed_friction_decay_per_wavelength=bed,
                nu_effective=nu,
                coupling=str(d["coupling"]) if "coupling" in d else None, n_fluid=int(d["n"]),
                alpha=float(d["alpha"]) if "alpha" in d else 0.02,
                wall_viscosity=float(d["wall_viscosity"]) if "wall_viscosity" in d else 1.0,
                h_factor=float(d["h_factor"]) if "h_factor" in d else 1.3,
                diffusion=str(d["diffusion"]) if "diffusion" in d else "fourtakas",
                variant=str(d["variant"]) if "variant" in d else "",
                t_end=float(t[-1]), wall_s=float(d["wall"]), theory_H_over_S=theory, gauges=rows,
                k_fit=k_fit, k_theory=KH / DEPTH)


def main():
    import rockjax as rj

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--t-end", type=float, default=6.0)
    ap.add_argument("--coupling", default="boundary_particles", choices=["penalty", "boundary_particles"])
    ap.add_argument("--alpha", type=float, default=None, help="artificial viscosity (default: the scene's)")
    ap.add_argument("--wall-viscosity", type=float, default=None,
                    help="viscous factor towards walls/blocks (default: the scene's; 0 = free slip)")
    ap.add_argument("--h-factor", type=float, default=1.5, help="smoothing length / dx (the scene's default)")
    ap.add_argument("--stroke", type=float, default=STROKE, help="paddle stroke m")
    ap.add_argument("--diffusion", default="fourtakas", choices=rj.sph.names("diffusion"))
    ap.add_argument("--variant", default="", help="'+'-joined parts: " + "; ".join(f"{k}: {v}" for k, v in VARIANTS.items()))
    ap.add_argument("--out", default=None, help="JSON-lines file the record is appended to "
                                                "(default results/piston_decay.jsonl)")
    ap.add_argument("--from-npz", default=None, help="analyse a saved run instead of simulating")
    ap.add_argument("--npz", default="piston_decay.npz", help="where to save the gauge records")
    a = ap.parse_args()
    npz = a.from_npz
    if npz is None:
        simulate(a.dx, a.coupling, a.t_end, a.npz, alpha=a.alpha, wall_viscosity=a.wall_viscosity,
                 h_factor=a.h_factor, diffusion=a.diffusion, stroke=a.stroke, variant=a.variant)
        npz = a.npz
    rec = analyse(npz)
    print(json.dumps(rec))
    rec["date"] = time.strftime("%Y-%m-%d")
    with open(a.out or HERE / "results" / "piston_decay.jsonl", "a") as f:
        f.write(json.dumps(rec) + "\n")


if __name__ == "__main__":
    main()
