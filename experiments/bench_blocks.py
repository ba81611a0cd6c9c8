"""Benchmark of the rock blocks: block-steps/s and contact evaluations/s for box piles of 10, 100 and
1000 blocks, FCP iterations vs accuracy, and (if ``mujoco`` is importable) the same box pile in
MuJoCo's CPU simulator as a reference ratio.  Prints JSON lines.

    .venv/bin/python experiments/bench_blocks.py [--sizes 10 100 1000] [--steps 200] [--out FILE.jsonl]
    .venv/bin/python experiments/bench_blocks.py --sizes 100 --ab-segments 0 64   # segmented narrow phase vs one pass
    .venv/bin/python experiments/bench_blocks.py --ab-narrow   # FCP per edge direction / law over active slots, A/B
    .venv/bin/python experiments/bench_blocks.py --shape rock --sizes 100 --ab-crossing 0 8   # crossings among selected edges
    .venv/bin/python experiments/bench_blocks.py --shape rock --sizes 100 --ab-fcp-iterations 2 0   # the FCP rounds' cost
    .venv/bin/python experiments/bench_blocks.py --shape rock --sizes 100 --ab-support-edges 0 -1   # FCP rounds over the support sets' edges
    .venv/bin/python experiments/bench_blocks.py --shape rock --sizes 100 --ab-skip-separated   # separated pairs not evaluated
    .venv/bin/python experiments/bench_blocks.py --shape rock --sizes 10 100 --ab-fcp-crosses 0 192 128   # FCP crosses enumerated

Pile: N boxes (0.18-0.2 m, 2650 kg/m^3) stacked ~4 high in columns in contact on a fixed floor
slab, with 2 mm lateral jitter (no initial overlap); ``--shape rock``: the same columns of rocks
instead, each the convex hull of 12 random points near a sphere (~30 edges, no parallel ones),
scaled to 0.19 m, each 1 mm above the top of the one below, timed after ``ROCK_WARMUP_S`` = 0.05 s
of falling into contact (MuJoCo likewise, its rocks as mesh geoms; the rocks are still bouncing
then: ~12 contact points on 100 rocks in the timed window, MuJoCo ~35 contacts); k_n = 1e7 N/m, dt = stable_dt.  Timed
after one warm-up chunk (compile excluded).  "contact_evals" counts narrow-phase pair evaluations
(the pair buffer entries whose boxes overlap), "contact_points" the active contact points.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

import rockjax.blocks as rb
from jsonl_out import emit
from rockjax.blocks import Broadphase, ConvexPolyhedron, Motion, box, make_blocks, slab
from rockjax.blocks.fcp import vertex_directions
from rockjax.types import Status


def rock(rng, size=0.19, n_points=12):
    """A random convex rock: the hull of ``n_points`` points near a sphere, scaled to ``size`` (m)."""
    while True:
        p = rng.normal(size=(n_points, 3))
        p *= rng.uniform(0.7, 1.0, (n_points, 1)) / np.linalg.norm(p, axis=1, keepdims=True)
        try:
            hull = ConvexPolyhedron.from_vertices(p)
        except ValueError:
            continue
        return ConvexPolyhedron.from_vertices(hull.vertices * (size / np.ptp(hull.vertices, axis=0).max()))


def pile(n, seed=0, shape="box"):
    """Columns of boxes (0.18-0.2 m, random) stacked in contact on a floor, 2 mm lateral jitter so
    neighbours come within the AABB margin; returns (polyhedra, centroids) with the floor first.
    ``shape="rock"``: random rocks (:func:`rock`) instead, each 1 mm above the top of the one below
    (or the floor): they fall into contact over the benchmark's warm-up (``ROCK_WARMUP_S``)."""
    if shape == "rock":
        return _rock_pile(n, seed)
    rng = np.random.default_rng(seed)
    ncol = max(1, int(math.ceil(math.sqrt(n / 4))))  # ~4 blocks per column
    pitch = 0.205
    pos, polys, top = [], [], {}
    for k in range(n):
        c = k % ncol**2
        ix, iy = c % ncol, c // ncol
        sx, sy, sz = rng.uniform(0.18, 0.2, 3)
        z0 = top.get(c, 0.0)
        pos.append([ix * pitch + rng.uniform(-0.002, 0.002), iy * pitch + rng.uniform(-0.002, 0.002), z0 + sz / 2])
        top[c] = z0 + sz
        polys.append(box(sx, sy, sz))
    L = ncol * pitch + 1.0
    cxy = 0.5 * (ncol - 1) * pitch
    return [slab(L, L, 0.3)] + polys, np.array([[cxy, cxy, -0.15]] + pos)


