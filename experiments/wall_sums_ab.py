"""The walls' extrapolation sums (``walls.adami_sums``) over the real flat (fluid, wall) list, four
ways: the list in row order summed by ``segment_sum`` (``WallSums.SCATTER``, a scatter-add: on a
GPU, atomics into the wall rows), the list in wall order summed by
``segment_sum(indices_are_sorted=True)``, the list in wall order summed as padded ranges over the
walls near the fluid only (a gather and a row sum, no scatter), and rockjax's ``WallSums.RANGES``
(a segmented scan over the wall-ordered list, read at each wall's last slot).

The dam break of ``--size`` (``compare_peers``) is primed; the list's pairs are sorted by wall once
(outside the timing: a list rebuild's job). Each variant is one jitted function from positions,
pressures and densities to the [n, 2] sums, geometry included; best of ``--reps`` calls. JSON
lines: ms per call, the largest difference from the row-order sums relative to their scale.

    python experiments/wall_sums_ab.py --size 1M     # on the device machine
    python experiments/wall_sums_ab.py --size 5k     # a dry run on the CPU
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compare_peers import NX  # noqa: E402
from jsonl_out import emit  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="1M")
    ap.add_argument("--reps", type=int, default=20)
    a = ap.parse_args(argv)

    import jax
    import jax.numpy as jnp
    import numpy as np

    import rockjax as rj
    from rockjax.sph.neighbours import take
    from rockjax.sph.walls import adami_sums, wall_pair_geometry
    from rockjax.step import prime
    from rockjax.tuning import WallSums

    scene = rj.scenes.dam_break(dx=0.5 / NX[a.size])
    config, params = scene.config.tuned(wall_sums=WallSums.SCATTER), scene.params
    ranges_config = config.tuned(wall_sums=WallSums.RANGES)
    nbrs_r = jax.jit(lambda s, p: prime(s, p, ranges_config))(scene.state, params).nbrs
    state = jax.jit(lambda s, p: prime(s, p, config))(scene.state, params)
    P, nbrs, n = state.particles, state.nbrs, config.n_particles
    f = params.fluid
    w_fn = config.scheme.kernel.w
    count = int(nbrs.wall_count)
    row, col = np.asarray(nbrs.wall_row), np.asarray(nbrs.wall_col)
    M = row.shape[0]
    # the list by wall: valid pairs sorted by column (stable: rows ascending within a wall), padding last
    key = np.where(np.arange(M) < count, col, n)
    order = np.argsort(key, kind="stable")
    row_s, col_s = row[order], col[order]
    per_wall = np.bincount(col[:count], minlength=n)
    start = np.concatenate([[0], np.cumsum(per_wall)[:-1]]).astype(np.int32)
    kw = int(per_wall.max())
    near = np.nonzero(per_wall)[0].astype(np.int32)  # walls with a fluid neighbour
    nbrs_s = nbrs.replace(wall_row=jnp.asarray(row_s), wall_col=jnp.asarray(col_s))
    grid = config.grid
    gravity = params.gravity

    def current(x, p, rho):
        return adami_sums(wall_pair_geometry(x, nbrs, grid), p, rho, gravity, f.h, w_fn, config)

    def shipped_ranges(x, p, rho):
        return adami_sums(wall_pair_geometry(x, nbrs_r, grid), p, rho, gravity, f.h, w_fn, ranges_config)

    def sorted_segment(x, p, rho):
        wp = wall_pair_geometry(x, nbrs_s, grid)
        w = jnp.where(wp.valid, w_fn(wp.r, f.h), 0.0)
        g_d = wp.d[0] * gravity[0] + wp.d[1] * gravity[1] + wp.d[2] * gravity[2]
        vals = jnp.stack([w * (take(p, wp.row) - take(rho, wp.row) * g_d), w], axis=-1)
        return jax.ops.segment_sum(vals, wp.col, num_segments=n, indices_are_sorted=True)

    start_near = jnp.asarray(start[near])
    cnt_near = jnp.asarray(per_wall[near].astype(np.int32))
    near_j = jnp.asarray(near)

    def ranges(x, p, rho):
        wp = wall_pair_geometry(x, nbrs_s, grid)
        w = jnp.where(wp.valid, w_fn(wp.r, f.h), 0.0)
        g_d = wp.d[0] * gravity[0] + wp.d[1] * gravity[1] + wp.d[2] * gravity[2]
        vals = jnp.stack([w * (take(p, wp.row) - take(rho, wp.row) * g_d), w], axis=-1)
        k = jnp.arange(kw, dtype=jnp.int32)[None, :]
        slot = jnp.minimum(start_near[:, None] + k, M - 1)
        got = jnp.where((k < cnt_near[:, None])[..., None], vals[slot], 0.0).sum(1)  # [n_near, 2]
        return jnp.zeros((n, 2), vals.dtype).at[near_j].set(got, unique_indices=True, indices_are_sorted=True)

    args = (P.x, P.p, P.rho)
    ref = None
    for name, fn in [("row_order_segment_sum", current), ("wall_order_segment_sum_sorted", sorted_segment),
                     ("wall_order_ranges_near_walls", ranges), ("rockjax_wall_sums_ranges", shipped_ranges)]:
        jf = jax.jit(fn)
        t0 = time.perf_counter()
        out = jax.block_until_ready(jf(*args))
        compile_s = time.perf_counter() - t0
        best = float("inf")
        for _ in range(a.reps):
            t0 = time.perf_counter()
            jax.block_until_ready(jf(*args))
            best = min(best, time.perf_counter() - t0)
        out = np.asarray(out)
        ref = out if ref is None else ref
        scale = np.abs(ref).max(axis=0)
        emit({"bench": "wall_sums_ab", "size": a.size, "variant": name, "n_fluid": config.n_fluid,
              "n_wall": config.n_wall, "wall_pairs": count, "wall_pair_capacity": M, "max_per_wall": kw,
              "walls_near_fluid": int(near.size), "ms": round(1e3 * best, 4), "compile_s": round(compile_s, 2),
              "max_rel_diff": float((np.abs(out - ref).max(axis=0) / scale).max()),
              "dtype": str(P.x.dtype), "backend": jax.default_backend()})


if __name__ == "__main__":
    main()
