"""What a checkpoint costs: time to write one and its size in the run file, against a frame's and
against the steps between two frames, and the time a resume takes to start; plus the check that
the resumed run ends where the uninterrupted one does (bit for bit).

    python experiments/bench_checkpoint.py [--dx 0.04 0.03] [--frames 6] [--out experiments/results/checkpoint.jsonl]

One JSON line per scene and dx (``jsonl_out.emit``): n particles, steps per frame, wall s of a chunk
(after the compile), frame write s and MB, checkpoint write s and MB, resume start s (reading the
checkpoint and rebuilding the state, before the first chunk), simulated s per wall s with
checkpoints every frame vs none (the same run twice, measured in this process), bit-identical.
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import tempfile
import time

import h5py
import jax
import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402

import rockjax as rj  # noqa: E402
from rockjax import driver  # noqa: E402
from rockjax.io import hdf5  # noqa: E402


def timed(cls, name, log):
    real = getattr(cls, name)

    def wrapped(*a, **kw):
        t = time.perf_counter()
        out = real(*a, **kw)
        log.setdefault(name, []).append(time.perf_counter() - t)
        return out

    setattr(cls, name, wrapped)
    return real


def storage_mb(path, group):
    with h5py.File(path, "r") as f:
        total = 0

        def add(_, obj):
            nonlocal total
            if isinstance(obj, h5py.Dataset):
                total += obj.id.get_storage_size()

        f[group].visititems(add)
    return total / 2**20


def frame_mb(path):
    with h5py.File(path, "r") as f:
        n = f["time"].shape[0]
        names = [k for k in f if isinstance(f[k], h5py.Dataset) and k not in ("time", "status", "kind")]
        return sum(f[k].id.get_storage_size() for k in names) / n / 2**20


def run(dx: float, frames: int, out_path: str):
    scene = rj.scenes.sliding_wedge(dx=dx)
    steps_per_frame = 200
    frame_dt = steps_per_frame * scene.config.dt
    t_end = frames * frame_dt
    kw = dict(t_end=t_end, frame_dt=frame_dt, progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        rj.simulate(scene, out=os.path.join(tmp, "warm.h5"), **dict(kw, t_end=frame_dt))  # compile
        log: dict = {}
        reals = [timed(hdf5.Writer, "write_checkpoint", log), timed(hdf5.Writer, "append", log)]
        chunk_log: dict = {}
        real_chunk = driver._compiled_chunk

        def chunk_timer(config, n, period):
            fn = real_chunk(config, n, period)

            def go(s, p):
                t = time.perf_counter()
                out = jax.block_until_ready(fn(s, p))
                chunk_log.setdefault("chunk", []).append(time.perf_counter() - t)
                return out

            return go

        driver._compiled_chunk = chunk_timer
        try:
            a = os.path.join(tmp, "a.h5")
            t0 = time.perf_counter()
            ref = rj.simulate(scene, out=a, **kw)  # one checkpoint, at the end
            wall_plain = time.perf_counter() - t0
            b = os.path.join(tmp, "b.h5")
            t0 = time.perf_counter()
            rj.simulate(scene, out=b, checkpoint_every=1, **kw)
            wall_ckpt = time.perf_counter() - t0
            c = os.path.join(tmp, "c.h5")
            rj.simulate(scene, out=c, **dict(kw, t_end=(frames // 2) * frame_dt))
            t0 = time.perf_counter()
            ckpt = driver.check_resume(c)
            driver._resumed(ckpt, c, scene, scene.state, scene.params, steps_per_frame, t_end)
            resume_start = time.perf_counter() - t0
            res = rj.simulate(scene, resume=c, **dict(kw, frame_dt=None))
        finally:
            driver._compiled_chunk = real_chunk
            hdf5.Writer.write_checkpoint, hdf5.Writer.append = reals
        same = all(np.array_equal(np.asarray(x), np.asarray(y)) for x, y in
                   zip(jax.tree_util.tree_leaves(res.state), jax.tree_util.tree_leaves(ref.state)))
        sim = frames * frame_dt
        counts = scene.counts()
        rec = dict(
            experiment="bench_checkpoint", scene="sliding_wedge", dx=dx, n_fluid=counts["fluid"],
            n_wall=counts["wall"], steps_per_frame=steps_per_frame, frames=frames,
            chunk_s=float(np.median(chunk_log["chunk"])), frame_write_s=float(np.median(log["append"])),
            checkpoint_write_s=float(np.median(log["write_checkpoint"])), frame_mb=frame_mb(a),
            checkpoint_mb=storage_mb(a, "checkpoints"), resume_start_s=resume_start,
            sim_s_per_wall_s_no_checkpoints=sim / wall_plain, sim_s_per_wall_s_checkpoint_every_frame=sim / wall_ckpt,
            wall_ratio_every_frame=wall_ckpt / wall_plain, resumed_bit_identical=bool(same),
            date=datetime.date.today().isoformat())
        emit(rec, out_path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dx", type=float, nargs="+", default=[0.04, 0.025])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    jax.config.update("jax_compilation_cache_dir", os.path.join(os.path.dirname(__file__), "..", ".jax_cache"))
    for dx in args.dx:
        run(dx, args.frames, args.out)


if __name__ == "__main__":
    main()
