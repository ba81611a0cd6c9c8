"""Verlet skin against step time on the 3D dam break, at rest and in the developed collapse: JSON lines.

For each skin (Verlet skin / dx) the peers' dam break (``scenes.dam_break``, 0.5 x 0.5 x 1.0 m
column) is first run with ``rockjax.simulate`` to ``--t-flow`` (default 0.3 s: the surge is
running along the floor, the fastest particles move ~0.04 dx per step), which also grows any
capacity the flow needs. Then chunks of ``--steps`` steps of the driver's schedule
(``rollout.scheduled_step``: list rebuilt at least every 32 steps and whenever a particle would move
more than skin / 2) are timed from two states: ``rest`` (the initial column, where only the
32-step rebuilds happen) and ``flow`` (the state at ``--t-flow``, where the displacement trigger
rebuilds every few steps). The variants are timed interleaved, ``--rounds`` times, best kept, so
their ratios come from one run on one machine.

Printed per (skin, state): ``K`` (neighbour slots per particle), ``cell_capacity``, ``ms_step``,
``fluid_particle_steps_per_s``, ``rebuilds`` per chunk (counted by replaying the chunk with a
counter), and ``vs_first`` (speed relative to the first skin listed, same state).

Usage: ``python experiments/bench_skin.py [--nx 22] [--skins 0.6 0.45 0.3] [--out FILE]``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import time


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, nargs="+", default=[22], help="particles across the 0.5 m column (22: 21k)")
    ap.add_argument("--skins", type=float, nargs="+", default=[0.6, 0.45, 0.3])
    ap.add_argument("--t-flow", type=float, default=0.3)
    ap.add_argument("--steps", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", default=None, help="also append the JSON lines to this file")
    args = ap.parse_args(argv)

    import jax
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.driver import resize
    from rockjax.rollout import needs_rebuild, scheduled_step
    from rockjax.step import prime, refresh

    try:
        commit = os.popen("git -C %s rev-parse --short HEAD 2>/dev/null" % os.path.dirname(__file__)).read().strip()
    except OSError:
        commit = ""
    meta = {"date": datetime.date.today().isoformat(), "host_cpus": os.cpu_count(), "machine": platform.machine(),
            "jax": jax.__version__, "backend": jax.default_backend(), "git": commit}
    out = open(args.out, "a") if args.out else None
    for nx in args.nx:
        runs = []
        for skin in args.skins:
            scene = rj.scenes.dam_break(dx=0.5 / nx, skin_factor=skin)
            res = rj.simulate(scene, t_end=args.t_flow, frame_dt=args.t_flow, progress=False)
            cfg, params = res.scene.config, scene.params
            rest = jax.jit(lambda s, p, cfg=cfg: prime(refresh(s, cfg), p, cfg))(resize(scene.state, cfg), params)
            flow = res.state.replace(step=jnp.zeros((), jnp.int32))
            one = scheduled_step(cfg, period=32)

            def chunk(s, p, one=one):
                return jax.lax.scan(lambda s, _: (one(s, p), None), s, None, length=args.steps)[0]

            def count(s, p, one=one, cfg=cfg):  # rebuilds in a chunk (same rule as scheduled_step)
                def body(c, _):
                    s, n = c
                    n = n + ((s.step % 32 == 0) | needs_rebuild(s, cfg)).astype(jnp.int32)
                    return (one(s, p), n), None
                return jax.lax.scan(body, (s, jnp.zeros((), jnp.int32)), None, length=args.steps)[0][1]

            f = jax.jit(chunk)
            rebuilds = {w: int(jax.jit(count)(s, params)) for w, s in (("rest", rest), ("flow", flow))}
            runs.append(dict(skin=skin, cfg=cfg, f=f, states={"rest": rest, "flow": flow}, params=params,
                             rebuilds=rebuilds, times={"rest": [], "flow": []}))
        for _ in range(args.rounds):
            for r in runs:
                for w, s in r["states"].items():
                    jax.block_until_ready(r["f"](s, r["params"]))
                    t0 = time.perf_counter()
                    jax.block_until_ready(r["f"](s, r["params"]))
                    r["times"][w].append(time.perf_counter() - t0)
        first = {}
        for r in runs:
            cfg = r["cfg"]
            for w in ("rest", "flow"):
                t = min(r["times"][w]) / args.steps
                first.setdefault(w, t)
                rec = {"bench": "skin", "case": "dambreak3d", "nx": nx, "n_fluid": cfg.n_fluid, "n_wall": cfg.n_wall,
                       "skin_dx": r["skin"], "K": cfg.neighbour_capacity, "cell_capacity": cfg.cell_capacity,
                       "state": w, "t_flow_s": args.t_flow if w == "flow" else 0.0, "steps": args.steps,
                       "rebuilds": r["rebuilds"][w], "ms_step": round(t * 1e3, 3),
                       "fluid_particle_steps_per_s": round(cfg.n_fluid / t), "vs_first": round(first[w] / t, 3),
                       "load_avg_1m": round(os.getloadavg()[0], 2), **meta}
                print(json.dumps(rec), flush=True)
                if out:
                    out.write(json.dumps(rec) + "\n")
    if out:
        out.close()


if __name__ == "__main__":
    main()
