"""Where a block step's time goes: each stage of ``advance_blocks`` jitted and timed alone on the
benchmark piles of ``bench_blocks.py`` (boxes or rocks), beside the whole step. Prints JSON lines.

    .venv/bin/python experiments/profile_blocks.py [--sizes 100 1000] [--shape box|rock] [--reps 20] [--out F.jsonl]

Stages (the order ``contact.contact_forces`` and ``integrate.advance_blocks`` run them):

* ``pose``: world vertices and face planes;
* ``broad``: whether the candidate-pair list is kept (``contact._kept_or_rebuilt``: the blocks'
  boxes against those of the last build); a rebuild (``broadphase.candidate_pairs``: AABBs, grid,
  compaction; ``contact._remap``: the history carried over) is timed alone (``rebuild_ms``) and
  counted over ``--settle`` steps (``rebuilds_per_step``);
* ``separated``: which pairs the stored plane still separates (``contact.separated_pairs``) and
  the gather of the evaluated pairs to the front;
* ``fcp``, ``points``, ``law``: the Fast Common Plane, the contact points and the contact law
  (with the history's feature match and the pair's loads) over the evaluated pairs only, in one
  pass (no segments) -- the narrow phase's arithmetic;
* ``scatter``: the pairs' loads summed onto the blocks;
* ``integrate``: the velocity / pose update and the step's status checks.

``step`` is ``advance_blocks`` itself (one step, jitted alone); ``segments_overhead`` is the step
less the stages' sum: the segmented scan (``BlockConfig.pair_segment``), the scatter back to the
buffer order and what fusion across stages saves or costs. Each stage is timed as the best of
``--reps`` calls of a jitted function on the pile's state after ``--settle`` steps (boxes start in
contact; rocks fall for ``bench_blocks.ROCK_WARMUP_S`` first).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import jax.numpy as jnp

sys.path.insert(0, os.path.dirname(__file__))

import rockjax.blocks as rb  # noqa: E402
from bench_blocks import ROCK_WARMUP_S, pile  # noqa: E402
from jsonl_out import emit  # noqa: E402
from rockjax.blocks import Broadphase, Motion, make_blocks  # noqa: E402
from rockjax.blocks import contact as C  # noqa: E402
from rockjax.blocks.broadphase import candidate_pairs  # noqa: E402
from rockjax.blocks.fcp import sat_start  # noqa: E402
from rockjax.blocks.model import block_mass, world_planes, world_vertices  # noqa: E402


def _best(fn, args, reps):
    out = fn(*args)
    jax.block_until_ready(out)
    walls = []
    for _ in range(reps):
        t = time.perf_counter()
        jax.block_until_ready(fn(*args))
        walls.append(time.perf_counter() - t)
    return min(walls), out


def profile(n, shape="box", reps=20, settle=20, pair_segment=None):
    polys, pos = pile(n, shape=shape)
    motion = [Motion.FIXED] + [Motion.DYNAMIC] * n
    bp = Broadphase.ALL_PAIRS if n <= 32 else Broadphase.GRID
    cfg, par, st = make_blocks(polys, positions=pos, motion=motion, normal_stiffness=1e7, shear_stiffness=4e6,
                               broadphase=bp, pair_capacity=None,
                               **({} if pair_segment is None else dict(pair_segment=pair_segment)))
    dt = rb.stable_dt(cfg, par, st)
    g = jnp.asarray([0.0, 0.0, -9.81], st.x.dtype)

    @jax.jit
    def steps(s, k_t):
        def body(c, _):
            s, t = c
            s, _ = rb.advance_blocks(s, par, cfg, dt=dt, t=t, gravity=g)
            return (s, t + dt), None
        return jax.lax.scan(body, (s, k_t), None, length=settle)[0]

    t0 = jnp.zeros((), st.x.dtype)
    n_settle = (int(ROCK_WARMUP_S / (settle * dt)) if shape == "rock" else 0) + 1
    for _ in range(n_settle):
        st, t0 = steps(st, t0)

    @jax.jit
    def count_rebuilds(s, t):  # the list rebuilds over ``settle`` more steps (its boxes renewed)
        def body(c, _):
            s, t, k = c
            s2, _ = rb.advance_blocks(s, par, cfg, dt=dt, t=t, gravity=g)
            k = k + jnp.any(s2.history.box_lo != s.history.box_lo).astype(jnp.int32)
            return (s2, t + dt, k), None
        return jax.lax.scan(body, (s, t, jnp.int32(0)), None, length=settle)[0]

    st, t0, rebuilds = count_rebuilds(st, t0)
    rebuilds, n_counted = int(rebuilds), settle

    step = jax.jit(lambda s, t: rb.advance_blocks(s, par, cfg, dt=dt, t=t, gravity=g))
    rec = dict(bench="blocks_profile", shape=shape, n_blocks=n, pair_capacity=cfg.pair_capacity,
               pair_segment=cfg.pair_segment, pair_segment_setting=pair_segment, dt=dt, reps=reps)
    times = {}
    times["step"], _ = _best(step, (st, t0), reps)

    sh = st.shape
    n_dir = sh.direction_edge.shape[1]
    iterations = 0 if sat_start(n_dir) and not cfg.joint_water else cfg.fcp_iterations
    support_edges = cfg.support_edges if 0 < cfg.support_edges < n_dir else 0
    crosses = cfg.fcp_crosses if support_edges and 0 < cfg.fcp_crosses < support_edges ** 2 else 0
    dyn = jnp.asarray([m == Motion.DYNAMIC for m in cfg.motion])

    @jax.jit
    def pose(s):
        Xw = world_vertices(s)
        Nw, Dw = world_planes(s)
        return Xw, Nw, Dw

    times["pose"], (Xw, Nw, Dw) = _best(pose, (st,), reps)
    # a list rebuild (the broad phase and the history's remap) is timed alone; a step runs one only
    # when a block's box has moved by half the AABB margin (``contact._kept_or_rebuilt``), and the
    # stage "broad" is that check on this state (a kept list: the rebuild skipped)
    broad = jax.jit(lambda X: candidate_pairs(cfg, X, sh.vertex_mask))
    times["rebuild_broad"], (pairs, mask, _) = _best(broad, (Xw,), reps)
    remap = jax.jit(lambda old, p, m: C._remap(old, p, m, cfg.n_blocks))
    times["rebuild_remap"], _ = _best(remap, (st.history, pairs, mask), reps)
    kept = jax.jit(lambda old, X: C._kept_or_rebuilt(cfg, old, X, sh.vertex_mask))
    times["broad"], (hist, _) = _best(kept, (st.history, Xw), reps)
    mask = hist.pair_mask

    @jax.jit
    def separated(X, hist):
        clear, gap = C.separated_pairs(X, sh.vertex_mask, sh, hist.pairs, hist.plane, hist.plane_valid,
                                       tol_rel=cfg.inside_tolerance)
        keep = hist.pair_mask & ~clear
        order = jnp.argsort(~keep, stable=True)
        args = (hist.pairs[:, 0], hist.pairs[:, 1], hist.pair_mask, hist.plane, hist.plane_valid, hist.shear,
                hist.contact_feature)
        return keep, tuple(a[order] for a in args)

    times["separated"], (keep, args) = _best(separated, (Xw, hist), reps)
    K = int(jnp.sum(keep))
    args = tuple(a[:K] for a in args)
    i, j, m_, plane, pvalid, shear, feat_old = args
    bodies = C._Bodies(Xw, Nw, Dw, sh, st.x, st.v, st.omega, jnp.where(dyn, 1.0 / block_mass(st, par), 0.0))

    fcp = jax.jit(lambda b, i, j, p, v: C._common_planes(b, i, j, p, v, iterations=iterations,
                                                          support_edges=support_edges, crosses=crosses))
    times["fcp"], fc = _best(fcp, (bodies, i, j, plane, pvalid), reps)
    points = jax.jit(lambda b, i, j, n, gap: C._pair_points(b, cfg, i, j, n, gap))
    times["points"], pc = _best(points, (bodies, i, j, fc["normal"], fc["gap"]), reps)

    @jax.jit
    def law(b, i, j, n, pc, m_, shear, feature_old):
        active_all = pc.active & m_[:, None]
        depth_all = jnp.where(active_all, pc.depth, 0.0)
        n_points = jnp.sum(active_all.astype(jnp.int32), 1)
        slot = C._active_slots(active_all, cfg.law_slots)
        pts, depth, active, feature = (C._take_slots(a, slot) for a in (pc.points, depth_all, active_all, pc.feature))
        feature = jnp.where(active, feature, -1)
        same = (feature[:, :, None] == feature_old[:, None, :]) & (feature[:, :, None] >= 0)
        shear = jnp.einsum("skm,smc->skc", same.astype(shear.dtype), shear)
        return C._law_loads(cfg.law, par, dt, b, i, j, n, pts, depth, active, n_points, shear)

    times["law"], lw = _best(law, (bodies, i, j, fc["normal"], pc, m_, shear, feat_old), reps)
    Fj, Tj, Ti = lw[3], lw[4], lw[5]
    B = cfg.n_blocks

    @jax.jit
    def scatter(i, j, Fj, Tj, Ti):
        f = jnp.zeros((B, 3), Fj.dtype).at[j].add(Fj).at[i].add(-Fj)
        return f, jnp.zeros((B, 3), Fj.dtype).at[j].add(Tj).at[i].add(Ti)

    times["scatter"], (force, torque) = _best(scatter, (i, j, Fj, Tj, Ti), reps)
    # the integration alone: advance_blocks' update with the contact loads given (contact off)
    cfg_free = cfg
    d = jnp.asarray(cfg.dynamic)

    @jax.jit
    def integrate(s, force, torque):
        from rockjax.blocks.integrate import quat_integrate, quat_matrix
        from rockjax.blocks.model import stable_dt_jax
        m = par.density[d] * s.shape.volume[d]
        vd = s.v[d] + dt * (force[d] / m[:, None] + g)
        R = quat_matrix(s.q[d])
        Iw = jnp.einsum("bij,bjk,blk->bil", R, par.density[d, None, None] * s.shape.inertia_unit[d], R)
        wd = s.omega[d]
        rhs = torque[d] - jnp.cross(wd, jnp.einsum("bij,bj->bi", Iw, wd))
        wd = wd + dt * jnp.linalg.solve(Iw, rhs[..., None])[..., 0]
        xd = s.x[d] + dt * vd
        qd = quat_integrate(s.q[d], wd, dt)
        ok = jnp.all(jnp.isfinite(xd)) & (dt <= stable_dt_jax(cfg_free, par, s.shape, safety=1.0))
        return s.x.at[d].set(xd), s.v.at[d].set(vd), s.q.at[d].set(qd), s.omega.at[d].set(wd), ok

    times["integrate"], _ = _best(integrate, (st, force, torque), reps)
    stages = ("pose", "broad", "separated", "fcp", "points", "law", "scatter", "integrate")
    total = sum(times[k] for k in stages)
    rec.update(candidate_pairs=int(jnp.sum(mask)), evaluated_pairs=K,
               contact_points=int(jnp.sum(pc.active & m_[:, None])),
               step_ms=1e3 * times["step"], stages_ms={k: round(1e3 * times[k], 4) for k in stages},
               rebuild_ms={k: round(1e3 * times["rebuild_" + k], 4) for k in ("broad", "remap")},
               rebuilds_per_step=rebuilds / n_counted,
               stages_sum_ms=1e3 * total, segments_overhead_ms=1e3 * (times["step"] - total),
               share_of_step={k: round(times[k] / times["step"], 4) for k in stages},
               block_steps_per_s=n / times["step"], us_per_evaluated_pair={
                   k: round(1e6 * times[k] / max(K, 1), 3) for k in ("fcp", "points", "law")},
               backend=jax.default_backend(), dtype=str(st.x.dtype))
    return rec


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--shape", choices=("box", "rock"), default="box")
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--settle", type=int, default=20)
    ap.add_argument("--pair-segment", type=lambda v: None if v == "auto" else int(v), nargs="+", default=[None],
                    help="BlockTuning.pair_segment values to profile ('auto': make_blocks' default)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    stamp = dict(date=time.strftime("%Y-%m-%d"), cmd="experiments/profile_blocks.py " + " ".join(sys.argv[1:]))
    for n, seg in ((n, seg) for n in a.sizes for seg in a.pair_segment):
        emit(dict(profile(n, a.shape, a.reps, a.settle, seg), **stamp, load_avg_1m_at_save=os.getloadavg()[0]), a.out)


if __name__ == "__main__":
    main()
