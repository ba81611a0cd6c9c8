"""One scene over 1, 2 and 4 devices (``rockjax.decomposition``): per-device work, halo volume and
step time, weak-scaled; and a written estimate for 8-64 GPUs. JSON lines.

Weak scaling: the 3D dam break's column is ``D`` times as long (0.5 m per device, 1.0 m high and
0.5 m wide; dx = 0.5 / nx), cut into ``D`` slabs of equal counts, so each device owns the same
~2 nx^3 water particles; ``--scheme dfsph`` runs DFSPH (its sweeps exchange their halo rows;
its cubic spline's shorter support makes the halo thinner). Each device count runs in its own subprocess with
``XLA_FLAGS=--xla_force_host_platform_device_count=D`` (the forced CPU devices share this
machine's cores: the wall time per step measures the total work, not a parallel speed-up; the
per-device rows and the halo volume are what carries to real devices). Per case:

* ``owned`` (mean owned rows per device), ``local_rows`` (the local fluid segment: owned + 2 halo
  buffers), ``halo_rows`` (rows sent per step, both sides, mean over devices), ``halo_mb_per_step``
  (their records' bytes), ``halo_fraction`` (halo rows / owned rows);
* ``ms_per_step`` of a compiled run of ``--steps`` steps from the primed state (second call, so
  compilation is excluded), ``water_particle_steps_per_s``, ``sim_s_per_wall_s``;
* with D = 1 also the plain one-device rollout on the same scene, ``plain_ms_per_step``: the
  decomposition's own overhead at one slab (no halo; the layout and the exchange's bookkeeping).

The last record (``kind: "estimate"``) is a model, not a measurement: per-step time on D GPUs =
capacity_factor (owned + halo rows) / the measured single-GPU WCSPH throughput (padding rows cost
as much as water rows: the local step runs every row of its buffers) + 2 exchanges x (latency +
halo bytes / link bandwidth), for a long channel whose cross-section holds ``--cross-section`` particles
(per x layer of dx), at the GPU throughput, link bandwidths and latencies stated in the record.

    .venv/bin/python experiments/bench_slabs.py [--nx 14] [--devices 1 2 4] [--steps 64] [--scheme dfsph]
        [--out experiments/results/slabs.jsonl]
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
    import numpy as np

    jax.config.update("jax_compilation_cache_dir", os.path.join(ROOT, ".jax_cache"))
    from rockjax import decomposition as D
    from rockjax.rollout import make_rollout
    from rockjax.scenes.fluid import dam_break
    from rockjax.step import prime

    n = jax.device_count()
    dx = 0.5 / args.nx
    sc = dam_break(dx=dx, column_length=0.5 * n, column_width=0.5, column_height=1.0, tank_length=0.5 * n + 1.5,
                   tank_width=0.5, scheme=args.scheme)
    cfg = sc.config
    steps = args.steps - args.steps % cfg.rebuild_every
    dec, ss = D.decompose(sc, n)
    ss = D.sharded_prime(dec, ss, sc.params)
    run = jax.jit(D.make_sharded_rollout(dec, steps, checkpoint=False))
    out = run(ss, sc.params)
    jax.block_until_ready(out)
    t = time.perf_counter()
    out = run(ss, sc.params)
    jax.block_until_ready(out)
    wall = time.perf_counter() - t
    row_bytes = sum(np.asarray(a).itemsize * int(np.prod(np.asarray(a).shape[2:]))
                    for a in jax.tree_util.tree_leaves(out.state.particles))
    halo = float(np.mean(np.asarray(out.slab.halo_sent)))
    owned = float(np.mean(np.asarray(out.slab.owned_count)))
    rec = dict(kind="case", scheme=args.scheme, devices=n, nx=args.nx, dx=dx, n_water=dec.n_water, steps=steps, dt=cfg.dt,
               owned=owned, owned_capacity=dec.owned, halo_capacity=dec.halo, local_rows=dec.n_local,
               local_walls=dec.local.n_wall, walls=cfg.n_wall, halo_width=dec.halo_width, halo_rows=halo,
               row_bytes=row_bytes, halo_mb_per_step=halo * row_bytes / 1e6, halo_fraction=halo / owned,
               status=D.slab_status(out), ms_per_step=1e3 * wall / steps,
               water_particle_steps_per_s=dec.n_water * steps / wall, sim_s_per_wall_s=steps * cfg.dt / wall,
               migrated=int(np.sum(np.asarray(out.slab.migrated))))
    if n == 1:
        roll = jax.jit(make_rollout(cfg, steps // cfg.rebuild_every, checkpoint=False))
        s0 = prime(sc.state, sc.params, cfg)
        jax.block_until_ready(roll(s0, sc.params))
        t = time.perf_counter()
        jax.block_until_ready(roll(s0, sc.params))
        rec["plain_ms_per_step"] = 1e3 * (time.perf_counter() - t) / steps
        rec["overhead_ratio"] = rec["ms_per_step"] / rec["plain_ms_per_step"]
    print("RESULT " + json.dumps(rec), flush=True)


def estimate(cases: list[dict], args) -> dict:
    """The written weak-scaling model (module docstring); its constants are in the record."""
    c = max(cases, key=lambda r: r["devices"])
    layers = c["halo_width"] / c["dx"]  # halo width in dx
    gpu_rate = 116e6  # WCSPH f32 particle-steps/s at 1M on one H200 (RESULTS.md "GPU")
    links = {"nvlink": (450e9, 10e-6), "infiniband_ndr": (50e9, 20e-6)}
    rows = []
    for per_device in (1e6, 4e6):
        owned_layers = per_device / args.cross_section
        halo_rows = 2 * layers * args.cross_section
        for n in (8, 16, 32, 64):
            link = "nvlink" if n <= 8 else "infiniband_ndr"
            bw, lat = links[link]
            t_compute = args.capacity_factor * (per_device + halo_rows) / gpu_rate
            t_ex = 2 * (lat + halo_rows / 2 * c["row_bytes"] / bw)
            rows.append(dict(gpus=n, particles=per_device * n, per_device=per_device, slab_dx=owned_layers,
                             halo_rows=halo_rows, link=link, ms_compute=1e3 * t_compute, ms_exchange=1e3 * t_ex,
                             efficiency=(per_device / gpu_rate) / (t_compute + t_ex)))
    return dict(kind="estimate", cross_section=args.cross_section, capacity_factor=args.capacity_factor, halo_width_dx=layers, row_bytes=c["row_bytes"],
                gpu_particle_steps_per_s=gpu_rate, links={k: dict(bandwidth_Bps=v[0], latency_s=v[1]) for k, v in links.items()},
                rows=rows, note="a model from the measured halo width and record size; not measured on GPUs")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=14)
    ap.add_argument("--devices", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--steps", type=int, default=64)
    ap.add_argument("--scheme", default="wcsph", choices=["wcsph", "dfsph"])
    ap.add_argument("--cross-section", type=float, default=200 * 50.0,
                    help="particles per x layer of the channel in the estimate (e.g. 200 m x 50 m at dx = 1 m)")
    ap.add_argument("--capacity-factor", type=float, default=1.5, help="decompose()'s buffer factor in the estimate")
    args = parse(ap, child)
    if args is None:
        return
    date = datetime.date.today().isoformat()
    cases = []
    for n in args.devices:
        rec = run_child(__file__, ["--nx", str(args.nx), "--steps", str(args.steps), "--scheme", args.scheme], n)
        if "error" in rec:
            emit(dict(rec, kind="case", date=date), args.out)
            continue
        rec = dict(rec, date=date, cores=os.cpu_count())
        cases.append(rec)
        emit(rec, args.out)
    if cases and args.scheme == "wcsph":  # the model uses the measured WCSPH GPU throughput
        emit(dict(estimate(cases, args), date=date), args.out)


if __name__ == "__main__":
    main()
