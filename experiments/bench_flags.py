"""XLA:CPU flags against XLA's defaults: step time of a fluid-only dam break (16k water particles),
the coupled sliding wedge (dx 0.04, boundary particles), a 100-box pile, and one dam-break step's
VJP. JSON lines out.

Variant ``no_ynn_fusions``: ``XLA_FLAGS=--xla_cpu_experimental_ynn_fusion_type=`` (jaxlib 0.10),
which stops XLA handing reductions and elementwise fusions to the YNNPACK library. XLA reads
its flags once per process, so each measurement is a fresh worker process; the variants alternate
round by round so that a slow spell of the shared machine hits both alike: compare within a round.

    .venv/bin/python experiments/bench_flags.py [--rounds 3] [--cases dam wedge pile vjp] [--out FILE]

VARIANTS maps a variant name to the XLA_FLAGS it runs with (the user's XLA_FLAGS are not passed on).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))

VARIANTS = {"xla_defaults": "", "no_ynn_fusions": "--xla_cpu_experimental_ynn_fusion_type="}


def _best(fn, args, reps):
    import jax

    jax.block_until_ready(fn(*args))
    best = float("inf")
    for _ in range(reps):
        t = time.perf_counter()
        jax.block_until_ready(fn(*args))
        best = min(best, time.perf_counter() - t)
    return best


def worker(case: str, reps: int) -> dict:
    import jax
    import jax.numpy as jnp

    import rockjax as rj

    steps = 16
    if case in ("dam", "wedge", "vjp"):
        if case == "wedge":
            scene = rj.scenes.sliding_wedge(dx=0.04, coupling=rj.Coupling.BOUNDARY_PARTICLES)
        else:
            scene = rj.scenes.dam_break(dx=0.5 / 20)
        config = scene.config
        state = jax.jit(rj.prime, static_argnums=2)(scene.state, scene.params, config)
        step = rj.make_step(config)
        if case == "vjp":
            from rockjax.step import advance

            def fn(s, p):
                out, pull = jax.vjp(lambda s, p: advance(s, p, config), s, p)
                return pull(out)

            f = jax.jit(fn)
            return dict(n_fluid=config.n_fluid, ms=1e3 * _best(f, (state, scene.params), 5 * reps))

        @jax.jit
        def chunk(s, p):
            return jax.lax.scan(lambda s, _: (step(s, p), None), s, None, length=steps)[0]

        return dict(n_fluid=config.n_fluid, ms_per_step=1e3 * _best(chunk, (state, scene.params), reps) / steps)
    if case == "pile":
        sys.path.insert(0, HERE)
        import rockjax.blocks as rb
        from bench_blocks import pile

        polys, pos = pile(100)
        motion = [rb.Motion.FIXED] + [rb.Motion.DYNAMIC] * 100
        cfg, par, st = rb.make_blocks(polys, positions=pos, motion=motion, normal_stiffness=1e7, shear_stiffness=4e6,
                                      broadphase=rb.Broadphase.GRID)
        dt = rb.stable_dt(cfg, par, st)
        g = jnp.asarray([0.0, 0.0, -9.81], st.x.dtype)

        @jax.jit
        def chunk(s):
            return jax.lax.scan(lambda s, _: (rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=g)[0], None), s,
                                None, length=steps)[0]

        return dict(n_blocks=100, ms_per_step=1e3 * _best(chunk, (st,), reps) / steps)
    raise ValueError(f"unknown case {case!r}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--cases", nargs="+", default=["dam", "wedge", "pile", "vjp"])
    ap.add_argument("--out", default=None, help="also append the records to this JSON-lines file")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        import jax

        rec = worker(a.worker, a.reps)
        rec.update(xla_flags=os.environ.get("XLA_FLAGS", ""), jaxlib=jax.__version__)
        print(json.dumps(rec), flush=True)
        return
    sys.path.insert(0, HERE)
    from jsonl_out import emit

    for rnd in range(a.rounds):
        for case in a.cases:
            for flags, value in VARIANTS.items():
                env = dict(os.environ)
                env.pop("XLA_FLAGS", None)
                if value:
                    env["XLA_FLAGS"] = value
                out = subprocess.run([sys.executable, __file__, "--worker", case, "--reps", str(a.reps)], env=env,
                                     capture_output=True, text=True, check=True).stdout
                rec = json.loads(out.strip().splitlines()[-1])
                emit(dict(bench="xla_flags", case=case, flags=flags, round=rnd, date=time.strftime("%Y-%m-%d"),
                          load=os.getloadavg()[0], **rec), a.out)


if __name__ == "__main__":
    main()
