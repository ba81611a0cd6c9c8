"""Piston wave maker: does the paddle deliver its volume flux? (issue 45: the waves' level deficit)

The waves of ``piston_decay.py``'s flume (kh = 1, depth 0.3 m, stroke 0.04 m, 4 m flat, periodic
2D slab, boundary-particle paddle) come out 5-7 % below linear theory already one depth from the
paddle. Mass conservation splits the question in two: the depth-integrated volume flux per unit
width ``Q(x, t) = sum_i V_i u_x,i / (b W)`` over the water particles within ``b / 2`` of a vertical
section x (``b = 2 dx``, ``W`` the slab width, ``V_i = m_i / rho_i``) against

* the paddle's own flux ``d dX/dt`` (``X = S/2 sin(omega t)``: amplitude ``S/2 omega d``; also
  with the depth as filled, whole lattice layers: 0.28 m at dx 0.04 for d = 0.3 m) at sections: a
  deficit there is flux the paddle does not deliver (a leak round it, the fluid's compression, the
  wall treatment's gap);
* ``(omega / k) (H / 2)`` of the height H measured by the gauge at the same x (a progressive linear
  wave's flux, ``omega / k = c``): a deficit in H with the flux delivered is in the wave's own
  kinematics (the elevation a flux makes).

First harmonics fitted as ``piston_decay.py`` fits its gauges (``validation.wave_height``: whole
periods from the front's arrival + 1 period until the beach reflection could return). JSON lines.

    .venv/bin/python experiments/piston_flux.py [--dx 0.03] [--t-end 5] [--out F.jsonl]

Its dx 0.04 records ran before the flume refused a depth that is not a whole number of dx.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402
from piston_decay import DEPTH, FLAT, KH, STROKE  # noqa: E402

SECTIONS = [0.15, 0.3, 0.6, 1.2]  # m from the paddle's rest face: 0.5, 1, 2, 4 depths


def run(dx: float, t_end: float, wall_viscosity: float | None, stroke: float):
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import scene_observer
    from rockjax.types import Kind
    from rockjax.validation import linear_wave

    T = linear_wave(KH, DEPTH)["period"]
    width = 8 * dx
    scene = rj.scenes.piston_wavemaker(dx=dx, stroke=stroke, period=T, water_depth=DEPTH, flat_length=FLAT,
                                       beach_slope=0.3, flume_width=width, coupling=rj.Coupling("boundary_particles"),
                                       gauge_x=SECTIONS, h_factor=1.5)
    if wall_viscosity is not None:
        fl = scene.params.fluid
        scene = scene.replace(params=scene.params.replace(fluid=fl.replace(
            wall_viscosity=jnp.asarray(wall_viscosity, fl.alpha.dtype))))
    base = scene_observer(scene.meta)
    xs = jnp.asarray(SECTIONS)
    b = 2.0 * dx

    def observe(state, params, config):  # noqa: D401 (stroke, T, dx closed over: host constants)
        out = base(state, params, config)
        P = state.particles
        V = jnp.where(P.kind == Kind.FLUID, P.vol * params.fluid.rho0 / P.rho, 0.0)
        near = jnp.abs(P.x[None, :, 0] - xs[:, None]) < 0.5 * b
        out["flux"] = jnp.sum(jnp.where(near, V[None, :] * P.v[None, :, 0], 0.0), axis=1) / (b * width)
        # water that got behind the paddle's face (a leak round it): the face is at x = X(t) +- a spacing
        face = 0.5 * stroke * jnp.sin(2 * jnp.pi * state.step * config.dt / T)
        out["behind"] = jnp.sum((P.kind == Kind.FLUID) & (P.x[:, 0] < face - dx))
        # the water's volume change (compression) within one depth of the paddle
        zone = (P.kind == Kind.FLUID) & (P.x[:, 0] < face + DEPTH)
        out["near_volume_change"] = jnp.sum(jnp.where(zone, P.vol * (params.fluid.rho0 / P.rho - 1.0), 0.0)) / width
        return out

    # the water's depth as filled: whole lattice layers below water_depth (7 x 0.04 = 0.28 m for 0.3 m)
    x0 = np.asarray(scene.state.particles.x)[: scene.config.n_fluid]
    layers = len(np.unique(np.round(x0[np.abs(x0[:, 0] - 0.5 * FLAT) < 0.5 * dx, 2] / dx, 3)))
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=T / 24, observe=observe, progress=False)
    fl = scene.params.fluid
    return res, T, dict(n_fluid=scene.config.n_fluid, wall_s=round(time.perf_counter() - t0, 1),
                        wall_viscosity=float(fl.wall_viscosity), alpha=float(fl.alpha), h=float(fl.h),
                        volume_depth=layers * dx)


def analyse(res, T, stroke, volume_depth):
    from rockjax.validation import linear_wave, piston_transfer, wave_height

    wave = linear_wave(KH, DEPTH)
    t = np.asarray(res.times)
    Q = np.asarray(res.observed["flux"])
    eta = np.asarray(res.observed["gauges"])
    omega, k = wave["omega"], wave["k"]
    q_paddle = 0.5 * stroke * omega * DEPTH  # amplitude of d dX/dt per unit width, m^2/s
    behind = np.asarray(res.observed["behind"])
    dv = np.asarray(res.observed["near_volume_change"])
    hv, _, _ = wave_height(t, dv, period=T, t_start=T, t_stop=float(t[-1]))
    rows = []
    for j, x in enumerate(SECTIONS):
        t_start = x / wave["cg"] + T
        t_stop = min((2 * FLAT - x) / wave["cg"], float(t[-1]))
        hq, _, n = wave_height(t, Q[:, j], period=T, t_start=t_start, t_stop=t_stop)
        he, _, _ = wave_height(t, eta[:, j], period=T, t_start=t_start, t_stop=t_stop)
        q1 = 0.5 * hq  # first-harmonic amplitude
        rows.append(dict(x=x, x_over_depth=round(x / DEPTH, 3), periods=n, flux_amp=q1, flux_over_paddle=q1 / q_paddle,
                         flux_over_paddle_filled=q1 / (q_paddle * volume_depth / DEPTH),
                         H_over_S=he / stroke, flux_from_H=0.5 * he * omega / k,
                         flux_over_flux_from_H=q1 / (0.5 * he * omega / k) if he > 0 else None))
    # the paddle's stroke volume per unit width is S d; the near-paddle compression's first harmonic against it
    return dict(q_paddle=q_paddle, theory_H_over_S=piston_transfer(KH), sections=rows,
                behind_max=int(behind.max()), compression_over_stroke_volume=0.5 * hv / (0.5 * stroke * DEPTH))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.03, help="m; a whole fraction of the 0.3 m depth")
    ap.add_argument("--t-end", type=float, default=5.0)
    ap.add_argument("--wall-viscosity", type=float, default=None, help="FluidParams.wall_viscosity (default: the scene's)")
    ap.add_argument("--stroke", type=float, default=STROKE)
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    res, T, info = run(a.dx, a.t_end, a.wall_viscosity, a.stroke)
    rec = dict(bench="piston_flux", kh=KH, depth=DEPTH, stroke=a.stroke, period=T, dx=a.dx, t_end=a.t_end, **info,
               **analyse(res, T, a.stroke, info["volume_depth"]), date=time.strftime("%Y-%m-%d"),
               cmd="experiments/piston_flux.py " + " ".join(sys.argv[1:] if argv is None else argv),
               load_avg_1m=round(os.getloadavg()[0], 2))
    emit(rec, a.out)


if __name__ == "__main__":
    main()
