"""SPH throughput on the 3D dam break (``rockjax.scenes.dam_break``): JSON lines, one per case.

Each case (fluid particle count x scheme) runs in its own subprocess so that peak memory
(``ru_maxrss``) and compile caches are per case. Per case it measures:

* ``compile_s``: lowering + compiling the chunk (``make_rollout``, no checkpointing) and the
  separate build / step functions;
* ``ms_build``: one neighbour-list rebuild (sort by cell + list), ``ms_step``: one step with a
  given list; ``ms_per_step``: a whole chunk of ``blocks * rebuild_every`` steps divided by its
  steps (rebuilds included) -- the number that counts;
* ``fluid_particle_steps_per_s`` (fluid particles x steps / s, the peers' metric) and
  ``total_particle_steps_per_s`` (fluid + wall particles);
* ``cpu_ms_per_step``: process CPU time per step (median chunk), steadier than wall time when
  other processes compete for the cores;
* ``peak_rss_mb``; ``cpu_util`` (process CPU seconds / wall seconds over the timed chunks, <= 2 on
  this machine) and the load average before and after: other agents share the 2 cores, so compare
  ratios within one run, and distrust a case whose ``cpu_util`` is far below ~1.8.

The chunk starts from the primed initial state (water at rest, breaking) and its final status
must be clean (no overflow, no stale list); a growable status bit is cured the way the driver
cures it for a rollout (``driver._grow_rollout``) and the case is rerun, the final capacities are reported.

* ``rebuilds``: list rebuilds in one timed chunk (block starts + displacement triggers, see
  ``rockjax.rollout.needs_rebuild``; ``--no-trigger`` for the fixed schedule only);
* ``warm_s``: simulated time [s] run before timing (``--warm-time``); from rest (0) the water is
  slow and displacement-triggered lists are rarely rebuilt, so time developed flow as well.

Usage: ``python experiments/bench_sph.py [--sizes 5k 20k 80k] [--schemes wcsph seed]
[--blocks 4] [--reps 3] [--skin-factor 0.6] [--rebuild-every 8] [--warm-time 0.3] [--no-trigger]
[--tag NAME]``; ``--ab 0.6:8:0 0.3:32:1 ...`` (SKIN:REBUILD_EVERY:TRIGGER) times those settings
interleaved in one process (first size only; the fair comparison on a shared machine).
Sizes follow the peers (``shared/peers/common.py``): a = 0.5 m column of 2 nx^3 particles,
nx = 14, 22, 34 (5488, 21296, 78608 fluid particles); ``160k`` is nx = 43.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import subprocess
import sys
import time

SIZES = {"5k": 14, "20k": 22, "80k": 34, "160k": 43}


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _sweeps(state) -> dict:
    """The last step's solver sweeps (DFSPH's ``Particles.solver``; empty for explicit schemes)."""
    solver = state.particles.solver
    if solver is None:
        return {}
    import numpy as np

    s = np.asarray(solver)
    return {"sweeps_density": int(s[:, 4].max()), "sweeps_divergence": int(s[:, 5].max())}


def run_case(size: str, scheme: str, *, blocks: int, reps: int, skin_factor: float | None,
             rebuild_every: int | None, warm_time: float = 0.0, trigger: bool = True, tag: str = "",
             diffusion: str | None = None, gather: str | None = None, row_tile: int | None = None,
             kernel: str | None = None, h_factor: float | None = None, cfl: float | None = None) -> dict:
    import jax
    import numpy as np

    import rockjax as rj
    from rockjax.driver import _grow_rollout, resize
    from rockjax.rollout import make_rollout, needs_rebuild
    from rockjax.step import advance, prime, refresh

    nx = SIZES[size]
    kw = {}
    if skin_factor is not None:
        kw["skin_factor"] = skin_factor
    if rebuild_every is not None:
        kw["rebuild_every"] = rebuild_every
    if h_factor is not None:
        kw["h_factor"] = h_factor
    if cfl is not None:
        kw["cfl"] = cfl
    fluid_scheme = rj.sph.from_names(scheme, kernel=kernel)
    if diffusion is not None and hasattr(fluid_scheme, "diffusion"):  # WCSPH's term; the seed scheme has none
        fluid_scheme = fluid_scheme.replace(diffusion=rj.sph.by_name("diffusion", diffusion))
    t0 = time.perf_counter()
    scene = rj.scenes.dam_break(dx=0.5 / nx, scheme=fluid_scheme, **kw)
    setup_s = time.perf_counter() - t0
    if gather is not None or row_tile is not None:  # speed settings (rockjax.Tuning)
        scene = scene.replace(config=scene.config.tuned(
            **({"gather": rj.GatherForm(gather)} if gather else {}), **({"row_tile": row_tile} if row_tile is not None else {})))
    config, params, state0 = scene.config, scene.params, scene.state
    counts = scene.counts()
    regrows = 0
    while True:
        t0 = time.perf_counter()
        prime_c = jax.jit(lambda s, p: prime(s, p, config)).lower(state0, params).compile()
        state = prime_c(state0, params)
        chunk = jax.jit(lambda s, p: make_rollout(config, blocks, checkpoint=False,
                                                  rebuild_on_displacement=trigger)(s, p)[0])
        chunk_c = chunk.lower(state, params).compile()
        compile_s = time.perf_counter() - t0
        warm_steps = 0
        while warm_steps * config.dt < warm_time - 1e-12:
            state = chunk_c(state, params)
            warm_steps += blocks * config.rebuild_every
        out = jax.block_until_ready(chunk_c(state, params))
        bits = int(out.status) | int(state.status)
        if bits & ~int(rj.Status.growable()):
            raise RuntimeError(f"{size}/{scheme}: fatal status {rj.Status.describe(bits)}")
        if not bits:
            break
        regrows += 1
        if regrows > 6:
            raise RuntimeError(f"{size}/{scheme}: gave up regrowing ({rj.Status.describe(bits)})")
        config = _grow_rollout(config, out if int(out.status) else state, bits)
        state0 = resize(state0, config)

    steps = blocks * config.rebuild_every

    def count_rebuilds(s, p):  # the timed chunk's schedule, counting its rebuilds
        def one(s, i):
            due = (i % config.rebuild_every == 0) | (trigger & needs_rebuild(s, config))
            s = jax.lax.cond(due, lambda s: refresh(s, config), lambda s: s, s)
            return advance(s, p, config), due
        return jax.lax.scan(one, s, jax.numpy.arange(steps))[1].sum()

    rebuilds = int(jax.jit(count_rebuilds)(state, params))
    load_before = os.getloadavg()[0]
    walls, cpus = [], []
    for _ in range(reps):
        c0, w0 = _cpu(), time.perf_counter()
        jax.block_until_ready(chunk_c(state, params))
        walls.append(time.perf_counter() - w0)
        cpus.append(_cpu() - c0)
    load_after = os.getloadavg()[0]
    wall = min(walls)

    t0 = time.perf_counter()
    refresh_c = jax.jit(lambda s: refresh(s, config)).lower(state).compile()
    advance_c = jax.jit(lambda s, p: advance(s, p, config)).lower(state, params).compile()
    compile_parts_s = time.perf_counter() - t0

    def best(f, *args, n=reps):
        jax.block_until_ready(f(*args))
        ts = []
        for _ in range(n):
            w0 = time.perf_counter()
            jax.block_until_ready(f(*args))
            ts.append(time.perf_counter() - w0)
        return min(ts)

    ms_build = 1e3 * best(refresh_c, state)
    ms_step = 1e3 * best(advance_c, state, params)
    nf, nw = counts["fluid"], counts["wall"]
    diffusion_term = getattr(config.scheme, "diffusion", None)  # WCSPH's; None for the seed scheme
    return {
        "bench": "sph_dam_break_3d", "tag": tag, "size": size, "scheme": scheme,
        "diffusion": diffusion_term.name if diffusion_term is not None else None,
        "gather": config.effective_gather.value, "row_tile": config.effective_row_tile, "n_fluid": nf, "n_wall": nw,
        "dx": 0.5 / nx, "dtype": str(np.asarray(state.particles.x).dtype),
        "kernel": config.scheme.kernel.name, "h_dx": round(float(params.fluid.h) / (0.5 / nx), 3),
        "dt": config.dt, "sim_s_per_wall_s": round(steps * config.dt / wall, 5), **_sweeps(out),
        "K": config.neighbour_capacity, "cell_capacity": config.cell_capacity,
        "skin_dx": round(config.skin / (0.5 / nx), 3), "rebuild_every": config.rebuild_every, "regrows": regrows,
        "trigger": trigger, "warm_s": round(warm_steps * config.dt, 4), "rebuilds": rebuilds,
        "steps_timed": steps, "reps": reps,
        "ms_per_step": round(1e3 * wall / steps, 2), "cpu_ms_per_step": round(1e3 * sorted(cpus)[len(cpus) // 2] / steps, 2), "ms_build": round(ms_build, 2), "ms_step": round(ms_step, 2),
        "ms_per_step_model": round(ms_step + ms_build / config.rebuild_every, 2),
        "fluid_particle_steps_per_s": round(nf * steps / wall),
        "total_particle_steps_per_s": round((nf + nw) * steps / wall),
        "compile_s": round(compile_s, 2), "compile_parts_s": round(compile_parts_s, 2), "setup_s": round(setup_s, 2),
        "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "cpu_util": round(sum(cpus) / sum(walls), 2), "load_before": round(load_before, 2),
        "load_after": round(load_after, 2), "jax": jax.__version__,
    }


def ab_case(size: str, specs: list[str], *, steps: int, reps: int, warm_time: float = 0.0, tag: str = "",
            scheme: str = "wcsph") -> dict:
    """Interleaved A/B in one process: for each spec ``SKIN:K:TRIGGER[:DIFFUSION]`` (skin / dx,
    rebuild_every, 0/1, optionally a density-diffusion name, ``rockjax.sph.names("diffusion")``) a chunk of ``steps`` steps (a multiple of every K) from the same initial state; reps are
    interleaved so the variants see the same machine load. Returns one record with per-spec
    best wall and median CPU ms per step and the rebuild counts."""
    import jax

    import rockjax as rj
    from rockjax.driver import _grow_rollout, resize
    from rockjax.rollout import make_rollout
    from rockjax.step import prime

    nx = SIZES[size]
    runs = {}
    for spec in specs:
        skin, k, trig, *diff = spec.split(":")
        kw = {"scheme": rj.sph.from_names(scheme, diffusion=diff[0]) if diff else rj.sph.from_names(scheme)}
        scene = rj.scenes.dam_break(dx=0.5 / nx, skin_factor=float(skin), rebuild_every=int(k), **kw)
        config, params, state0 = scene.config, scene.params, scene.state
        for _ in range(6):  # cure capacity bits the way the driver does
            state = jax.jit(lambda s, p, c=config: prime(s, p, c))(state0, params)
            run = jax.jit(lambda s, p, c=config, t=bool(int(trig)): make_rollout(
                c, steps // c.rebuild_every, checkpoint=False, rebuild_on_displacement=t)(s, p)[0])
            w = 0
            while w * config.dt < warm_time - 1e-12:
                state = run(state, params)
                w += steps
            out = jax.block_until_ready(run(state, params))
            bits = int(out.status) | int(state.status)
            if not bits:
                break
            if bits & ~int(rj.Status.growable()):
                raise RuntimeError(f"{spec}: {rj.Status.describe(bits)}")
            config = _grow_rollout(config, out if int(out.status) else state, bits)
            state0 = resize(state0, config)
        nf = scene.counts()["fluid"]
        runs[spec] = dict(run=run, state=state, params=params, K=config.neighbour_capacity,
                          k=config.rebuild_every, walls=[], cpus=[])
    for _ in range(reps):
        for spec, r in runs.items():
            c0, w0 = _cpu(), time.perf_counter()
            jax.block_until_ready(r["run"](r["state"], r["params"]))
            r["walls"].append(time.perf_counter() - w0)
            r["cpus"].append(_cpu() - c0)
    res = {}
    for spec, r in runs.items():
        wall = min(r["walls"])
        res[spec] = {"K": r["K"], "rebuild_every": r["k"], "ms_per_step": round(1e3 * wall / steps, 2),
                     "cpu_ms_per_step": round(1e3 * sorted(r["cpus"])[len(r["cpus"]) // 2] / steps, 2),
                     "fluid_particle_steps_per_s": round(nf * steps / wall)}
    return {"bench": "sph_dam_break_3d_ab", "tag": tag, "size": size, "scheme": scheme, "n_fluid": nf, "steps": steps, "reps": reps,
            "warm_s": warm_time, "specs": res, "load_after": round(os.getloadavg()[0], 2), "jax": jax.__version__,
            "date": datetime.date.today().isoformat()}


def main(argv=None):
    import rockjax as rj

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["5k", "20k", "80k"], choices=list(SIZES))
    ap.add_argument("--schemes", nargs="+", default=["wcsph", "seed"])
    ap.add_argument("--blocks", type=int, default=4, help="neighbour-list blocks per timed chunk")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--skin-factor", type=float, default=None, help="Verlet skin / dx (scene default if omitted)")
    ap.add_argument("--rebuild-every", type=int, default=None, help="steps per list (scene default if omitted)")
    ap.add_argument("--warm-time", type=float, default=0.0, help="simulated seconds to run before timing")
    ap.add_argument("--no-trigger", action="store_true", help="fixed rebuild schedule (no displacement trigger)")
    ap.add_argument("--tag", default="", help="label stored in each record")
    ap.add_argument("--diffusion", default=None, choices=rj.sph.names("diffusion"),
                    help="WCSPH density diffusion (scene default if omitted)")
    ap.add_argument("--ab", nargs="+", metavar="SKIN:K:TRIGGER[:DIFFUSION]",
                    help="interleaved in-process A/B of these settings (first size only), e.g. 0.6:8:0 0.3:32:1 "
                         "0.3:32:1:fourtakas_surface")
    ap.add_argument("--gather", default=None, choices=["components", "rows"], help="Tuning.gather (GatherForm)")
    ap.add_argument("--row-tile", type=int, default=None, help="Tuning.row_tile (0: one block)")
    ap.add_argument("--ab-steps", type=int, default=32)
    ap.add_argument("--kernel", default=None, choices=rj.sph.names("kernel"), help="the scheme's kernel")
    ap.add_argument("--h-factor", type=float, default=None, help="h / dx (scene default if omitted)")
    ap.add_argument("--cfl", type=float, default=None, help="the scene's CFL number (scene default if omitted)")
    ap.add_argument("--case", nargs=2, metavar=("SIZE", "SCHEME"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    opts = dict(blocks=args.blocks, reps=args.reps, skin_factor=args.skin_factor, rebuild_every=args.rebuild_every,
                warm_time=args.warm_time, trigger=not args.no_trigger, tag=args.tag,
                diffusion=args.diffusion, gather=args.gather, row_tile=args.row_tile,
                kernel=args.kernel, h_factor=args.h_factor, cfl=args.cfl)
    if args.ab:
        print(json.dumps(ab_case(args.sizes[0], args.ab, steps=args.ab_steps, reps=args.reps,
                                 warm_time=args.warm_time, tag=args.tag, scheme=args.schemes[0])), flush=True)
        return
    if args.case:
        print(json.dumps(run_case(args.case[0], args.case[1], **opts)), flush=True)
        return
    for size in args.sizes:
        for scheme in args.schemes:
            cmd = [sys.executable, os.path.abspath(__file__), "--case", size, scheme, "--blocks", str(args.blocks),
                   "--reps", str(args.reps), "--warm-time", str(args.warm_time), "--tag", args.tag]
            if args.no_trigger:
                cmd += ["--no-trigger"]
            if args.diffusion is not None:
                cmd += ["--diffusion", args.diffusion]
            if args.gather is not None:
                cmd += ["--gather", args.gather]
            if args.row_tile is not None:
                cmd += ["--row-tile", str(args.row_tile)]
            if args.skin_factor is not None:
                cmd += ["--skin-factor", str(args.skin_factor)]
            for flag, value in (("--kernel", args.kernel), ("--h-factor", args.h_factor), ("--cfl", args.cfl)):
                if value is not None:
                    cmd += [flag, str(value)]
            if args.rebuild_every is not None:
                cmd += ["--rebuild-every", str(args.rebuild_every)]
            proc = subprocess.run(cmd, capture_output=True, text=True)
            lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
            if proc.returncode or not lines:
                print(json.dumps({"bench": "sph_dam_break_3d", "size": size, "scheme": scheme,
                                  "error": (proc.stderr or proc.stdout).strip().splitlines()[-1:]}), flush=True)
            else:
                print(lines[-1], flush=True)


if __name__ == "__main__":
    main()
