"""The field-scale scene (``scenes.fjord``) at a laptop resolution, decomposed over forced CPU
devices (``decomposition.run_sharded``) against one device: JSON lines.

Per device count D (each in its own subprocess, ``--xla_force_host_platform_device_count=D``):
water / wall / slide particles, the slabs' owned counts and halo rows, wall time of the run (the
forced devices share this machine's cores), the status bits, regrows and rebalances, the slide's
travel, and with D > 1 the largest difference of the water positions [m] and of the slide's
centroid from the one-device run in the same process (float32 unless ``--x64``).

    .venv/bin/python experiments/fjord_sharded.py [--dx 4] [--t-end 1.0] [--devices 2 4] [--x64]
        [--out experiments/results/fjord_sharded.jsonl]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from forced_devices import parse, run_child  # noqa: E402
from jsonl_out import emit  # noqa: E402

ROOT = os.path.dirname(HERE)


def child(args):
    import jax

    if args.x64:
        jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_compilation_cache_dir", os.path.join(ROOT, ".jax_cache"))
    import numpy as np

    from rockjax import decomposition as D, scenes
    from rockjax.driver import host_frame
    from rockjax.rollout import make_rollout
    from rockjax.step import prime

    n = jax.device_count()
    sc = scenes.fjord(dx=args.dx)
    cfg = sc.config
    k = cfg.rebuild_every
    steps = max(k, int(round(args.t_end / cfg.dt / k)) * k)
    t = time.perf_counter()
    r = D.run_sharded(sc, n, steps, chunk_steps=steps)
    jax.block_until_ready(r.state)
    wall = time.perf_counter() - t
    g = D.gather_fluid(r.dec, r.state)
    slide = np.asarray(r.state.state.blocks.x)[0, 0]
    rec = dict(devices=n, dx=args.dx, x64=bool(args.x64), steps=steps, dt=cfg.dt, water=r.dec.n_water,
               walls=cfg.n_wall, slide_particles=cfg.n_block_particles, bounds=list(r.dec.bounds),
               owned=np.asarray(r.state.slab.owned_count).tolist(), halo_rows=np.asarray(r.state.slab.halo_sent).tolist(),
               local_rows=r.dec.n_local, status=D.slab_status(r.state), regrows=r.regrows, rebalances=r.rebalances,
               wall_s_with_compile=wall,
               slide_travel=float(np.linalg.norm(slide - np.asarray(sc.state.blocks.x)[0])))
    if n > 1:
        run = jax.jit(make_rollout(cfg, steps // k, checkpoint=False))
        ref, _ = run(prime(sc.state, sc.params, cfg), sc.params)
        water = host_frame(ref)["x"][:r.dec.n_water]  # original particle order: the water first
        rec.update(max_dx_vs_one_device=float(np.abs(g["x"] - water).max()),
                   slide_dx_vs_one_device=float(np.abs(slide - np.asarray(ref.blocks.x)[0]).max()),
                   one_device_status=int(ref.status))
    print("RESULT " + json.dumps(rec), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=4.0)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--devices", type=int, nargs="+", default=[2, 4])
    ap.add_argument("--x64", action="store_true")
    args = parse(ap, child)
    if args is None:
        return
    date = datetime.date.today().isoformat()
    for n in args.devices:
        rec = run_child(__file__, ["--dx", str(args.dx), "--t-end", str(args.t_end)] + (["--x64"] if args.x64 else []), n)
        emit(dict(rec, date=date, kind="fjord_sharded"), args.out)


if __name__ == "__main__":
    main()