def _rock_pile(n, seed):
    rng = np.random.default_rng(seed)
    ncol = max(1, int(math.ceil(math.sqrt(n / 4))))
    pitch = 0.205
    pos, polys, top = [], [], {}
    for k in range(n):
        c = k % ncol**2
        p = rock(rng)
        z0 = top.get(c, 0.0) + 1e-3
        pos.append([(c % ncol) * pitch, (c // ncol) * pitch, z0 - p.vertices[:, 2].min()])
        top[c] = z0 + np.ptp(p.vertices[:, 2])
        polys.append(p)
    L = ncol * pitch + 1.0
    cxy = 0.5 * (ncol - 1) * pitch
    return [slab(L, L, 0.3)] + polys, np.array([[cxy, cxy, -0.15]] + pos)


def per_edge(st):
    """``st`` with every edge its own direction: the FCP then scores the crosses of all edge pairs
    (as before the edge-direction tables; the same planes, more candidates). With 12 directions a
    box also loses the complete start (``fcp.sat_start``), so the iterations run again: the
    ``--ab-narrow`` records of 2026-11-26 predate that start and time the two changes alone."""
    sh = st.shape
    nE = sh.edges.shape[1]
    ar = jnp.broadcast_to(jnp.arange(nE, dtype=jnp.int32), sh.edge_mask.shape)
    vdir = jax.vmap(lambda e, em: vertex_directions(e, em, sh.vertex_mask.shape[1]))(sh.edges, sh.edge_mask)
    shape = sh.replace(edge_direction=ar, direction_edge=ar, direction_mask=sh.edge_mask)
    if hasattr(sh, "vertex_direction"):  # (built once since 2026-11-29; ab_commits.py runs older code)
        shape = shape.replace(vertex_direction=vdir)
    return st.replace(shape=shape)


#: ``--ab-narrow`` variants: (name, make_blocks keywords, FCP per edge)
NARROW_VARIANTS = (("per edge, law over all slots", dict(law_slots=0), True),
                   ("per direction, law over all slots", dict(law_slots=0), False),
                   ("per edge, law over active slots", {}, True),
                   ("per direction, law over active slots (default)", {}, False))


def _history(s):
    """The contact history of a block state: ``s.history``, or the state itself in the commits
    before ``BlockState.history`` (same field names; for ``ab_commits.py``)."""
    return getattr(s, "history", s)


def _n_points(s):
    """Active contact points of a block state (also of the commits before ``contact_feature``, for
    ``ab_commits.py``)."""
    s = _history(s)
    if hasattr(s, "contact_feature"):
        return jnp.sum(s.contact_feature >= 0)
    return jnp.sum(s.slot_active)


#: s simulated before a rock pile is timed (the rocks fall into contact; boxes start in contact)
ROCK_WARMUP_S = 0.05


def pile_stepper(n, chunk=50, pair_segment=None, edges_as_directions=False, shape="box", lift=0.0, **kw):
    """The pile of :func:`pile` (its blocks raised by ``lift`` m) as blocks of ``make_blocks(**kw)``
    and a jitted ``advance(state, t0) -> (state, status, t, pairs [chunk], points [chunk])`` over
    ``chunk`` steps of the stable dt under gravity. Returns ``(cfg, state, dt, advance)``."""
    polys, pos = pile(n, shape=shape)
    pos = np.array(pos, dtype=float)
    pos[1:, 2] += lift
    motion = [Motion.FIXED] + [Motion.DYNAMIC] * n
    bp = Broadphase.ALL_PAIRS if n <= 32 else Broadphase.GRID
    cfg, par, st = make_blocks(polys, positions=pos, motion=motion, normal_stiffness=1e7, shear_stiffness=4e6,
                               broadphase=bp, pair_capacity=None, **({} if pair_segment is None else {"pair_segment": pair_segment}), **kw)
    if edges_as_directions:
        st = per_edge(st)
    dt = rb.stable_dt(cfg, par, st)
    g = jnp.asarray([0.0, 0.0, -9.81], st.x.dtype)

    @jax.jit
    def advance(s, t0):
        def body(c, _):
            s, stat, t = c
            s, st_ = rb.advance_blocks(s, par, cfg, dt=dt, t=t, gravity=g)
            return (s, stat | st_, t + dt), (jnp.sum(_history(s).pair_mask), _n_points(s))
        (s, stat, t), (npairs, npts) = jax.lax.scan(body, (s, jnp.int32(0), t0), None, length=chunk)
        return s, stat, t, npairs, npts

    return cfg, st, dt, advance


def run_blocks(n, steps, chunk=50, pair_segment=None, edges_as_directions=False, shape="box", **kw):
    cfg, st, dt, advance = pile_stepper(n, chunk, pair_segment, edges_as_directions, shape, **kw)
    bp = cfg.broadphase
    t0 = jnp.zeros((), st.x.dtype)
    tc = time.perf_counter()
    st, stat, t0, _, _ = advance(st, t0)
    st.x.block_until_ready()
    compile_s = time.perf_counter() - tc
    for _ in range(int(ROCK_WARMUP_S / (chunk * dt)) if shape == "rock" else 0):
        st, s_, t0, _, _ = advance(st, t0)
        stat = stat | s_
    st.x.block_until_ready()  # (dispatch is asynchronous: the warm-up must not run into the timing)
    nch = max(1, steps // chunk)
    evals = pts = 0
    tw = time.perf_counter()
    for _ in range(nch):
        st, s_, t0, npairs, npts = advance(st, t0)
        stat = stat | s_
        evals += int(np.sum(npairs))
        pts += int(np.sum(npts))
    st.x.block_until_ready()
    wall = time.perf_counter() - tw
    nsteps = nch * chunk
    return dict(bench="blocks_pile", shape=shape, n_blocks=n, broadphase=bp.value, pair_capacity=cfg.pair_capacity,
                pair_segment=cfg.pair_segment, law_slots=cfg.law_slots,
                crossing_edges=getattr(cfg, "crossing_edges", None), support_edges=getattr(cfg, "support_edges", None),
                fcp_crosses=getattr(cfg, "fcp_crosses", None), skip_separated=getattr(cfg, "skip_separated", None),
                max_edges=cfg.max_edges, fcp_per_edge=edges_as_directions,
                fcp_directions=int(st.shape.direction_edge.shape[1]),
                contact_slots=cfg.contact_slots, fcp_iterations=cfg.fcp_iterations, dt=dt, steps=nsteps,
                wall_s=round(wall, 3), compile_plus_first_chunk_s=round(compile_s, 2),
                block_steps_per_s=n * nsteps / wall, contact_evals_per_s=evals / wall,
                mean_pairs=evals / nsteps, mean_contact_points=pts / nsteps,
                status=Status.describe(int(stat)),
                backend=jax.default_backend(), dtype=str(st.x.dtype))


def run_mujoco(n, steps, dt, shape="box"):
    """The same pile in MuJoCo's CPU simulator (boxes as box geoms; rocks as mesh geoms, which
    MuJoCo collides as their convex hulls), block-steps/s at the same dt. Rocks first fall into
    contact for ``ROCK_WARMUP_S``, as in :func:`run_blocks`."""
    try:
        import mujoco
    except ImportError:
        return dict(bench="mujoco_pile", shape=shape, n_blocks=n, skipped="mujoco not importable")
    polys, pos = pile(n, shape=shape)
    geoms, meshes = [], []
    for k in range(n):
        x, y, z = pos[k + 1]
        if shape == "rock":
            v = " ".join(f"{c:.9g}" for c in polys[k + 1].vertices.ravel())
            meshes.append(f'<mesh name="r{k}" vertex="{v}"/>')
            geom = f'<geom type="mesh" mesh="r{k}" density="2650"/>'
        else:
            sx, sy, sz = np.ptp(polys[k + 1].vertices, axis=0)
            geom = f'<geom type="box" size="{sx/2} {sy/2} {sz/2}" density="2650"/>'
        geoms.append(f'<body pos="{x} {y} {z}"><freejoint/>{geom}</body>')
    size = '<size memory="2G"/>' if n > 2000 else ""  # (the default arena overflows at 10k bodies)
    xml = (f'<mujoco><option timestep="{dt}"/>{size}<asset>{"".join(meshes)}</asset><worldbody>'
           '<geom type="plane" size="50 50 0.1"/>' + "".join(geoms) + "</worldbody></mujoco>")
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    for _ in range(int(ROCK_WARMUP_S / dt) if shape == "rock" else 10):
        mujoco.mj_step(model, data)
    tw = time.perf_counter()
    ncon = 0
    for _ in range(steps):
        mujoco.mj_step(model, data)
        ncon += data.ncon
    wall = time.perf_counter() - tw
    return dict(bench="mujoco_pile", shape=shape, n_blocks=n, version=mujoco.__version__, dt=dt, steps=steps,
                wall_s=round(wall, 3), block_steps_per_s=n * steps / wall, mean_contacts=ncon / steps,
                note="MuJoCo CPU (1 thread, soft constraints, Newton solver, default settings), same pile"
                     + (" (rocks: mesh geoms, collided as convex hulls)" if shape == "rock" else ""))


def fcp_accuracy(n_cases=60, iterations=(0, 1, 2, 4, 8)):
    """Cold-start FCP depth accuracy vs iteration count on random overlaps (tests/blocks/fcp_cases)."""
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests", "blocks"))
    from fcp_cases import fcp_fn, padded, place_at_gap, random_block, random_rotation, sat

    rng = np.random.default_rng(7)
    cases = []
    for _ in range(n_cases):
        pi = random_block(rng, int(rng.integers(5, 13)), rng.uniform(0.5, 2.0))
        pj = random_block(rng, int(rng.integers(5, 13)), rng.uniform(0.5, 2.0))
        qi, qj = random_rotation(rng), random_rotation(rng)
        L = min(pi.bounding_radius, pj.bounding_radius)
        xj = place_at_gap(pi, qi, pj, qj, rng.normal(size=3), -rng.uniform(1e-3, 0.1) * L)
        cases.append((pi, qi, pj, qj, xj, L, sat(pi, qi, np.zeros(3), pj, qj, xj)))
    out = []
    for it in iterations:
        f = fcp_fn(it)
        errs, ok = [], 0
        for pi, qi, pj, qj, xj, L, (g, ax, second) in cases:
            o = f(padded(pi), jnp.asarray(qi, jnp.float32), jnp.zeros(3), padded(pj), jnp.asarray(qj, jnp.float32),
                  jnp.asarray(xj, jnp.float32), jnp.zeros(3), jnp.bool_(False))
            e = abs(float(o["gap"]) - g) / L
            errs.append(e)
            ok += e <= 2e-5
        out.append(dict(bench="fcp_iterations", iterations=it, cases=n_cases, frac_exact=ok / n_cases,
                        max_depth_err_rel=float(np.max(errs)), mean_depth_err_rel=float(np.mean(errs)),
                        note="cold start (no warm plane); overlaps 1e-3..0.1 L; exact = float64 SAT; "
                             "the differentiable final round adds one candidate round to every count"))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--no-fcp", action="store_true")
    ap.add_argument("--ab-segments", type=int, nargs="+", default=None,
                    help="instead: time each pile with these BlockConfig.pair_segment values (0 = one pass over "
                         "the pair buffer), alternated --repeats times in this process, and print the ratios")
    ap.add_argument("--ab-narrow", action="store_true",
                    help="instead: time each pile with the FCP scoring every edge or each edge direction, and the "
                         "contact law over every contact slot or the gathered active ones (BlockConfig.law_slots), "
                         "alternated --repeats times in this process, and print the ratios")
    ap.add_argument("--ab-crossing", type=int, nargs="+", default=None,
                    help="instead: time each pile with these BlockConfig.crossing_edges values (0 = crossings of "
                         "every edge pair), alternated --repeats times in this process, and print the ratios")
    ap.add_argument("--ab-fcp-iterations", type=int, nargs="+", default=None,
                    help="instead: time each pile with these BlockConfig.fcp_iterations (what the FCP rounds cost; "
                         "boxes run none without joint water), alternated --repeats times in this process")
    ap.add_argument("--ab-support-edges", type=int, nargs="+", default=None,
                    help="instead: time each pile with these BlockConfig.support_edges (0 = every edge direction in "
                         "each FCP round; -1 = make_blocks' default, the most any face touches), alternated")
    ap.add_argument("--ab-fcp-crosses", type=int, nargs="+", default=None,
                    help="instead: time each pile with these BlockConfig.fcp_crosses (0 = every cross of the gathered "
                         "directions, support_edges^2 slots; -1 = make_blocks' default), alternated")
    ap.add_argument("--ab-skip-separated", action="store_true",
                    help="instead: time each pile evaluating every candidate pair against skipping the pairs their "
                         "stored plane separates (BlockConfig.skip_separated), alternated --repeats times")
    ap.add_argument("--shape", choices=("box", "rock"), default="box", help="pile of boxes or of random rocks")
    ap.add_argument("--no-mujoco", action="store_true")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--best-of", type=int, default=3,
                    help="the pile timed this many times in each code (alternated), the best of each reported")
    ap.add_argument("--out", default=None, help="also append the records (with date, command, load) to this file")
    a = ap.parse_args()
    stamp = dict(date=time.strftime("%Y-%m-%d"), cmd="experiments/bench_blocks.py " + " ".join(sys.argv[1:]))

    def out(rec):
        emit(dict(rec, **stamp, load_avg_1m_at_save=os.getloadavg()[0]), a.out)

    def steps_for(n):
        return a.steps if n < 1000 else max(50, a.steps // 4)

    def alternate(n, variants, bench, keys=()):
        """Time ``variants`` [(name, run_blocks keywords)] on the n-box pile, alternated
        ``--repeats`` times; emit every run and one record with the best walls and the speed-ups
        over the first variant."""
        walls = {name: [] for name, _ in variants}
        statuses = {name: set() for name, _ in variants}
        for _ in range(a.repeats):
            for name, kw in variants:
                r = run_blocks(n, steps_for(n), **kw)
                walls[name].append(r["wall_s"])
                statuses[name].add(r["status"])
                out(dict(r, variant=name))
        best = {name: min(w) for name, w in walls.items()}
        ref = variants[0][0]
        out(dict(bench=bench, n_blocks=n, pair_capacity=r["pair_capacity"], mean_pairs=r["mean_pairs"],
                 **{k: r[k] for k in keys}, best_wall_s=best,
                 status_by_variant={name: ", ".join(sorted(v)) for name, v in statuses.items()},
                 speedup_over_first={name: best[ref] / b for name, b in best.items()}))

    if a.ab_narrow:
        for n in a.sizes:
            alternate(n, [(name, dict(kw, edges_as_directions=pe, shape=a.shape)) for name, kw, pe in NARROW_VARIANTS],
                      "blocks_narrow_ab", keys=("mean_contact_points", "steps", "shape"))
        return
    if a.ab_segments:
        for n in a.sizes:
            alternate(n, [(sg, dict(pair_segment=sg, shape=a.shape)) for sg in a.ab_segments], "blocks_pair_segment_ab",
                      keys=("shape",))
        return
    if a.ab_crossing:
        for n in a.sizes:
            alternate(n, [(ce, dict(crossing_edges=ce, shape=a.shape)) for ce in a.ab_crossing], "blocks_crossing_ab",
                      keys=("shape", "max_edges", "mean_contact_points"))
        return
    if a.ab_fcp_iterations:
        for n in a.sizes:
            alternate(n, [(it, dict(fcp_iterations=it, shape=a.shape)) for it in a.ab_fcp_iterations],
                      "blocks_fcp_iterations_ab", keys=("shape", "max_edges", "fcp_directions", "mean_contact_points"))
        return
    if a.ab_support_edges:
        for n in a.sizes:
            alternate(n, [(k, dict(support_edges=None if k < 0 else k, shape=a.shape)) for k in a.ab_support_edges],
                      "blocks_support_edges_ab", keys=("shape", "max_edges", "fcp_directions", "support_edges",
                                                       "mean_contact_points", "status"))
        return
    if a.ab_fcp_crosses:
        for n in a.sizes:
            alternate(n, [(k, dict(fcp_crosses=None if k < 0 else k, shape=a.shape)) for k in a.ab_fcp_crosses],
                      "blocks_fcp_crosses_ab", keys=("shape", "support_edges", "fcp_crosses", "mean_contact_points",
                                                     "status"))
        return
    if a.ab_skip_separated:
        for n in a.sizes:
            alternate(n, [("every pair", dict(skip_separated=False, shape=a.shape)),
                          ("skip separated (default)", dict(shape=a.shape))],
                      "blocks_skip_separated_ab", keys=("shape", "mean_contact_points", "status"))
        return
    def best(runs):
        """The fastest of ``runs`` (records), with every run's wall and their count."""
        top = dict(max(runs, key=lambda r: r.get("block_steps_per_s", 0.0)))
        if "wall_s" in top:
            top.update(best_of=len(runs), walls_s=[r["wall_s"] for r in runs])
        return top

    for n in a.sizes:
        # the two codes alternated --best-of times, the best of each kept (the first run in a
        # process is often the slowest: measured 0.41 vs 0.25-0.28 s on the 10-rock pile)
        ours, theirs = [], []
        for _ in range(a.best_of):
            ours.append(run_blocks(n, steps_for(n), shape=a.shape))
            if not a.no_mujoco:
                theirs.append(run_mujoco(n, a.steps, ours[-1]["dt"], a.shape))
        r = best(ours)
        out(r)
        if a.no_mujoco:
            continue
        m = best(theirs)
        if "block_steps_per_s" in m:
            m["ratio_rockjax_over_mujoco"] = r["block_steps_per_s"] / m["block_steps_per_s"]
        out(m)
    if not a.no_fcp:
        for r in fcp_accuracy():
            out(r)


if __name__ == "__main__":
    main()
