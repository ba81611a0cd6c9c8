"""Which switches make a coupled wedge's gradient local? An A/B of the smooth settings (issue 44).

Scene: ``scenes.sliding_wedge`` at dx = 0.05 m (the gradient tests' wedge: a 0.2 m wedge on a 40
degree slope, front at the shoreline, 0.2 m of water, 0.4 m flat, a 30 degree beach; ~400 water
particles; seed Eq 22 penalty coupling; joint water on), float64, ``--steps`` steps (default
1056 = 0.80 s: the wedge in the water and the wave on the beach).

Variants (``--variants``, see ``variant``): ``sharp`` (the defaults), ``law``
(``blocks.laws.SmoothPenaltyCoulomb`` at its default widths), ``coupling``
(``coupling.Penalty(onset=0.5, face_blend=0.1)``), ``law+coupling``, ``smooth``
(``calibrate.smooth_config``: both and the joint-water patch's fading corners), ``+nojw``: joint
water off.
Per variant, observations after every block of 8 steps: the wedge's down-slope coordinate, the
free-surface elevation at x = 0.30 m, and the smooth run-up on the far beach. Their derivatives
w.r.t. each leaf (``--leaves``: density, friction angle, artificial viscosity alpha) come from one
forward-mode pass per leaf (``jax.jvp``, exact), and central secants at relative steps 1e-2 ...
1e-6 from two runs per step and leaf; every (observable, time, leaf) is classified with
``rockjax.gradcheck.classify`` (ok: the 1e-3 and 1e-4 secants agree with AD within 2 %).

Output: JSON lines (``--out``), one per variant x leaf x observable at each of ``--report-times``
(AD, secants, verdict), and one summary per variant (the fraction of "ok" over all times after
the wedge reaches the water, per observable and leaf; timings).

    .venv/bin/python experiments/smoothness_ab.py [--steps 1056] [--variants sharp,law,coupling,law+coupling,smooth]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rockjax import Coupling, Status, scenes  # noqa: E402
from rockjax.blocks import SmoothPenaltyCoulomb  # noqa: E402
from rockjax.calibrate import get_leaf, observed, set_leaf, smooth_config  # noqa: E402
from rockjax.coupling import penalty  # noqa: E402
from rockjax.gradcheck import classify  # noqa: E402
from rockjax.observables import gauge_elevation, runup_kwargs, smooth_runup  # noqa: E402
from rockjax.sph import Artificial, Laminar  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402

STEPS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
OBS = ("wedge_s", "gauge_030", "smooth_runup")


def wedge(dx: float, water_depth: float = 0.2):
    return scenes.sliding_wedge(dx=dx, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=water_depth,
                                flat_length=0.4, flume_width=0.4, start_distance=0.0, coupling=Coupling.PENALTY)


def variant(scene, name: str):
    """The scene's config for variant ``name``: ``sharp`` (the defaults), ``smooth``
    (``calibrate.smooth_config``), or ``+``-joined parts: ``law`` (``SmoothPenaltyCoulomb``),
    ``widelaw`` (the law with 10x its default widths and a 30 % slip band), ``coupling``
    (``Penalty(onset=0.5, face_blend=0.1)``), ``wideblend`` (``face_blend=0.5``), ``jwfade``
    (``joint_fade_points``),
    ``nojw`` (joint water off), ``laminar`` (``sph.Laminar`` viscosity, no approach switch, with
    ``laminar_params``), ``smoothav`` (Monaghan's approach switch smoothed over |mu| < 0.001 c0),
    ``softfloor`` (the Adami walls' pressure floor rounded over 0.1 rho0 g dx), ``rebuild1`` (lists
    rebuilt at every step, observed every step);
    ``smooth`` may be a part too (``smooth+nojw``)."""
    cfg = scene.config
    parts = set() if name == "sharp" else set(name.split("+"))
    if "smooth" in parts:
        cfg = smooth_config(cfg)
        parts.discard("smooth")
    unknown = parts - {"law", "widelaw", "coupling", "wideblend", "jwfade", "nojw", "rebuild1", "laminar", "smoothav",
                       "softfloor"}
    if unknown:
        raise ValueError(f"variant {name!r}: unknown parts {sorted(unknown)}")
    blocks = cfg.blocks
    if "law" in parts:
        blocks = dataclasses.replace(blocks, law=SmoothPenaltyCoulomb())
    if "widelaw" in parts:  # 10x the default widths, a 30 % stick/slip band
        blocks = dataclasses.replace(blocks, law=SmoothPenaltyCoulomb(onset_depth=1e-4, closing_speed=1e-2, slip_band=0.3))
    if "jwfade" in parts:
        blocks = dataclasses.replace(blocks, joint_fade_points=True)
    if "nojw" in parts:
        blocks = dataclasses.replace(blocks, joint_water=False)
    if "laminar" in parts:  # no approach switch: Laminar viscosity instead of Monaghan's (params: laminar_params)
        cfg = cfg.replace(scheme=dataclasses.replace(cfg.scheme, viscosity=Laminar()))
    if "smoothav" in parts:  # Monaghan's approach switch over |mu| < 0.001 c0 (sph.Artificial.approach_band)
        cfg = cfg.replace(scheme=dataclasses.replace(cfg.scheme, viscosity=Artificial(approach_band=1e-3)))
    if "softfloor" in parts:  # the walls' pressure floor rounded over 0.1 rho0 g dx (sph.Adami.floor_band)
        band = 0.1 * 1000.0 * 9.81 * float(scene.meta.dx)
        cfg = cfg.replace(scheme=dataclasses.replace(cfg.scheme, walls=dataclasses.replace(cfg.scheme.walls, floor_band=band)))
    if "rebuild1" in parts:  # neighbour lists rebuilt before every step (another summation order)
        cfg = cfg.replace(rebuild_every=1)
    cpl = penalty.Penalty(onset=0.5, face_blend=0.1) if "coupling" in parts else cfg.coupling
    if "wideblend" in parts:  # the faces blended over half the penalty layer
        cpl = penalty.Penalty(onset=0.5, face_blend=0.5)
    return cfg.replace(blocks=blocks, coupling=cpl)


def laminar_params(params):
    """``params`` with the laminar viscosity that matches Monaghan's in 3D: nu = alpha h c0 / 10."""
    f = params.fluid
    return params.replace(fluid=f.replace(nu=f.alpha * f.h * f.c0 / 10.0))


def observer(scene, config):
    meta = scene.meta
    th = math.radians(meta["slope_angle_deg"])
    s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])
    y = 0.5 * meta["flume_width"]
    x = 0.30
    pts = jnp.asarray([[x, y]])
    bottom = jnp.asarray([max(-x * math.tan(th), -meta["water_depth"])])
    kw = dict(runup_kwargs(meta), temperature=0.25 * float(meta.dx))  # band 2 dx on the far beach

    def observe(state, params):
        eta = gauge_elevation(state, params, config, pts, bottom_z=bottom, still_level=meta["still_level"])
        return jnp.stack([state.blocks.x[0] @ s_dir, eta[0], smooth_runup(state, **kw)])

    return observe


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.05)
    ap.add_argument("--steps", type=int, default=1056)
    ap.add_argument("--variants", default="sharp,law,coupling,law+coupling,smooth")
    ap.add_argument("--leaves", default="blocks.density[0],blocks.friction_angle,fluid.alpha")
    ap.add_argument("--report-times", default="0.2,0.3,0.4,0.55,0.8")
    ap.add_argument("--water-depth", type=float, default=0.2,
                    help="m; 0.4 puts the slope's toe beyond the wedge's reach within 0.8 s")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    scene = wedge(a.dx, a.water_depth)
    leaves = a.leaves.split(",")
    dt = float(scene.config.dt)
    for name in a.variants.split(","):
        cfg = variant(scene, name)
        params = laminar_params(scene.params) if "laminar" in name.split("+") else scene.params
        observe = observer(scene, cfg)

        def run(p):
            final, obs = observed(cfg, p, a.steps, observe, state=scene.state)
            return obs, final.status

        fwd = jax.jit(run)
        t0 = time.perf_counter()
        obs0, status = fwd(params)
        obs0 = np.asarray(obs0)
        t_compile = time.perf_counter() - t0
        if int(status):
            emit(dict(variant=name, error=Status.describe(int(status))), a.out)
            continue
        t0 = time.perf_counter()
        fwd(params)[0].block_until_ready()
        t_fwd = time.perf_counter() - t0
        times = dt * cfg.rebuild_every * np.arange(1, obs0.shape[0] + 1)
        # the wedge reaches the water (its front at the shoreline) at once; the wave on the beach later
        ad, fd = {}, {}
        jvp = jax.jit(lambda p, tp: jax.jvp(lambda q: run(q)[0], (p,), (tp,))[1])
        t0 = time.perf_counter()
        for leaf in leaves:
            x0 = float(get_leaf(params, leaf))
            tang = jax.tree_util.tree_map(jnp.zeros_like, params)
            tang = set_leaf(tang, leaf, 1.0)
            ad[leaf] = np.asarray(jvp(params, tang))
            sec = []
            for r in STEPS:
                h = r * abs(x0)
                op = np.asarray(fwd(set_leaf(params, leaf, x0 + h))[0])
                om = np.asarray(fwd(set_leaf(params, leaf, x0 - h))[0])
                sec.append((op - om) / (2 * h))
            fd[leaf] = np.stack(sec)  # [steps, T, obs]
        t_checks = time.perf_counter() - t0
        summary = dict(variant=name, water_depth=a.water_depth, steps=a.steps, t_end=float(times[-1]), dt=dt, n_fluid=scene.config.n_fluid,
                       compile_s=round(t_compile, 1), forward_s=round(t_fwd, 2), checks_s=round(t_checks, 1),
                       runup_end=float(obs0[-1, 2]), wedge_s_end=float(obs0[-1, 0]))
        ok_frac = {}
        for leaf in leaves:
            for k, on in enumerate(OBS):
                verd = [classify(ad[leaf][t, k], STEPS, fd[leaf][:, t, k]) for t in range(len(times))]
                late = times >= 0.25
                ok_frac[f"{on}|{leaf}"] = round(float(np.mean([v == "ok" for v, l in zip(verd, late) if l])), 3)
                for tr in (float(s) for s in a.report_times.split(",")):
                    t = int(np.argmin(np.abs(times - tr)))
                    emit(dict(variant=name, water_depth=a.water_depth, leaf=leaf, obs=on, t=round(float(times[t]), 4), value=float(obs0[t, k]),
                              ad=float(ad[leaf][t, k]), fd={f"{r:.0e}": float(fd[leaf][i, t, k]) for i, r in enumerate(STEPS)},
                              verdict=verd[t]), a.out)
        summary["ok_fraction_after_0.25s"] = ok_frac
        emit(summary, a.out)


if __name__ == "__main__":
    main()
