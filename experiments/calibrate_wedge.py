"""Inverse calibration of a sliding wedge: recover its density and friction angle from synthetic
observations of the wedge position and two wave gauges.

Scene: ``rockjax.scenes.sliding_wedge`` scaled down (dx = 0.05 m by default: a 0.2 m wedge on a
40 degree slope, friction 15 deg, density 2500 kg/m^3, 0.2 m of water, seed Eq 22 penalty
coupling), float64, ``--steps`` steps (default 248 = 0.19 s). Observations after every block of
``rebuild_every`` steps: the wedge's down-slope coordinate and the free-surface elevation at
x = 0.15 and 0.30 m (``observables.gauge_elevation``), made with the true parameters. The fit
starts from +20 % density and -20 % friction angle (``--start``) and runs
``rockjax.calibrate.calibrate`` (optax L-BFGS directions, host line search, log-space fields) on
the mean squared relative misfit (each observable scaled by the RMS of its signal).

Output: one JSON line per iteration on stdout and, in ``--out`` (default experiments/out):
``calibrate_wedge.json`` (truth, start, loss and parameter paths, errors, timings) and
``calibrate_wedge.png`` (loss and relative parameter error per iteration).

    .venv/bin/python experiments/calibrate_wedge.py [--dx 0.05] [--steps 248] [--max-iter 50]
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rockjax import Status, scenes  # noqa: E402
from rockjax.calibrate import calibrate, get_leaf, set_leaf, trajectory_loss  # noqa: E402
from rockjax.observables import gauge_elevation  # noqa: E402

FIELDS = ["blocks.density[0]", "blocks.friction_angle"]


def build(dx: float, slope_deg: float):
    return scenes.sliding_wedge(dx=dx, slope_angle_deg=slope_deg, block_length=0.2, block_width=0.2,
                                water_depth=0.2, flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                friction_angle_deg=15.0, block_density=2500.0)


def observer(scene):
    th = math.radians(scene.meta["slope_angle_deg"])
    s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])
    xs = np.array([0.15, 0.30])
    pts = jnp.asarray(np.stack([xs, np.full(2, 0.5 * scene.meta["flume_width"])], 1))
    bottom = jnp.asarray(np.maximum(-xs * math.tan(th), -scene.meta["water_depth"]))

    def observe(state, params):
        eta = gauge_elevation(state, params, scene.config, pts, bottom_z=bottom, still_level=scene.meta["still_level"])
        return jnp.concatenate([(state.blocks.x[0] @ s_dir)[None], eta])

    return observe, np.asarray(scene.state.blocks.x[0]) @ np.asarray(s_dir)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.05)
    ap.add_argument("--slope", type=float, default=40.0)
    ap.add_argument("--steps", type=int, default=248)
    ap.add_argument("--max-iter", type=int, default=50)
    ap.add_argument("--start", type=float, nargs=2, default=[1.2, 0.8], help="start / truth for density, friction")
    ap.add_argument("--out", default=str(pathlib.Path(__file__).resolve().parent / "out"))
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    scene = build(args.dx, args.slope)
    observe, pos0 = observer(scene)
    L = trajectory_loss(scene.config, args.steps, observe)
    vg = jax.jit(jax.value_and_grad(L, has_aux=True))
    nb = args.steps // scene.config.rebuild_every
    zero = jnp.zeros((nb, 3))
    truth = {f: float(get_leaf(scene.params, f)) for f in FIELDS}
    (_, (target, status)), _ = vg(scene.params, scene.state, zero, zero, zero)
    t_first = time.perf_counter() - t0
    if int(status):
        raise SystemExit(f"truth run status: {Status.describe(int(status))}")
    target = np.asarray(target)
    sig = target.copy()
    sig[:, 0] -= pos0
    scale = np.sqrt(np.mean(sig**2, axis=0))
    w = jnp.broadcast_to(jnp.asarray(1.0 / (target.size * scale**2)), target.shape)
    print(json.dumps(dict(event="setup", n_fluid=scene.config.n_fluid, n_wall=scene.config.n_wall, dt=scene.config.dt,
                          steps=args.steps, obs_scale=scale.tolist(), compile_and_first_grad_s=t_first)), flush=True)

    def value_and_grad(p):
        (value, (_, st)), g = vg(p, scene.state, jnp.asarray(target), zero, w)
        if int(st):
            raise FloatingPointError(f"status {Status.describe(int(st))} at {[float(get_leaf(p, f)) for f in FIELDS]}")
        return value, g

    start = scene.params
    for f, r in zip(FIELDS, args.start):
        start = set_leaf(start, f, r * truth[f])
    t1 = time.perf_counter()

    def cb(it, loss, vals):
        print(json.dumps(dict(event="iteration", iteration=it, loss=loss, values=vals,
                              rel_error={f: vals[f] / truth[f] - 1 for f in FIELDS},
                              elapsed_s=time.perf_counter() - t1)), flush=True)

    res = calibrate(None, start, FIELDS, value_and_grad=value_and_grad, max_iter=args.max_iter, tol_loss=1e-16,
                    callback=cb)
    err = {f: res.values[f] / truth[f] - 1 for f in FIELDS}
    out = dict(event="result", scene=dict(dx=args.dx, slope_deg=args.slope, steps=args.steps, dt=scene.config.dt,
                                          n_fluid=scene.config.n_fluid, n_wall=scene.config.n_wall),
               truth=truth, start={f: r * truth[f] for f, r in zip(FIELDS, args.start)}, rel_error=err,
               recovered_within_1pct=bool(all(abs(e) <= 0.01 for e in err.values())),
               seconds_per_eval=(time.perf_counter() - t1) / max(res.n_evals, 1),
               compile_and_first_grad_s=t_first, **res.to_json())
    print(json.dumps(out), flush=True)
    outdir = pathlib.Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    (outdir / "calibrate_wedge.json").write_text(json.dumps(out, indent=1))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
        ax[0].semilogy(res.loss_path, "o-")
        ax[0].set_xlabel("iteration")
        ax[0].set_ylabel("misfit (mean squared relative)")
        for f in FIELDS:
            ax[1].semilogy(np.abs(np.asarray(res.param_paths[f]) / truth[f] - 1) + 1e-16, "o-", label=f)
        ax[1].axhline(0.01, color="k", lw=0.8, ls="--", label="1 %")
        ax[1].set_xlabel("iteration")
        ax[1].set_ylabel("|value / truth - 1|")
        ax[1].legend(fontsize=8)
        fig.suptitle(f"sliding wedge calibration (dx={args.dx} m, {args.steps} steps, L-BFGS)")
        fig.tight_layout()
        fig.savefig(outdir / "calibrate_wedge.png", dpi=120)
    except ImportError:
        pass


if __name__ == "__main__":
    main()
