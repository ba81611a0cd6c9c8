"""DFSPH's two reverse modes of its solves against central secants, their cost and memory: JSON lines.

``DFSPH(gradient="unrolled")`` differentiates through the fixed sweeps of each solve (needs
``iterations=n``); ``gradient="implicit"`` applies the implicit function theorem at each solve's
result and solves the adjoint system with ``adjoint_iterations`` Jacobi sweeps (any forward:
fixed sweeps or the ``while_loop`` to tolerance). The implicit gradient is the derivative of the
*converged* solve: where the forward stopped short of convergence it differs from the derivative of
what was computed, by about the forward's own distance from convergence.

Scene: the gradient tests' dam break (``gradcases.tiny_dam_break``: a 0.3 x 0.3 x 0.5 m column,
dx 0.1 m, 45 fluid; ``--dx 0.05``: 360 fluid), laminar viscosity, float64, ``--steps`` steps.
Loss: the fluid's kinetic energy at the end [J]. Per case: the loss, ``rockjax.gradcheck`` on
``fluid.h`` and ``gravity[2]`` (AD, central secants at relative steps 1e-3 ... 1e-6, verdict), AD's
relative distance from the smallest-step secant that agrees with the next (``ad_vs_fd``), mean
sweeps per step of the last step's solves, value-and-grad time over forward time (medians of
``--repeats`` after a warm-up, compile excluded), and XLA's compiled temporary bytes of both.

    .venv/bin/python experiments/dfsph_adjoint.py [--dx 0.1] [--steps 16] [--out experiments/results/dfsph_adjoint.jsonl]
"""

from __future__ import annotations

import argparse
import datetime
import os
import statistics
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

from jsonl_out import emit  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "gradients"))

CASES = {  # name: DFSPH settings
    "unrolled_4": dict(iterations=4),
    "unrolled_8": dict(iterations=8),
    "unrolled_100": dict(iterations=100),
    "implicit_fixed_8": dict(iterations=8, gradient="implicit"),
    "implicit_tol_1e-3": dict(gradient="implicit"),
    "implicit_tol_1e-8": dict(gradient="implicit", tolerance=1e-8, divergence_tolerance=1e-8, max_iterations=1000),
    "implicit_tol_1e-8_adjoint_400": dict(gradient="implicit", tolerance=1e-8, divergence_tolerance=1e-8,
                                          max_iterations=1000, adjoint_iterations=400),
}


def _timed(fn, arg, repeats: int) -> float:
    jax.block_until_ready(fn(arg))
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(arg))
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def run_case(name: str, settings: dict, *, dx: float, steps: int, repeats: int) -> dict:
    import gradcases as gc

    import rockjax as rj
    from rockjax.calibrate import observed
    from rockjax.gradcheck import gradcheck
    from rockjax.observables import energies

    scene = gc.tiny_dam_break(scheme=rj.DFSPH(viscosity=rj.sph.Laminar(), **settings)) if dx == 0.1 else \
        rj.scenes.dam_break(dx=dx, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8,
                            tank_width=0.3, scheme=rj.DFSPH(viscosity=rj.sph.Laminar(), **settings))
    config, params = scene.config, scene.params

    def final(p):
        return observed(config, p, steps, None, state=scene.state)[0]

    def loss(p):
        return energies(final(p), p, config)["kinetic"]

    fwd = jax.jit(loss)
    vg = jax.jit(jax.value_and_grad(loss))
    mem = {k: f.lower(params).compile().memory_analysis() for k, f in (("forward", fwd), ("grad", vg))}
    t_fwd = _timed(fwd, params, repeats)
    t_vg = _timed(vg, params, repeats)
    last = jax.jit(final)(params)
    sweeps = last.particles.solver[0, 4:6]
    report = gradcheck(fwd, params, ["fluid.h", "gravity[2]"], steps=(1e-3, 1e-4, 1e-5, 1e-6), jit=False,
                       value_and_grad=vg)
    leaves = {}
    for c in report.leaves:
        conv = c.converged_fd
        leaves[c.path] = {"ad": c.ad, "fd": dict(zip([f"{r:.0e}" for r in c.steps], c.fd)), "verdict": c.verdict,
                          "ad_vs_fd": None if conv is None else abs(c.ad - conv) / max(abs(conv), 1e-300)}
    return {"experiment": "dfsph_adjoint", "date": datetime.date.today().isoformat(), "case": name, "settings": {k: v for k, v in settings.items()},
            "dx": dx, "n_fluid": config.n_fluid, "steps": steps, "dt": config.dt, "dtype": "float64",
            "loss": float(report.loss), "leaves": leaves,
            "last_step_sweeps": {"density": float(sweeps[0]), "divergence": float(sweeps[1])},
            "forward_s": round(t_fwd, 5), "grad_s": round(t_vg, 5), "grad_over_forward": round(t_vg / t_fwd, 2),
            "temp_bytes_forward": int(mem["forward"].temp_size_in_bytes),
            "temp_bytes_grad": int(mem["grad"].temp_size_in_bytes)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.1)
    ap.add_argument("--steps", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    for name in args.cases:
        emit(run_case(name, CASES[name], dx=args.dx, steps=args.steps, repeats=args.repeats), args.out)


if __name__ == "__main__":
    main()
