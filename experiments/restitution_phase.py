"""Restitution of a cube dropped flat on a floor vs the phase of the impact within a step, and what
it costs to get it right: a smaller block step (option a) or the step-resolved normal force of the
contact law (option b, ``PenaltyCoulomb(resolve_step=True)``, the default).

Drops: ``scenes.block_on_incline`` at 0 degrees with a 0.1 m cube (blocks only; ``config.dt`` is
the builder's default, ``blocks.stable_dt``: seed Eq 8 with safety 0.5), released from 16
heights from 0.0500 m spaced by (2 + 1/16) steps of the fall at the impact speed (at most
0.0503 m; one vmapped rollout of ~1e4 steps at the default dt), so that the first contact falls
1/16 of a step later for each (``phase``: the gap before the first contact step over that
step's closing, measured). e = upward speed after the last contact step / downward speed before
the first, against the closing-only closed form exp(-zeta arccos(zeta) / sqrt(1 - zeta^2)).
Per law and dt factor (dt = factor x the builder's): min / max e and its error over the phases,
the eighths of a step the phases cover, steps in contact, and the cost -- drop-steps/s (each
drop is one DYNAMIC block: block-steps/s of the batch of 16) and simulated s per wall s of the
batch, compile excluded (best of ``--reps`` timed calls).

Cost of the law on its own (``law_cost``): block-steps/s of ``bench_blocks``' 100-box pile at
rest with the plain and the resolved law at the same dt (each built twice, compiled first, then
alternated, best of 12 or ``--reps``; the two builds' spread measures the noise); and the law alone (``law_alone``: one call on 4096 points). Coupled scene (``coupled``): which step limits ``sliding_wedge`` (the
fluid's CFL step or the blocks' Eq 8 step, before and after the builder softens the rock), and
the full coupled step's ms with each law (best of ``--reps`` chunks, alternated).

    python experiments/restitution_phase.py --out experiments/results/restitution_phase.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from jsonl_out import emit  # noqa: E402

from rockjax.blocks import PenaltyCoulomb, SmoothPenaltyCoulomb, advance_blocks  # noqa: E402

# the drops, their release heights and the bounce's measure: the test's own (one definition)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "blocks"))
from test_restitution_phase import G, ZETAS, bounce, closed_form, cube_scene, heights, rollout  # noqa: E402

LAWS = {"plain": PenaltyCoulomb(resolve_step=False), "resolved": PenaltyCoulomb(),
        "smooth plain": SmoothPenaltyCoulomb(resolve_step=False), "smooth resolved": SmoothPenaltyCoulomb()}
#: (law, dt factors) measured: the plain law down to the step that meets 2 %, the others at the default
PLAN = (("plain", (1.0, 1 / 2, 1 / 3, 1 / 4, 1 / 6, 1 / 8)), ("resolved", (1.0, 1 / 2)),
        ("smooth plain", (1.0,)), ("smooth resolved", (1.0, 1 / 8)))


def _commit():
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=os.path.dirname(os.path.abspath(__file__)), timeout=10).stdout.strip()
    except Exception:
        return None


def drops(law_name, factor, zeta, reps):
    sc = cube_scene(zeta, LAWS[law_name])
    st = sc.state.blocks
    z_rest = float(st.x[0, 2])
    dt = sc.config.dt * factor
    hs = heights(dt)
    states = jax.tree_util.tree_map(lambda a: jnp.stack([a] * len(hs)), st)
    states = states.replace(x=states.x.at[:, 0, 2].add(jnp.asarray(hs, st.x.dtype)))
    n = int(math.ceil((math.sqrt(2 * hs.max() / G) + 1e-3) / dt))
    run = rollout(sc.config.blocks, n)
    args = (states, sc.params.blocks, jnp.asarray(dt, st.x.dtype))
    t0 = time.perf_counter()
    z, v = jax.block_until_ready(run(*args))
    first_s = time.perf_counter() - t0
    walls = []
    for _ in range(reps):
        t0 = time.perf_counter()
        jax.block_until_ready(run(*args))
        walls.append(time.perf_counter() - t0)
    wall = min(walls)
    z, v = np.asarray(z, np.float64), np.asarray(v, np.float64)
    res = [bounce(z_rest + h, z[k], v[k], dt, z_rest) for k, h in enumerate(hs)]
    e, phase, steps = (np.asarray(a) for a in zip(*res))
    err = e / closed_form(zeta) - 1.0
    K = len(hs)
    return dict(bench="restitution_phase", case="drops", law=law_name, dt_factor=factor, zeta=zeta,
                e_closed_form=closed_form(zeta), e_min=float(e.min()), e_max=float(e.max()),
                err_min=float(err.min()), err_max=float(err.max()), max_abs_err=float(np.abs(err).max()),
                within_2pct=bool(np.abs(err).max() < 0.02),
                phases=[round(float(p), 4) for p in phase], errors=[round(float(x), 5) for x in err],
                eighths_covered=int(len(np.unique(np.minimum(np.floor(phase * 8), 7)))),
                steps_in_contact_min=int(steps.min()), steps_in_contact_max=int(steps.max()),
                dt=dt, dt_builder=sc.config.dt, steps=n, drops=K, wall_s=round(wall, 3),
                compile_plus_first_s=round(first_s, 2), block_steps_per_s=K * n / wall,
                sim_s_per_wall_s=K * n * dt / wall, heights=[float(hs[0]), float(hs[-1])])


def law_cost(reps, n_blocks=100, steps=100):
    """Block-steps/s of ``bench_blocks``' box pile (k_n = 1e7 N/m, dt = stable_dt) with each law:
    one jitted chunk of ``steps`` steps per law, compiled first, then timed alternately (best of
    ``reps``), each law built twice (the two builds' spread is the noise)."""
    from bench_blocks import pile

    from rockjax.blocks import Broadphase, Motion, make_blocks, stable_dt

    polys, pos = pile(n_blocks)
    fns = {}
    for name, law in (("plain", LAWS["plain"]), ("resolved", LAWS["resolved"]), ("plain again", LAWS["plain"]),
                      ("resolved again", LAWS["resolved"])):
        cfg, par, st = make_blocks(polys, positions=pos, motion=[Motion.FIXED] + [Motion.DYNAMIC] * n_blocks,
                                   normal_stiffness=1e7, shear_stiffness=4e6, broadphase=Broadphase.GRID, law=law)
        dt = stable_dt(cfg, par, st)
        g = jnp.asarray([0.0, 0.0, -G], st.x.dtype)

        def chunk(s, cfg=cfg, par=par, dt=dt):
            def body(c, _):
                s_, t = c
                s_, stat = advance_blocks(s_, par, cfg, dt=dt, t=t, gravity=g)
                return (s_, t + dt), stat
            (s, _), stat = jax.lax.scan(body, (s, jnp.zeros((), s.x.dtype)), None, length=steps)
            return s, jnp.bitwise_or.reduce(stat)

        fn = jax.jit(chunk)
        jax.block_until_ready(fn(st))
        fns[name] = (fn, st)
    best = {}
    for _ in range(reps):
        for name, (fn, st) in fns.items():
            t0 = time.perf_counter()
            jax.block_until_ready(fn(st))
            best[name] = min(best.get(name, float("inf")), time.perf_counter() - t0)
    rate = {k: n_blocks * steps / v for k, v in best.items()}
    return dict(bench="restitution_phase", case="law_cost", method="precompiled, alternated", n_blocks=n_blocks,
                steps=steps, dt=dt, block_steps_per_s_plain=rate["plain"], block_steps_per_s_resolved=rate["resolved"],
                block_steps_per_s_plain_again=rate["plain again"], block_steps_per_s_resolved_again=rate["resolved again"],
                ratio_resolved_over_plain=(rate["resolved"] + rate["resolved again"]) / (rate["plain"] + rate["plain again"]),
                ratio_plain_again_over_plain=rate["plain again"] / rate["plain"],
                ratio_resolved_again_over_resolved=rate["resolved again"] / rate["resolved"], best_of=reps)


def law_alone(reps, S=128, L=32, calls=200):
    """The law's own cost: one jitted call on S x L contact points (closing, random depths and
    velocities) per law, best of ``reps`` batches of ``calls`` calls, alternated (us per point)."""
    from rockjax.blocks import ContactPoint, box, make_blocks

    _, par, _ = make_blocks([box(0.1, 0.1, 0.1)])
    rng = np.random.default_rng(0)
    f = par.normal_stiffness.dtype
    nrm = np.zeros((S, L, 3))
    nrm[..., 2] = 1.0
    pt = ContactPoint(depth=jnp.asarray(rng.uniform(1e-7, 1e-4, (S, L)), f), normal=jnp.asarray(nrm, f),
                      velocity=jnp.asarray(rng.normal(0.0, 0.5, (S, L, 3)), f),
                      reduced_mass=jnp.asarray(rng.uniform(1.0, 10.0, (S, 1)), f), pair_points=jnp.full((S, 1), 4.0, f))
    hist = jnp.asarray(rng.normal(0.0, 1e-6, (S, L, 3)), f)
    fns = {name: jax.jit(lambda p_, h_, law=LAWS[name]: law(p_, h_, par, 1e-5)) for name in ("plain", "resolved")}
    for fn in fns.values():
        jax.block_until_ready(fn(pt, hist))
    best = {}
    for _ in range(reps):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            for _ in range(calls):
                out = fn(pt, hist)
            jax.block_until_ready(out)
            best[name] = min(best.get(name, float("inf")), (time.perf_counter() - t0) / calls)
    return dict(bench="restitution_phase", case="law_alone", points=S * L, calls=calls,
                us_per_point_plain=1e6 * best["plain"] / (S * L), us_per_point_resolved=1e6 * best["resolved"] / (S * L),
                ratio_resolved_over_plain=best["resolved"] / best["plain"], best_of=reps)


def coupled(dx, reps):
    """sliding_wedge: which step limits dt, and the coupled step's ms with each law."""
    import rockjax as rj
    from rockjax import blocks
    from rockjax.rollout import make_rollout
    from rockjax.scenes import stable_dt as fluid_dt

    sc = rj.scenes.sliding_wedge(dx=dx)
    c, p = sc.config, sc.params
    dt_fluid = fluid_dt(p, scheme=c.scheme, cfl=c.cfl)
    dt_blocks_built = blocks.stable_dt(c.blocks, p.blocks, sc.state.blocks)
    k_built = float(p.blocks.normal_stiffness)
    # the blocks' step at make_blocks' own stiffness (penalty_modulus 1e9 Pa x the median DYNAMIC
    # block size, shear 0.4 of it), before the builder softens the rock to the fluid's step
    cfg0, par0, st0 = c.blocks, p.blocks, sc.state.blocks
    k_default = 1e9 * 2 * float(np.median(np.asarray(st0.shape.radius)[list(cfg0.dynamic)]))
    f = par0.normal_stiffness.dtype
    dt_blocks_default = blocks.stable_dt(cfg0, par0.replace(normal_stiffness=jnp.asarray(k_default, f),
                                                            shear_stiffness=jnp.asarray(0.4 * k_default, f)), st0)
    state = rj.prime(sc.state, p, c)
    times = {}
    fns = {}
    for name in ("plain", "resolved"):
        cn = c.replace(blocks=dataclasses.replace(c.blocks, law=LAWS[name]))
        run = make_rollout(cn, 1, checkpoint=False)
        fns[name] = jax.jit(lambda s, q, run=run: run(s, q)[0])
        jax.block_until_ready(fns[name](state, p))
    for _ in range(reps):
        for name in ("plain", "resolved"):
            t0 = time.perf_counter()
            jax.block_until_ready(fns[name](state, p))
            times[name] = min(times.get(name, float("inf")), time.perf_counter() - t0)
    k = c.rebuild_every
    return dict(bench="restitution_phase", case="coupled", scene="sliding_wedge", dx=dx, n_fluid=c.n_fluid,
                dt=c.dt, dt_fluid=dt_fluid, dt_blocks_built=dt_blocks_built, dt_blocks_default_k=dt_blocks_default,
                limited_by="fluid" if dt_fluid <= dt_blocks_built else "blocks",
                normal_stiffness_built=k_built, normal_stiffness_default=k_default,
                stiffness_softened_by=k_default / k_built,
                ms_per_step_plain=1e3 * times["plain"] / k, ms_per_step_resolved=1e3 * times["resolved"] / k,
                ratio_resolved_over_plain=times["resolved"] / times["plain"], best_of=reps)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--only", nargs="*", default=["drops", "law_cost", "law_alone", "coupled"])
    ap.add_argument("--dx", type=float, default=0.04, help="sliding_wedge's spacing for the coupled case")
    ap.add_argument("--laws", nargs="*", default=None, help="drops of these laws only (default: all of PLAN)")
    ap.add_argument("--factors", nargs="*", type=float, default=None, help="drops at these dt factors only")
    a = ap.parse_args()
    common = dict(date=datetime.date.today().isoformat(), commit=_commit(), backend=jax.default_backend(),
                  jax=jax.__version__, host_cpus=os.cpu_count(),
                  cmd="experiments/restitution_phase.py " + " ".join(sys.argv[1:]))
    if "drops" in a.only:
        for name, factors in PLAN:
            if a.laws is not None and name not in a.laws:
                continue
            for f in factors:
                if a.factors is not None and not any(abs(f - x) < 1e-3 for x in a.factors):
                    continue
                for zeta in ZETAS:
                    rec = drops(name, f, zeta, a.reps)
                    rec.update(common, load_avg_1m=round(os.getloadavg()[0], 2))
                    emit(rec, a.out, shown={k: v for k, v in rec.items() if k not in ("phases", "errors")})
    if "law_cost" in a.only:
        rec = law_cost(max(a.reps, 12))
        rec.update(common, load_avg_1m=round(os.getloadavg()[0], 2))
        emit(rec, a.out)
    if "law_alone" in a.only:
        rec = law_alone(max(a.reps, 5))
        rec.update(common, load_avg_1m=round(os.getloadavg()[0], 2))
        emit(rec, a.out)
    if "coupled" in a.only:
        rec = coupled(a.dx, a.reps)
        rec.update(common, load_avg_1m=round(os.getloadavg()[0], 2))
        emit(rec, a.out)


if __name__ == "__main__":
    main()
