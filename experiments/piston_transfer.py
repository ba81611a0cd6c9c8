"""Piston wave maker vs linear wave-maker theory (Dean & Dalrymple 1991), JSON lines out.

Runs ``scenes.piston_wavemaker`` as a 2D periodic slab, records the free-surface elevation at a
gauge > 3 depths from the paddle, and compares the wave height of the steady waves (before the
beach reflection returns) with H/S = 2 (cosh 2kh - 1) / (sinh 2kh + 2kh), interpolated from
``data/validation/piston_wavemaker_transfer.csv`` (``rockjax.validation``).

    python experiments/piston_transfer.py --dx 0.03 --kh 1.0 --coupling boundary_particles
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from rockjax.validation import linear_wave, piston_transfer, wave_height


def run(*, dx: float, kh: float, depth: float, stroke: float, coupling: str, flat_length: float,
        gauge_depths: float = 4.0, t_end: float | None = None, wall_viscosity: float = 0.0,
        npz: str | None = None, still_npz: str | None = None, settle: float = 0.0,
        settle_alpha: float = 1.0) -> dict:
    import rockjax as rj
    from rockjax.observables import scene_observer

    wave = linear_wave(kh, depth)
    T, cg = wave["period"], wave["cg"]
    x_g = gauge_depths * depth
    scene = rj.scenes.piston_wavemaker(dx=dx, stroke=stroke, period=T, water_depth=depth, flat_length=flat_length,
                                       beach_slope=0.3, coupling=rj.Coupling(coupling),
                                       gauge_x=[x_g], wall_viscosity=wall_viscosity)
    # the developed train at the gauge: from the front's arrival + 2 periods (the front is spread
    # by dispersion) until the reflection off the beach (~flat_length away) could return
    t_arrive = x_g / cg
    t_reflect = (2 * flat_length - x_g) / cg
    t_end = t_reflect if t_end is None else t_end
    if min(t_end, t_reflect) - (t_arrive + 2 * T) < T:
        need = x_g + 1.5 * T * cg
        raise ValueError(f"flat_length {flat_length} m leaves less than one developed period at the gauge "
                         f"(x = {x_g} m, c_g = {cg:.3f} m/s, T = {T:.3f} s): use flat_length >= {need:.2f} m")
    t0 = time.perf_counter()
    if settle > 0:  # relax the water first (paddle still, strong artificial viscosity), then start at t = 0
        scene = rj.scenes.settle(scene, t_settle=settle, alpha=settle_alpha)
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=scene_observer(scene.meta), progress=False)
    wall = time.perf_counter() - t0
    eta = np.asarray(res.observed["gauges"][:, 0])
    if npz:
        np.savez(npz, t=np.asarray(res.times), eta=eta, stroke=stroke, dx=dx)
    window = dict(period=T, t_start=t_arrive + 2 * T, t_stop=min(t_end, t_reflect))
    H, H2, n = wave_height(res.times, eta, **window)
    theory = piston_transfer(kh)
    extra = {}
    if still_npz:  # the same flume with the paddle (nearly) still: its start transient removed from the record
        st = np.load(still_npz)
        if st["t"].shape != np.shape(res.times) or not np.allclose(st["t"], res.times):
            raise ValueError(f"{still_npz}: its frame times differ from this run's (same flume, dx and t_end needed)")
        Hs, _, _ = wave_height(res.times, st["eta"], **window)
        Hr, _, _ = wave_height(res.times, eta - st["eta"], **window)
        extra = dict(still_H_over_S=Hs / stroke, H_over_S_minus_still=Hr / stroke,
                     rel_error_minus_still=(Hr / stroke - theory) / theory)
    return dict(kh=kh, depth=depth, period=T, stroke=stroke, dx=dx, coupling=coupling, gauge_x=x_g,
                wall_viscosity=wall_viscosity, h_factor=float(scene.params.fluid.h) / dx,
                n_fluid=scene.config.n_fluid, t_end=t_end, window=[window["t_start"], window["t_stop"]], n_periods=n,
                H=H, H_over_S=H / stroke, H2_over_S=H2 / stroke, theory_H_over_S=theory, rel_error=(H / stroke - theory) / theory,
                settle_s=settle, settle_alpha=settle_alpha if settle > 0 else None,
                wall_s=wall, load=os.getloadavg()[0], **extra)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--kh", type=float, default=1.0)
    ap.add_argument("--depth", type=float, default=0.3)
    ap.add_argument("--stroke", type=float, default=0.04)
    ap.add_argument("--flat-length", type=float, default=4.5,
                    help="m; the developed train needs the beach reflection to return late enough")
    ap.add_argument("--coupling", default="boundary_particles", choices=["penalty", "boundary_particles"])
    ap.add_argument("--wall-viscosity", type=float, default=0.0,
                    help="FluidParams.wall_viscosity (default 0: free-slip walls, as linear theory is inviscid; "
                         "the scene's default 1 damps the train along the flume)")
    ap.add_argument("--npz", default=None, help="also save the gauge record (t, eta) here")
    ap.add_argument("--still-npz", default=None,
                    help="the --npz of the same flume run with a negligible stroke (e.g. 1e-9): also fit the "
                         "record minus that one (removes the start transient of the water on the beach)")
    ap.add_argument("--settle", type=float, default=0.0,
                    help="s: first relax the water with the paddle still and artificial viscosity --settle-alpha, "
                         "then start the paddle from that state at t = 0")
    ap.add_argument("--settle-alpha", type=float, default=1.0)
    a = ap.parse_args()
    print(json.dumps(run(dx=a.dx, kh=a.kh, depth=a.depth, stroke=a.stroke, coupling=a.coupling,
                         flat_length=a.flat_length, wall_viscosity=a.wall_viscosity, npz=a.npz,
                         still_npz=a.still_npz, settle=a.settle, settle_alpha=a.settle_alpha)), flush=True)


if __name__ == "__main__":
    main()
