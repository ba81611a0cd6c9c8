"""Calibration over the full wedge event (issue 44, item 5): density and friction angle from gauge,
run-up and wedge records through the impact to 0.8 s, with the slope at a stated scale.

Scene: the gradient tests' wedge (``smoothness_ab.wedge``: 408 water particles) with
``calibrate.smooth_config``, float64, ``--steps`` (default 1056 = 0.80 s). Observations after
every block of 8 steps: the wedge's down-slope coordinate, the free-surface elevation at
x = 0.30 m, the smooth run-up on the far beach; synthetic, from each truth (``--truths``: density
kg/m^3 : friction deg), optionally with Gaussian noise of ``--noise`` x each signal's RMS. The fit
starts from +20 % density and -20 % friction angle and runs ``calibrate.calibrate`` (L-BFGS in log
space) on the mean squared relative misfit with ``calibrate.secant_value_and_grad`` (central
secants over ``--rel-step`` of each field: over this horizon the exact gradient is local, see
``smoothness_ab.py``). With noise, the posterior spread is the Gauss-Newton one:
``cov = (J^T W J)^-1`` with J the observations' secant Jacobian at the fit and W the inverse noise
variances.

Output: one JSON line per truth (``--out``): truth, start, fitted values and errors, iterations,
evaluations, wall time, and the posterior standard deviations when noisy.

    .venv/bin/python experiments/calibrate_full_event.py [--truths 2500:15,2200:20,2800:10] [--noise 0]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rockjax.calibrate import calibrate, get_leaf, observed, secant_value_and_grad, set_leaf, smooth_config  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402
from smoothness_ab import observer, wedge  # noqa: E402

FIELDS = ["blocks.density[0]", "blocks.friction_angle"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1056)
    ap.add_argument("--truths", default="2500:15,2200:20,2800:10")
    ap.add_argument("--noise", type=float, default=0.0, help="noise std as a fraction of each signal's RMS")
    ap.add_argument("--rel-step", type=float, default=1e-2)
    ap.add_argument("--max-iter", type=int, default=25)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    scene = wedge(0.05)
    cfg = smooth_config(scene.config)
    observe = observer(scene, cfg)
    run = jax.jit(lambda p: observed(cfg, p, a.steps, observe, state=scene.state)[1])
    s0 = np.asarray(observe(scene.state, scene.params))
    rng = np.random.default_rng(a.seed)
    for spec in a.truths.split(","):
        rho, phi_deg = (float(v) for v in spec.split(":"))
        truth = set_leaf(set_leaf(scene.params, FIELDS[0], rho), FIELDS[1], math.radians(phi_deg))
        clean = np.asarray(run(truth))
        sig = clean - s0[None, :]
        rms = np.sqrt(np.mean(sig ** 2, axis=0))
        noise_std = a.noise * rms
        data = clean + rng.normal(size=clean.shape) * noise_std[None, :]
        w = 1.0 / (data.size * rms ** 2)
        target, weights = jnp.asarray(data), jnp.asarray(np.broadcast_to(w, data.shape))

        def loss(p):
            return jnp.sum(weights * (run(p) - target) ** 2)

        vg = secant_value_and_grad(loss, FIELDS, rel_step=a.rel_step)
        start = set_leaf(set_leaf(truth, FIELDS[0], 1.2 * rho), FIELDS[1], 0.8 * math.radians(phi_deg))
        t0 = time.perf_counter()
        res = calibrate(None, start, FIELDS, value_and_grad=vg, max_iter=a.max_iter, tol_loss=1e-14)
        wall = time.perf_counter() - t0
        tv = {FIELDS[0]: rho, FIELDS[1]: math.radians(phi_deg)}
        rec = dict(kind="calibrate_full_event", steps=a.steps, t_end=round(a.steps * float(cfg.dt), 4), truth=spec,
                   noise=a.noise, rel_step=a.rel_step, start={f: float(get_leaf(start, f)) for f in FIELDS},
                   values=res.values, rel_error={f: res.values[f] / tv[f] - 1 for f in FIELDS},
                   loss_start=res.loss_path[0], loss_end=res.loss_path[-1], n_iter=res.n_iter, n_evals=res.n_evals,
                   converged=res.converged, wall_s=round(wall, 1))
        if a.noise > 0:
            # Gauss-Newton posterior: J = d obs / d field (secants), W = 1 / noise variance
            J = []
            for f in FIELDS:
                x0 = res.values[f]
                h = a.rel_step * abs(x0)
                J.append(((np.asarray(run(set_leaf(res.params, f, x0 + h)))
                           - np.asarray(run(set_leaf(res.params, f, x0 - h)))) / (2 * h)).reshape(-1))
            J = np.stack(J, 1)
            Wn = np.broadcast_to(1.0 / noise_std ** 2, data.shape).reshape(-1)
            cov = np.linalg.inv(J.T @ (Wn[:, None] * J))
            sd = np.sqrt(np.diag(cov))
            rec["posterior_sd"] = {f: float(s) for f, s in zip(FIELDS, sd)}
            rec["posterior_sd_rel"] = {f: float(s / tv[f]) for f, s in zip(FIELDS, sd)}
            rec["error_in_sd"] = {f: float((res.values[f] - tv[f]) / s) for f, s in zip(FIELDS, sd)}
        emit(rec, a.out)


if __name__ == "__main__":
    main()
