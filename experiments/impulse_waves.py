"""Impulse waves from a rigid block sliding into a flume, against Heller & Hager's (2010) fit.

``scenes.sliding_wedge`` with the wedge spanning the flume (one dx of gap each side: a 2D
experiment, as in Heller & Hager's prismatic channel) and gauges every depth from 2 to 8 depths
beyond the shoreline (``--gauges-to``), run to 2 s (``--t-end``). The wedge is guided
(``sliding_wedge(guided=True)``: its sideways translation and its rotations about x and z
locked, as a slide on a laboratory flume's rails); ``--unguided`` leaves it free, and then only
the water in its 1 dx gaps holds it: after it stops at the toe it drifts into a side wall (at dx
0.04 / 0.02 it crossed one at 1.6 / 2.2 s). The record keeps its sideways drift
(``wedge_drift_y``). Heller & Hager (2010, J. Waterway Port Coastal Ocean Eng. 136(3), 145-155)
fit the maximum near-field wave amplitude and height of granular slides with the impulse product

    P = F S^(1/2) M^(1/4) {cos[(6/7) alpha]}^(1/2),   a_M / h = (4/9) P^(4/5),   H_M / h = (5/9) P^(4/5),

F = V_s / sqrt(g h) (slide speed at impact), S = s / h (slide thickness, here the wedge's
thickness normal to the slope), M = m_s / (rho_w b h^2) (slide mass per flume width), alpha the
slope angle. Rigid blocks are not granular slides (Heller & Spinneken 2013 compare the two); the
fit is the reference the issue names. The run records the slide's impact velocity (its centroid
velocity when its lowest point reaches the still level), a_M = the largest crest over the gauges
before the beach reflection returns, H_M = the largest crest-to-following-trough height, and
their ratios to the fit. One JSON line per run, appended to ``results/impulse_waves.jsonl``.

    python experiments/impulse_waves.py --slope 45 --length 0.2 --density 2500 --depth 0.2 --dx 0.02
    python experiments/impulse_waves.py --scheme dfsph --cfl 0.2      # DFSPH at its own h (= dx)

WCSPH runs at h = 1.5 dx (the wave flumes' setting); DFSPH at its kernel's own h: at 1.5 dx its
Jacobi sweeps diverge (``DFSPH.check_resolution``), and at its default CFL (0.4) the splash outran
the list's skin (a stale list with a rebuild every step), hence ``--cfl``.
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


def run(*, slope: float, length: float, density: float, depth: float, dx: float, start: float, width: float,
        friction: float, scheme: str = "wcsph", cfl: float | None = None, t_end: float | None = None,
        gauges_to: int = 8, guided: bool = True) -> dict:
    import rockjax as rj
    from rockjax.observables import impact_velocity, scene_observer

    g = 9.81
    gx = np.arange(2, int(gauges_to) + 1) * depth
    flat = float(16 * depth + 2 * depth)  # the beach far enough that its reflection misses the window
    scene = rj.scenes.sliding_wedge(dx=dx, slope_angle_deg=slope, block_density=density, friction_angle_deg=friction,
                                    block_length=length, block_width=width - 2 * dx, water_depth=depth,
                                    flat_length=flat, flume_width=width, start_distance=start,
                                    coupling=rj.Coupling.BOUNDARY_PARTICLES, scheme=scheme,
                                    h_factor=1.5 if scheme == "wcsph" else None,  # DFSPH: its own h (= dx)
                                    cfl=cfl, guided=guided)
    y = 0.5 * width
    scene = scene.replace(meta=scene.meta.with_items(gauges=dict(
        names=[f"x={x:.2f}" for x in gx], xy=[[float(x), y] for x in gx], bottom_z=[-depth] * len(gx))))
    c = math.sqrt(g * depth)
    t_end = 1.0 + (gx[-1] + 2 * depth) / c if t_end is None else t_end
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=0.01, observe=scene_observer(scene.meta), progress=False)
    wall = time.perf_counter() - t0
    by = np.asarray(res.frames["block_x"])[:, 0, 1]
    drift = float(np.max(np.abs(by - by[0])))  # the wedge's sideways drift m (nothing guides it but the water)
    t = np.asarray(res.times)
    eta = np.asarray(res.observed["gauges"])
    th = math.radians(slope)
    H_w = length * math.tan(th)
    bx = np.asarray(res.frames["block_x"])
    bv = np.asarray(res.frames["block_v"])
    # lowest point of the wedge below its centroid: the front-bottom corner, 2/3 H below it
    v_imp = impact_velocity(t, bx, bv, block=0, still_level=0.0, bottom_offset=2.0 * H_w / 3.0)
    Vs = float(np.linalg.norm(v_imp)) if v_imp is not None else float("nan")
    s = H_w * math.cos(th)
    m_s = density * 0.5 * length * H_w * (width - 2 * dx)
    F, S, M = Vs / c, s / depth, m_s / (1000.0 * (width - 2 * dx) * depth ** 2)
    P = F * math.sqrt(S) * M ** 0.25 * math.sqrt(math.cos(6.0 / 7.0 * th))
    a_fit, H_fit = 4.0 / 9.0 * P ** 0.8 * depth, 5.0 / 9.0 * P ** 0.8 * depth
    x_beach = scene.meta["x_beach"]
    a_M = H_M = 0.0
    x_aM = None
    crests = []  # (x / h, the largest crest there, the height from it to the following trough) per gauge
    for j, x in enumerate(gx):
        keep = t < (x + 2 * (x_beach - x)) / c + 0.5  # before the reflection from the beach returns
        e = eta[keep, j]
        if e.size < 3:
            continue
        i = int(np.argmax(e))
        trough = float(np.min(e[i:])) if i < e.size - 1 else 0.0
        crests.append([round(float(x) / depth, 3), float(e[i]), float(e[i] - trough)])
        if e[i] > a_M:
            a_M, x_aM = float(e[i]), float(x)
        H_M = max(H_M, float(e[i] - trough))
    return dict(scheme=scheme, cfl=cfl, guided=guided, slope_deg=slope, block_length=length, block_height=H_w, thickness=s,
                density=density, depth=depth, dx=dx, start_distance=start, flume_width=width, friction_deg=friction,
                impact_speed=Vs, F=F, S=S, M=M,
                P=P, a_M=a_M, x_aM_over_h=None if x_aM is None else x_aM / depth, H_M=H_M, a_M_fit=a_fit,
                H_M_fit=H_fit, a_ratio=a_M / a_fit, H_ratio=H_M / H_fit, x_M_fit_over_h=5.5 * math.sqrt(P),
                crest_by_gauge=crests, a_M_from_4h=max([c[1] for c in crests if c[0] >= 4.0], default=None),
                H_M_from_4h=max([c[2] for c in crests if c[0] >= 4.0 and len(c) > 2], default=None),
                wedge_front_x_end=float(bx[-1, 0, 0]) + length / 3.0,  # the vertical front, L / 3 ahead of the centroid
                wedge_drift_y=drift, n_fluid=scene.config.n_fluid, h_over_dx=float(scene.params.fluid.h) / dx,
                dt=scene.config.dt, t_end=t_end, wall_s=wall, load=os.getloadavg()[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--slope", type=float, default=45.0, help="slide angle alpha, degrees")
    ap.add_argument("--length", type=float, default=0.2, help="wedge length along its top m")
    ap.add_argument("--density", type=float, default=2500.0)
    ap.add_argument("--depth", type=float, default=0.2, help="still water depth h m")
    ap.add_argument("--dx", type=float, default=0.02)
    ap.add_argument("--start", type=float, default=0.2, help="front's distance up-slope from the shoreline m")
    ap.add_argument("--width", type=float, default=0.2, help="flume width m (the wedge fills it but 1 dx a side)")
    ap.add_argument("--friction", type=float, default=10.0, help="wedge-slope friction angle, degrees")
    ap.add_argument("--scheme", default="wcsph", choices=["wcsph", "dfsph"])
    ap.add_argument("--t-end", type=float, default=2.0,
                    help="s (the gauges to 8 depths see the first crest by then; the wedge drifts sideways "
                    "after it stops)")
    ap.add_argument("--gauges-to", type=int, default=8, help="the last gauge, in depths from the shoreline")
    ap.add_argument("--cfl", type=float, default=None, help="the scheme's CFL number (default its own)")
    ap.add_argument("--unguided", action="store_true", help="leave the wedge free sideways (no locked DOF)")
    ap.add_argument("--out", default=str(HERE / "results" / "impulse_waves.jsonl"))
    a = ap.parse_args()
    rec = run(slope=a.slope, length=a.length, density=a.density, depth=a.depth, dx=a.dx, start=a.start, width=a.width,
              friction=a.friction, scheme=a.scheme, cfl=a.cfl, t_end=a.t_end,
              gauges_to=a.gauges_to, guided=not a.unguided)
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown=rec)


if __name__ == "__main__":
    main()
