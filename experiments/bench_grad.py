"""Gradient and ensemble benchmarks: backward/forward time ratio, reverse-mode memory against the
number of steps, and ensemble throughput. JSON lines on stdout.

1. For T, 4T, 16T steps (``--base-steps`` T, default 2 list rebuilds): the forward rollout
   (``checkpoint=False``), ``jax.value_and_grad`` of the checkpointed rollout (nested
   ``jax.checkpoint`` chunks of ~sqrt(blocks), ``rockjax.rollout``) and, for memory only, the
   un-checkpointed gradient. Time: median of ``--repeats`` runs after a warm-up (compile
   excluded). Memory: XLA's compiled ``memory_analysis()`` -- temporary buffers of the compiled
   program (``temp_bytes``), which is the peak working set beyond inputs and outputs; it is
   deterministic, unlike process RSS on a shared machine.
2. Ensemble throughput (forward, ``rockjax.ensembles.ensemble`` of a rollout on the fixed rebuild
   schedule) at batch 1, 8, 64, against running the same members one by one with a jitted
   single-member rollout: scenario-steps/s; mode ``vmap`` (all members in one ``jax.vmap``,
   ``batch_size=None``) and ``map`` (one member at a time in a ``lax.map``, ``batch_size=1``, the
   CPU default).

3. ``--adjoint-ab``: the checkpointed gradient of ``--base-steps`` steps under each
   ``Tuning.adjoint`` (``AUTODIFF``: JAX transposes the neighbour gathers; ``PAIR_SUMS``: the
   gather-only custom VJP of ``rockjax.sph.pair_sum``, with the hand-derived pullbacks of
   ``rockjax.sph.pullbacks`` and with JAX's VJP of each pair function), each with the forward in
   one block (``row_tile`` 0) and in blocks of 512 rows (``--ab-tiles``), compiled in one process
   and timed alternately (``--repeats`` rounds; medians): the ratios hold on a shared machine.
4. ``--levels-ab 1 2``: the same for the rollout's ``checkpoint_levels`` (chunks only, or chunks
   and steps), with the scene's adjoint, and the compiled gradient's XLA temporary bytes; under
   ``PAIR_SUMS`` levels >= 2 with and without the steps saving the pair sums' outputs
   (``Tuning.save_pair_sums``).

Scenes (``--scene``): ``dam`` (default: a 0.3 x 0.3 x 0.5 m dam break at dx = 0.05 m, fluid
only; ``--dx 0.025``: 2 880 fluid), ``incline`` (blocks only), ``wedge`` (coupled, dx = 0.05 m).
``--f64`` for float64.

    .venv/bin/python experiments/bench_grad.py [--scene dam] [--base-steps 16] [--f64]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time

from rockjax.types import Adjoint, GatherForm


def build(name: str, dx: float = 0.05, dfsph_iterations: int | None = None):
    import numpy as np

    from rockjax import scenes

    if name == "dam":
        kw = {}
        if dfsph_iterations:  # the differentiable DFSPH: fixed sweeps; its list is rebuilt every step
            from rockjax import DFSPH

            kw = dict(scheme=DFSPH(iterations=dfsph_iterations), rebuild_every=1)
        return scenes.dam_break(dx=dx, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8,
                                tank_width=0.3, **kw)
    if name == "wedge":
        return scenes.sliding_wedge(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2,
                                    water_depth=0.2, flat_length=0.4, flume_width=0.4, start_distance=0.0)
    if name == "incline":
        from rockjax import blocks as B
        from rockjax.scenes.coupled import coupled_scene

        geo = B.geometry
        th = math.radians(30.0)
        n = np.array([math.sin(th), 0.0, math.cos(th)])
        c, s = math.cos(th), math.sin(th)
        box = geo.box(0.2, 0.2, 0.1)
        tilted = geo.ConvexPolyhedron.from_vertices(
            box.vertices @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]).T + 0.05 * n)
        slope = geo.slope(4.0, 2.0, 0.2, 30.0)
        return coupled_scene(name="incline", dx=None, polyhedra=[tilted, slope],
                             positions=[tilted.centroid_world, slope.centroid_world],
                             motion=(B.Motion.DYNAMIC, B.Motion.FIXED), block_density=2500.0,
                             friction_angle_deg=20.0, block_kwargs=dict(penalty_modulus=1e7))
    raise SystemExit(f"unknown scene {name!r}")


def objective(scene):
    """A scalar of the final state that depends on every part of the scene."""
    import jax.numpy as jnp

    def f(state, params):
        out = 0.0
        if state.particles is not None:
            m = state.particles.kind == 0
            out = out + jnp.sum(jnp.where(m[:, None], state.particles.v**2, 0.0))
        if state.blocks is not None:
            out = out + jnp.sum(state.blocks.x[0])
        return out

    return f


def timed(fn, *args, repeats: int):
    import jax

    jax.block_until_ready(fn(*args))  # warm-up (compile)
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(fn(*args))
        ts.append(time.perf_counter() - t)
    return statistics.median(ts)


def alternated(fns: dict, *args, repeats: int) -> dict:
    """Median seconds of each ``fns[key](*args)``, the functions called in turn ``repeats`` times
    after one warm-up call each (this machine's load moves single timings by tens of per cent)."""
    import jax

    for f in fns.values():
        jax.block_until_ready(f(*args))
    times = {k: [] for k in fns}
    for _ in range(max(1, repeats)):
        for k, f in fns.items():
            t = time.perf_counter()
            jax.block_until_ready(f(*args))
            times[k].append(time.perf_counter() - t)
    return {k: statistics.median(ts) for k, ts in times.items()}


def step_vjp(config, state, params, repeats: int) -> dict:
    """One step (``rockjax.step.advance``): forward and forward + vector-Jacobian product (best of
    ``5 * repeats`` runs: the per-step times are short and the machine is shared), and, in each
    compiled program, the number of instructions producing an [n_fluid, K] pair array (what a pass
    materialises in memory) and of scatter instructions (XLA's transpose of a gather)."""
    import re

    import jax

    from rockjax.step import advance

    def fwd(s, p):
        return advance(s, p, config)

    def vjp(s, p):
        out, pull = jax.vjp(fwd, s, p)
        return pull(out)

    nf, K = config.n_fluid, config.neighbour_capacity
    pair_shapes = (f"[{nf},{K}]", f"[{nf * K},1]", f"[{nf * K}]")
    out = dict(bench="step_vjp", neighbour_capacity=K, row_tile=config.effective_row_tile)
    for name, fn in (("forward", fwd), ("vjp", vjp)):
        f = jax.jit(fn)
        hlo = f.lower(state, params).compile().as_text()
        entry = hlo[hlo.index("ENTRY"):]
        defs = re.findall(r"^\s*(?:ROOT )?%\S+ = (\S+) ([\w-]+)\(", entry, flags=re.M)
        out[f"{name}_pair_arrays"] = sum(1 for shp, op in defs if op not in ("parameter", "bitcast")
                                         and any(p in shp for p in pair_shapes))
        out[f"{name}_scatters"] = len(re.findall(r" scatter\(", hlo))
        ts = []
        jax.block_until_ready(f(state, params))
        for _ in range(5 * repeats):
            t = time.perf_counter()
            jax.block_until_ready(f(state, params))
            ts.append(time.perf_counter() - t)
        out[f"{name}_ms"] = 1e3 * min(ts)
    out["vjp_over_forward"] = out["vjp_ms"] / out["forward_ms"]
    return out


def adjoint_ab(scene, steps: int, repeats: int, tiles=(0, 512)) -> list[dict]:
    """Forward and checkpointed-gradient times of ``steps`` steps per (adjoint, row_tile, pullbacks), interleaved:
    ``PAIR_SUMS`` with the hand-derived pullbacks of ``sph.pullbacks`` and with JAX's VJP of each pair function."""
    import jax

    from rockjax import prime
    from rockjax.calibrate import observed

    obj = objective(scene)
    variants = [(a, t, hand) for t in tiles for a in Adjoint for hand in ((True, False) if a == Adjoint.PAIR_SUMS
                                                                            else (False,))]
    fns = {}
    for adjoint, tile, hand in variants:
        config = scene.config.tuned(adjoint=adjoint, row_tile=tile, hand_pullbacks=hand)
        state0 = jax.jit(prime, static_argnums=2)(scene.state, scene.params, config)

        def fwd(p, config=config, state0=state0):
            return obj(observed(config, p, steps, None, state=state0, checkpoint=False, prime=False)[0], p)

        def loss(p, config=config, state0=state0):
            return obj(observed(config, p, steps, None, state=state0, checkpoint=True, prime=False)[0], p)

        fns[adjoint, tile, hand, "forward"] = jax.jit(fwd).lower(scene.params).compile()
        fns[adjoint, tile, hand, "grad"] = jax.jit(jax.grad(loss)).lower(scene.params).compile()
    times = alternated(fns, scene.params, repeats=repeats)
    best_fwd = min(times[v + ("forward",)] for v in variants)
    out = []
    for adjoint, tile, hand in variants:
        f, g = times[adjoint, tile, hand, "forward"], times[adjoint, tile, hand, "grad"]
        out.append(dict(bench="adjoint_ab", adjoint=adjoint.value, row_tile=tile, steps=steps, repeats=repeats,
                        pullbacks=("hand" if hand else "jax") if adjoint == Adjoint.PAIR_SUMS else None,
                        forward_s=f, grad_s=g, grad_over_forward=g / f, grad_over_best_forward=g / best_fwd,
                        date=time.strftime("%Y-%m-%d")))
    return out


def levels_ab(scene, steps: int, repeats: int, levels=(1, 2)) -> list[dict]:
    """The checkpointed gradient of ``steps`` steps per ``checkpoint_levels`` (the scene's adjoint),
    compiled in one process and timed alternately with the forward; XLA's temporary bytes too."""
    import jax

    from rockjax import prime
    from rockjax.calibrate import observed

    obj = objective(scene)
    config = scene.config
    state0 = jax.jit(prime, static_argnums=2)(scene.state, scene.params, config)

    def fwd(p):
        return obj(observed(config, p, steps, None, state=state0, checkpoint=False, prime=False)[0], p)

    fns = {"forward": jax.jit(fwd).lower(scene.params).compile()}
    variants = [(lv, save) for lv in levels
                for save in ((True, False) if lv >= 2 and config.effective_adjoint == Adjoint.PAIR_SUMS else (True,))]
    for lv, save in variants:
        def loss(p, lv=lv, cfg=config.tuned(save_pair_sums=save)):
            return obj(observed(cfg, p, steps, None, state=state0, checkpoint=True, prime=False,
                                checkpoint_levels=lv)[0], p)

        fns[lv, save] = jax.jit(jax.grad(loss)).lower(scene.params).compile()
    times = alternated(fns, scene.params, repeats=repeats)
    f = times["forward"]
    return [dict(bench="levels_ab", checkpoint_levels=lv, saved_pair_sums=save, adjoint=config.effective_adjoint.value,
                 steps=steps, repeats=repeats, forward_s=f, grad_s=times[lv, save],
                 grad_over_forward=times[lv, save] / f,
                 grad_temp_bytes=int(fns[lv, save].memory_analysis().temp_size_in_bytes),
                 date=time.strftime("%Y-%m-%d"))
            for lv, save in variants]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="dam", choices=["dam", "incline", "wedge"])
    ap.add_argument("--base-steps", type=int, default=None, help="T (default 2 list rebuilds)")
    ap.add_argument("--multiples", type=int, nargs="+", default=[1, 4, 16])
    ap.add_argument("--batches", type=int, nargs="+", default=[1, 8, 64])
    ap.add_argument("--ensemble-steps", type=int, default=None, help="steps per member (default T)")
    ap.add_argument("--ensemble-modes", nargs="+", default=["vmap", "map"], choices=["vmap", "map"],
                    help="ensembles.ensemble's batch_size None (vmap: all members at once) and 1 (map)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--f64", action="store_true")
    ap.add_argument("--adjoint", default=None, choices=[a.value for a in Adjoint],
                    help="Tuning.adjoint: how reverse mode goes through the WCSPH pair sums (default: the scene's)")
    ap.add_argument("--dx", type=float, default=0.05, help="particle spacing of the dam scene m (0.05: 360 fluid)")
    ap.add_argument("--gather", default=None, choices=["components", "rows"], help="Tuning.gather (GatherForm)")
    ap.add_argument("--skip-grad", action="store_true")
    ap.add_argument("--dfsph-iterations", type=int, default=None,
                    help="dam scene with DFSPH(iterations=N) (fixed sweeps per solve), list rebuilt every step")
    ap.add_argument("--skip-ensemble", action="store_true")
    ap.add_argument("--levels", type=int, default=2, choices=[1, 2, 3],
                    help="checkpoint levels (rollout's checkpoint_levels): 1 chunks, 2 + steps, 3 + blocks")
    ap.add_argument("--chunk", type=int, default=None, help="blocks per checkpointed chunk (default sqrt)")
    ap.add_argument("--step-vjp", action="store_true",
                    help="only the per-step probe: one step's forward and vector-Jacobian product (time, and the "
                         "[n_fluid, K] arrays and scatter-adds of the compiled programs)")
    ap.add_argument("--levels-ab", type=int, nargs="+", default=None,
                    help="only the interleaved A/B of checkpoint_levels (e.g. 1 2) at --base-steps steps")
    ap.add_argument("--ab-tiles", type=int, nargs="+", default=[0, 512], help="row tiles of --adjoint-ab")
    ap.add_argument("--jax-pullbacks", action="store_true",
                    help="PAIR_SUMS with JAX's VJP of each pair function instead of the hand-derived pullbacks")
    ap.add_argument("--backward-tile", type=int, default=None,
                    help="rows per block of PAIR_SUMS's backward where the forward is one block "
                         "(Tuning.backward_tile, 512; 0 = one block, for accelerators)")
    ap.add_argument("--adjoint-ab", action="store_true",
                    help="only the interleaved A/B of Tuning.adjoint x row_tile (0, 512) at --base-steps steps")
    ap.add_argument("--time-plain", action="store_true",
                    help="also time the un-checkpointed gradient (memory grows like T)")
    args = ap.parse_args(argv)

    import jax

    if args.f64:
        jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    from rockjax import ensembles, prime
    from rockjax.calibrate import observed
    from rockjax.rollout import default_chunk

    scene = build(args.scene, args.dx, args.dfsph_iterations)
    if args.jax_pullbacks:
        scene = scene.replace(config=scene.config.tuned(hand_pullbacks=False))
    if args.backward_tile is not None:
        scene = scene.replace(config=scene.config.tuned(backward_tile=args.backward_tile))
    if args.adjoint:
        scene = scene.replace(config=scene.config.tuned(adjoint=Adjoint(args.adjoint)))
    if args.gather:  # GatherForm: a speed setting (rows: one row gather of the stacked values)
        scene = scene.replace(config=scene.config.tuned(gather=GatherForm(args.gather)))
    config = scene.config
    k = config.rebuild_every
    T = args.base_steps or 2 * k
    obj = objective(scene)
    base = dict(scene=args.scene, scheme=config.scheme.name, sweeps=getattr(config.scheme, "iterations", None),
                n_fluid=config.n_fluid, n_wall=config.n_wall,
                n_blocks=(config.blocks.n_blocks if config.blocks else 0), dtype="f64" if args.f64 else "f32",
                adjoint=config.effective_adjoint.value, gather=config.effective_gather.value, row_tile=config.effective_row_tile,
                jax_pullbacks=args.jax_pullbacks, backward_tile=args.backward_tile,
                dt=config.dt, rebuild_every=k, device=str(jax.devices()[0].platform))
    state0 = jax.jit(prime, static_argnums=2)(scene.state, scene.params, config)
    if args.step_vjp:
        print(json.dumps(dict(base, **step_vjp(config, state0, scene.params, args.repeats))), flush=True)
        return
    if args.levels_ab:
        for rec in levels_ab(scene, T, args.repeats, tuple(args.levels_ab)):
            print(json.dumps(dict(base, **rec)), flush=True)
        return
    if args.adjoint_ab:
        for rec in adjoint_ab(scene, T, args.repeats, tuple(args.ab_tiles)):
            print(json.dumps(dict(base, **rec)), flush=True)
        return

    if not args.skip_grad:
        for mult in args.multiples:
            n = mult * T

            def fwd(p, n=n):
                s, _ = observed(config, p, n, None, state=state0, checkpoint=False, prime=False)
                return obj(s, p)

            def loss(p, n=n, ck=True):
                s, _ = observed(config, p, n, None, state=state0, checkpoint=ck, prime=False,
                                checkpoint_levels=args.levels, chunk=args.chunk)
                return obj(s, p)

            f_jit = jax.jit(fwd)
            g_jit = jax.jit(jax.value_and_grad(loss))
            g_plain = jax.jit(jax.value_and_grad(lambda p, n=n: loss(p, n, False)))
            mem = {}
            for name, fn in (("forward", f_jit), ("grad_checkpointed", g_jit), ("grad_plain", g_plain)):
                t = time.perf_counter()
                c = fn.lower(scene.params).compile()
                ma = c.memory_analysis()
                mem[name] = dict(temp_bytes=int(ma.temp_size_in_bytes), compile_s=time.perf_counter() - t)
            t_f = timed(f_jit, scene.params, repeats=args.repeats)
            t_g = timed(g_jit, scene.params, repeats=args.repeats)
            extra = {}
            if args.time_plain:
                t_p = timed(g_plain, scene.params, repeats=args.repeats)
                extra = dict(grad_plain_s=t_p, grad_plain_over_forward=t_p / t_f)
            print(json.dumps(dict(base, bench="grad", steps=n, multiple=mult, blocks=n // k,
                                  checkpoint_levels=args.levels,
                                  chunk=args.chunk or default_chunk(n // k), forward_s=t_f, grad_s=t_g, grad_over_forward=t_g / t_f,
                                  forward_temp_bytes=mem["forward"]["temp_bytes"],
                                  grad_checkpointed_temp_bytes=mem["grad_checkpointed"]["temp_bytes"],
                                  grad_plain_temp_bytes=mem["grad_plain"]["temp_bytes"],
                                  compile_s={kk: v["compile_s"] for kk, v in mem.items()}, **extra)), flush=True)

    if not args.skip_ensemble:
        n = args.ensemble_steps or T
        fields = {}
        if scene.params.fluid is not None:
            fields["fluid.c0"] = float(scene.params.fluid.c0)
        if scene.params.blocks is not None:
            fields["blocks.friction_angle"] = float(scene.params.blocks.friction_angle)

        def sample(b):
            return ensembles.batch(scene.params, b, {f: v * jnp.linspace(0.9, 1.1, b) for f, v in fields.items()})

        def one(p):
            s, _ = observed(config, p, n, None, state=state0, checkpoint=False, prime=False,
                            rebuild_on_displacement=False)  # a cond under vmap runs both branches
            return obj(s, p)

        # per batch: one by one (a jitted single member, called per member), vmap (all members at
        # once, batch_size None) and map (one at a time in a lax.map, batch_size 1), alternated
        single = jax.jit(one)
        ens = dict(rebuild_on_displacement=False, repeats=args.repeats, date=time.strftime("%Y-%m-%d"))
        for b in args.batches:
            pb = sample(b)
            members = ensembles.unstack(pb)
            fns = {"one_by_one": lambda _: [single(m) for m in members]}
            for mode, size in (("vmap", None), ("map", 1)):
                if mode in args.ensemble_modes and not (mode == "map" and b == 1):
                    fns[mode] = ensembles.ensemble(one, batch_size=size)
            times = alternated(fns, pb, repeats=args.repeats)
            t_one = times["one_by_one"]
            for k, tb in times.items():
                print(json.dumps(dict(base, bench="ensemble", mode=k, batch=b, steps=n, seconds=tb,
                                      scenario_steps_per_s=b * n / tb, speedup_vs_one_by_one=t_one / tb, **ens)),
                      flush=True)


if __name__ == "__main__":
    main()
