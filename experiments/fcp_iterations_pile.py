"""What one FCP iteration instead of two changes in a pile (issue 46: the rock pile's speed).

``BlockConfig.fcp_iterations`` is the fixed count of Fast Common Plane iterations per pair and
step, warm-started from the pair's plane of the previous step. On cold starts one iteration is
already exact (``bench_blocks.py``'s accuracy table: 60/60 random overlaps), so the second is
paid for at every step of every pair. This measures what it changes where it matters, in a
running pile: ``bench_blocks``' 100-rock (or box) pile, float64, the rocks falling into contact
and settling (``--steps`` steps of the stable dt; ``--float32`` for the benchmarks' precision), run
with each count in ``--iterations``; the
blocks' final positions and rotations against the run with the most iterations, beside the
difference a 1e-9 m nudge of the initial heights makes with that count (the floor below which a
difference is the pile's own sensitivity, not the FCP's).

Output: JSON lines (``--out``): per count, the max / RMS position difference [m], the max rotation
difference [rad], the status, the wall time.

    .venv/bin/python experiments/fcp_iterations_pile.py [--shape rock] [--n 100] [--iterations 1 2 8] [--warm 0]

``--warm``: ``BlockConfig.fcp_warm_iterations`` of the runs (the iterations of a narrow-phase
segment whose pairs all carry last step's plane; the reference runs its count everywhere).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", "--float32" not in sys.argv)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rockjax.types import Status  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from bench_blocks import pile, pile_stepper  # noqa: E402
from jsonl_out import emit  # noqa: E402


def run(n, shape, iterations, steps, nudge=0.0, chunk=100, warm=None):
    """The pile after ``steps`` steps with ``iterations`` FCP iterations (``warm`` of them in
    segments of warm-started pairs; None: as many), its initial heights raised by ``nudge`` m:
    ``(state, status bits, dt, wall s)``."""
    warm = iterations if warm is None else min(warm, iterations)
    _, st, dt, advance = pile_stepper(n, chunk, shape=shape, lift=nudge, fcp_iterations=iterations,
                                      fcp_warm_iterations=warm)
    t0 = jnp.zeros((), st.x.dtype)
    stat = 0
    tw = time.perf_counter()
    for _ in range(max(1, steps // chunk)):
        st, s_, t0, _, _ = advance(st, t0)
        stat |= int(s_)
    st.x.block_until_ready()
    return st, stat, dt, time.perf_counter() - tw


def rotation_of(st):
    """The blocks' rotation matrices [B, 3, 3] from their quaternions."""
    from rockjax.blocks.model import quat_matrix

    return np.asarray(jax.vmap(quat_matrix)(st.q)) if st.q.ndim == 2 else np.asarray(quat_matrix(st.q))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shape", choices=("box", "rock"), default="rock")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--iterations", type=int, nargs="+", default=[1, 2, 8])
    ap.add_argument("--warm", type=int, nargs="+", default=[None], help="BlockConfig.fcp_warm_iterations of each "
                    "run (default: the run's iteration count; the reference always runs all its iterations warm too)")
    ap.add_argument("--steps", type=int, default=5000, help="steps of the stable dt (the rocks fall 1 mm into contact)")
    ap.add_argument("--float32", action="store_true", help="in float32 (the benchmarks' precision) instead of float64")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    ref_it = max(a.iterations)
    ref, stat_ref, dt, _ = run(a.n, a.shape, ref_it, a.steps)
    xr, Rr = np.asarray(ref.x), rotation_of(ref)
    size = 0.19

    def diff(st):
        dx = np.linalg.norm(np.asarray(st.x)[1:] - xr[1:], axis=1)
        R = rotation_of(st)
        rot = None if R is None else float(np.max(np.abs(R[1:] - Rr[1:])))
        return float(dx.max()), float(np.sqrt(np.mean(dx**2))), rot

    settle = float(np.max(np.linalg.norm(xr[1:] - np.asarray(pile(a.n, shape=a.shape)[1])[1:], axis=1)))
    base = dict(bench="fcp_iterations_pile", dtype=str(ref.x.dtype), shape=a.shape, n_blocks=a.n, steps=a.steps, dt=dt, t_end=a.steps * dt,
                reference_iterations=ref_it, max_block_travel_m=settle, block_size_m=size,
                date=time.strftime("%Y-%m-%d"), cmd="experiments/fcp_iterations_pile.py " + " ".join(sys.argv[1:]))
    nudged, stat_n, _, _ = run(a.n, a.shape, ref_it, a.steps, nudge=1e-9)
    mx, rms, rot = diff(nudged)
    emit(dict(base, case=f"{ref_it} iterations, initial heights +1e-9 m", max_dx_m=mx, rms_dx_m=rms, max_drot=rot,
              status=Status.describe(stat_n)), a.out)
    for it in a.iterations:
        for w in a.warm:
            if it == ref_it and (w is None or w >= it):
                continue
            st, stat, _, wall = run(a.n, a.shape, it, a.steps, warm=w)
            mx, rms, rot = diff(st)
            case = f"{it} iterations" + ("" if w is None or w >= it else f", {w} when warm-started")
            emit(dict(base, case=case, iterations=it, warm_iterations=it if w is None else min(w, it), max_dx_m=mx,
                      rms_dx_m=rms, max_drot=rot, status=Status.describe(stat), wall_s=round(wall, 2)), a.out)


if __name__ == "__main__":
    main()
