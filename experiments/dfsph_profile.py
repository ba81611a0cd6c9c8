"""Where a DFSPH step's time goes, measured inside the compiled chunk: JSON lines.

The 3D dam break of ``compare_peers.py`` (5k / 20k / 80k water particles), ``DFSPH()`` defaults,
float32, started from the state after ``--warm`` chunks of the collapse. One compiled chunk of
``--steps`` steps (a scan of ``rollout.scheduled_step``) per variant, the variants timed in turns
(``--repeats`` rounds; min and median per step):

* ``scheduled``: the driver's schedule (a rebuild when a particle moved skin / 2: every step here);
* ``no_rebuild``: the list of the chunk's first step kept (the sums are then not the physics, but
  their cost is: the difference to ``scheduled`` is what the list rebuild costs inside the chunk);
* ``no_rebuild_no_divergence``: also without the divergence solve.

Functions compiled alone mislead here: the non-pressure pass cost 30-41 ms alone at 20k and the
same pass through WCSPH's row-blocked pair sums 8-12 ms, yet the chunk's step did not change (XLA
fuses it with its neighbours inside the scan; the direct sums were kept). So only in-chunk
differences are reported.

    .venv/bin/python experiments/dfsph_profile.py [--sizes 5k 20k] [--out experiments/results/dfsph_profile.jsonl]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import statistics
import time

from jsonl_out import emit

NX = {"5k": 14, "20k": 22, "80k": 34}


def profile(size: str, *, steps: int, warm: int, repeats: int) -> dict:
    import jax

    import rockjax as rj
    from rockjax.rollout import scheduled_step
    from rockjax.step import prime

    dx = 0.5 / NX[size]
    scene = rj.scenes.dam_break(dx=dx, scheme=rj.DFSPH())
    config, params = scene.config, scene.params
    state = jax.jit(lambda s, p: prime(s, p, config))(scene.state, params)
    no_div = config.replace(scheme=dataclasses.replace(config.scheme, divergence_solve=False))

    def chunk(cfg, **kw):
        one = scheduled_step(cfg, **kw)
        return jax.jit(lambda s, p: jax.lax.scan(lambda s, _: (one(s, p), None), s, None, length=steps)[0])

    variants = {"scheduled": chunk(config),
                "no_rebuild": chunk(config, period=10**9, rebuild_on_displacement=False),
                "no_rebuild_no_divergence": chunk(no_div, period=10**9, rebuild_on_displacement=False)}
    for _ in range(warm):
        state = jax.block_until_ready(variants["scheduled"](state, params))
    compiled = {k: f.lower(state, params).compile() for k, f in variants.items()}
    for f in compiled.values():
        jax.block_until_ready(f(state, params))
    times = {k: [] for k in compiled}
    for _ in range(repeats):
        for k, f in compiled.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f(state, params))
            times[k].append((time.perf_counter() - t0) / steps * 1e3)
    ms = {k: {"min": round(min(v), 2), "median": round(statistics.median(v), 2)} for k, v in times.items()}
    med = {k: v["median"] for k, v in ms.items()}
    return {"experiment": "dfsph_profile", "date": datetime.date.today().isoformat(), "size": size,
            "n_fluid": config.n_fluid, "n_wall": config.n_particles - config.n_fluid, "steps": steps,
            "t_start_s": round(warm * steps * config.dt, 4), "K": config.neighbour_capacity,
            "ms_per_step": ms,
            "rebuild_ms": round(med["scheduled"] - med["no_rebuild"], 2),
            "divergence_solve_ms": round(med["no_rebuild"] - med["no_rebuild_no_divergence"], 2),
            "rebuild_share": round((med["scheduled"] - med["no_rebuild"]) / med["scheduled"], 3)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["5k", "20k"], choices=list(NX))
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--warm", type=int, default=3, help="chunks run first (the collapse under way)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    for size in args.sizes:
        emit(profile(size, steps=args.steps, warm=args.warm, repeats=args.repeats), args.out)


if __name__ == "__main__":
    main()
