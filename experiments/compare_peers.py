"""rockjax against the peer SPH codes (PySPH, SPlisHSPlasH) on the same 3D dam break: JSON lines.

The case is the peers' throughput case (``shared/peers/common.py``, README there): a 0.5 x 0.5 x
1.0 m water column in the corner of a 2.0 x 1.0 m open tank, g = 9.81, rho0 = 1000, Tait EOS with
c0 = 10 sqrt(2 g H) = 44.3 m/s, fluid on the same cell-centred lattice dx = 0.5 / nx, nx = 14, 22,
34 -> 5 488, 21 296, 78 608 fluid particles (identical in the three codes). rockjax runs
``scenes.dam_break`` (its default *is* this geometry, z up instead of the peers' y up) for the
same physical time as the peers' WCSPH window (steps x dt of PySPH WCSPH: 300 / 150 / 60 steps
of 0.3 dx / c0 -> 72.6 / 23.1 / 6.0 ms), from the start of the collapse, output off: one jitted
chunk (a scan of ``rollout.scheduled_step``, the schedule ``simulate`` runs: list rebuilt at the
start, on displacement and at least every 32 steps) timed after compilation, best of ``--reps``.
Its own time step is
0.25 h / c0 = 0.325 dx / c0 (h = 1.3 dx), so it takes slightly fewer steps than the peers.

Peers: if their venv exists (``$PEER_VENV``, default ``~/.cache/peer-venv``; install with
``shared/peers/install_peers.sh``, ~7 min) and ``--run-peers`` is given, each peer case runs in
its own subprocess right after rockjax's case, so the ratios come from one session on one
machine. Otherwise the recorded peer figures are used: ``--peer-results`` (default
``experiments/results/peers_2026-11-24.jsonl``, a copy of ``shared/peers/results``; measured on
an idle machine of this kind on 2026-11-24, an AMD EPYC Zen 5 2-core machine).

Printed per case and code: ``particle_steps_per_s`` (fluid particles x steps / wall s, the
peers' metric), ``sim_s_per_wall_s`` (physical time per wall second: credits larger time steps),
``cpu_particle_steps_per_s`` (per process-CPU second, steadier on a shared machine), and
``foreign_cpu`` (cores used by *other* processes while it ran; above ~0.2 the wall figures of
any code are not comparable). Then one ``ratio`` line per case and peer:
``rockjax / peer`` for particle-steps/s and sim-s per wall-s.

Usage (from the repository root)::

    .venv/bin/python experiments/compare_peers.py                    # 5k 20k, recorded peers
    .venv/bin/python experiments/compare_peers.py --sizes 5k 20k 80k --run-peers
    .venv/bin/python experiments/compare_peers.py --out experiments/results/compare_peers.jsonl

Environment: ``PEER_VENV`` (peer venv), ``PEERS_DIR`` (the peer scripts; default
``../shared/peers`` next to the repository), ``OMP_NUM_THREADS`` (peer threads; default 2).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import resource
import subprocess
import sys
import time

from jsonl_out import emit as emit_line

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PEERS_DIR = os.environ.get("PEERS_DIR", os.path.normpath(os.path.join(ROOT, "..", "shared", "peers")))
PEER_VENV = os.environ.get("PEER_VENV", os.path.expanduser("~/.cache/peer-venv"))
DEFAULT_PEER_RESULTS = os.path.join(ROOT, "experiments", "results", "peers_2026-11-24.jsonl")

G = 9.81
NX = {"5k": 14, "20k": 22, "80k": 34, "160k": 43, "300k": 53, "1M": 79}  # 2 nx^3 fluid particles (160k-1M: scaling only)
#: the peers' measured window (steps after 10 warm-up steps) per size, shared/peers/run_peers.sh
PEER_STEPS = {"5k": 300, "20k": 150, "80k": 60}
C0 = 10.0 * math.sqrt(2 * G * 1.0)
#: (code, scheme) cases of the peers, with their run script
PEER_CASES = [("pysph", "wcsph", "pysph_bench.py"), ("splishsplash", "wcsph", "splash_bench.py"),
              ("splishsplash", "dfsph", "splash_bench.py")]


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _monitor():
    """The peers' CPU-contention monitor (``common.CpuMonitor``), or None if the scripts are absent."""
    if not os.path.isfile(os.path.join(PEERS_DIR, "common.py")):
        return None
    sys.path.insert(0, PEERS_DIR)
    try:
        import common  # noqa: PLC0415

        return common.CpuMonitor
    except Exception:
        return None
    finally:
        sys.path.pop(0)


def compiled_chunk(size: str, scheme: str, *, blocks: int | None = None, period: int | None = None,
                   tuning: dict | None = None) -> dict:
    """The peers' 3D dam break of ``size`` as one compiled chunk, regrown until it runs clean.

    Returns a dict: ``chunk`` (compiled, ``(state, params) -> (state, sweeps)``), ``state`` (primed),
    ``params``, ``config``, ``counts``, ``dx``, ``steps``, ``period``, ``regrows``, ``setup_s``,
    ``compile_s`` and ``sweeps`` (per step the DFSPH solves' sweeps, [steps, 2], or None). The
    steps are those of the peers' physical window, or ``blocks`` x ``period`` (the scaling mode);
    they are scanned as ``simulate`` scans them (``rollout.scheduled_step``): the list is rebuilt at
    step 0, on displacement, and at least every ``period`` steps (default the driver's,
    ``driver.DEFAULT_REBUILD_PERIOD``). ``tuning``: ``Tuning`` fields to set (``Config.tuned``).
    """
    import jax

    import rockjax as rj
    from rockjax.driver import DEFAULT_REBUILD_PERIOD, _grow, resize
    from rockjax.rollout import scheduled_step
    from rockjax.step import prime

    nx = NX[size]
    dx = 0.5 / nx
    # the peers' window: WCSPH dt = 0.3 dx / c0; SPlisHSPlasH DFSPH dt = 0.4 dx / sqrt(2 g H) = 0.4 dx / (c0 / 10)
    # (DFSPH's window capped at 0.8 s: later the splash off the far wall leaves rockjax's closed
    # domain, 3.5 m high; the peers' tank is open)
    t_window = PEER_STEPS.get(size, 60) * 0.3 * dx / C0
    if scheme == "dfsph":
        t_window = min(PEER_STEPS.get(size, 60) * 4.0 * dx / C0, 0.8)
    t0 = time.perf_counter()
    scene = rj.scenes.dam_break(dx=dx, scheme=rj.sph.from_names(scheme))
    setup_s = time.perf_counter() - t0
    config, params, state0 = scene.config, scene.params, scene.state
    if tuning:
        config = config.tuned(**tuning)
    regrows = 0
    compile_s = 0.0
    period = max(config.rebuild_every, DEFAULT_REBUILD_PERIOD) if period is None else int(period)
    while True:
        steps = blocks * period if blocks else max(1, round(t_window / config.dt))
        t0 = time.perf_counter()
        state = jax.jit(lambda s, p: prime(s, p, config))(state0, params)
        one = scheduled_step(config, period=period)
        def body(s, p):  # the sweeps of each step's solves ride along (DFSPH; nothing for WCSPH)
            s = one(s, p)
            solver = s.particles.solver
            return s, (None if solver is None else solver[0, 4:6])

        chunk = jax.jit(lambda s, p: jax.lax.scan(lambda s, _: body(s, p), s, None, length=steps))
        chunk_c = chunk.lower(state, params).compile()
        compile_s += time.perf_counter() - t0
        out, sweeps = jax.block_until_ready(chunk_c(state, params))
        bits = int(out.status) | int(state.status)
        if bits & ~int(rj.Status.growable()):
            raise RuntimeError(f"rockjax {size}/{scheme}: fatal status {rj.Status.describe(bits)}")
        if not bits:
            break
        regrows += 1
        if regrows > 6:
            raise RuntimeError(f"rockjax {size}/{scheme}: gave up regrowing ({rj.Status.describe(bits)})")
        config, period = _grow(config, period, out if int(out.status) else state, bits)
        state0 = resize(state0, config)
    return {"chunk": chunk_c, "state": state, "params": params, "config": config, "counts": scene.counts(),
            "dx": dx, "steps": steps, "period": period, "regrows": regrows, "setup_s": setup_s,
            "compile_s": compile_s, "sweeps": sweeps}


def run_rockjax(size: str, scheme: str, *, reps: int, blocks: int | None = None, period: int | None = None) -> dict:
    """Time rockjax on the peers' 3D dam break of ``size`` (``compiled_chunk``), best of ``reps``."""
    import jax

    import rockjax as rj

    c = compiled_chunk(size, scheme, blocks=blocks, period=period)
    chunk_c, state, params, config, counts = c["chunk"], c["state"], c["params"], c["config"], c["counts"]
    dx, steps, period, regrows, sweeps = c["dx"], c["steps"], c["period"], c["regrows"], c["sweeps"]
    setup_s, compile_s = c["setup_s"], c["compile_s"]
    Mon = _monitor()
    mon = Mon().start() if Mon else None
    walls, cpus = [], []
    for _ in range(reps):
        c0, w0 = _cpu(), time.perf_counter()
        jax.block_until_ready(chunk_c(state, params))
        walls.append(time.perf_counter() - w0)
        cpus.append(_cpu() - c0)
    foreign = mon.stop() if mon else None
    i = min(range(reps), key=lambda j: walls[j])
    wall, cpu = walls[i], cpus[i]
    nf = counts["fluid"]
    solver = {} if sweeps is None else {  # mean sweeps per step, as the peer's dfsph_iters / dfsph_iters_v
        "dfsph_iters": round(float(sweeps[:, 0].mean()), 3), "dfsph_iters_v": round(float(sweeps[:, 1].mean()), 3),
        "kernel": config.scheme.kernel.name, "h_dx": round(float(params.fluid.h) / dx, 3)}
    return {"code": "rockjax", "version": rj.__version__, "scheme": scheme, "case": "dambreak3d_throughput",
            "size": size, "n_fluid": nf, "n_wall": counts["wall"], "dx": dx, "dt": config.dt, "steps": steps,
            "t_window_s": round(steps * config.dt, 6), "dtype": str(state.particles.x.dtype),
            "rebuild_period": period, "K": config.neighbour_capacity, "regrows": regrows,
            "wall_s": round(wall, 4), "cpu_s": round(cpu, 4),
            "particle_steps_per_s": round(nf * steps / wall, 1),
            "cpu_particle_steps_per_s": round(nf * steps / max(cpu, 1e-9), 1),
            "sim_s_per_wall_s": round(steps * config.dt / wall, 6),
            "compile_s": round(compile_s, 2), "setup_s": round(setup_s, 2), "reps": reps,
            "foreign_cpu": foreign, "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "jax": jax.__version__, "backend": jax.default_backend(), "source": "measured", **solver,
            **_device_memory(jax)}


def _device_memory(jax) -> dict:
    """The accelerator's name and its allocator's peak bytes in use (empty on the CPU backend)."""
    dev = jax.devices()[0]
    if dev.platform == "cpu":
        return {}
    stats = dev.memory_stats() or {}
    return {"device_kind": dev.device_kind,
            "peak_device_mb": round(stats.get("peak_bytes_in_use", 0) / 2**20, 1) or None}


def _peer_derived(rec: dict) -> dict:
    rec = dict(rec)
    if rec.get("cpu_s"):
        rec["cpu_particle_steps_per_s"] = round(rec["n_fluid"] * rec["steps"] / rec["cpu_s"], 1)
    rec["sim_s_per_wall_s"] = round(rec["steps"] * rec["dt"] / rec["wall_s"], 6)
    return rec


def run_peer(code: str, scheme: str, script: str, size: str, *, timeout: float) -> dict:
    """One peer case in the peer venv (``shared/peers/*_bench.py throughput``)."""
    py = os.path.join(PEER_VENV, "bin", "python")
    cmd = [py, os.path.join(PEERS_DIR, script), "throughput", "--scheme", scheme, "--size", size,
           "--steps", str(PEER_STEPS[size])]
    env = dict(os.environ, OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "2"),
               PEERS_MAX_IDLE_WAIT=os.environ.get("PEERS_MAX_IDLE_WAIT", "30"))
    env.pop("PEERS_RESULTS", None)
    try:
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=timeout,
                           env=env, cwd=PEERS_DIR)
        out = p.stdout
        rc = p.returncode
    except subprocess.TimeoutExpired:
        return {"code": code, "scheme": scheme, "size": size, "error": f"timeout after {timeout} s"}
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    if rc or not lines:
        return {"code": code, "scheme": scheme, "size": size, "error": f"rc={rc}",
                "log_tail": "\n".join(out.splitlines()[-5:])}
    rec = _peer_derived(json.loads(lines[-1]))
    rec["source"] = "measured"
    return rec


def recorded_peers(path: str) -> dict:
    """{(code, scheme, size): record} from a peers JSONL file: the last clean attempt of each case."""
    out = {}
    with open(path) as f:
        for ln in f:
            if not ln.startswith("{"):
                continue
            r = json.loads(ln)
            if r.get("case") != "dambreak3d_throughput" or "error" in r or not r.get("particle_steps_per_s"):
                continue
            r = _peer_derived(r)
            r["source"] = f"recorded ({os.path.relpath(path, ROOT)})"
            out[(r["code"], r["scheme"], r["size"])] = r
    return out


def _meta() -> dict:
    return {"date": datetime.date.today().isoformat(), "host_cpus": os.cpu_count(), "machine": platform.machine(),
            "python": platform.python_version(), "load_avg_1m": round(os.getloadavg()[0], 2)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", default=["5k", "20k"], choices=list(NX))
    ap.add_argument("--schemes", nargs="+", default=["wcsph"], help="rockjax schemes (wcsph, dfsph, seed)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--run-peers", action="store_true", help="run the peers now (needs $PEER_VENV)")
    ap.add_argument("--peer-results", default=DEFAULT_PEER_RESULTS, help="recorded peer JSONL (fallback)")
    ap.add_argument("--peer-timeout", type=float, default=600)
    ap.add_argument("--peer-cases", nargs="+", default=None, metavar="CODE:SCHEME",
                    help="only these peer cases, e.g. splishsplash:dfsph (default: all)")
    ap.add_argument("--out", default=None, help="also append the JSON lines to this file")
    ap.add_argument("--scaling", action="store_true",
                    help="rockjax only: throughput and peak memory vs size (up to 300k), --blocks list blocks each")
    ap.add_argument("--blocks", type=int, default=2, help="rebuild periods per timed chunk (--scaling)")
    ap.add_argument("--case", nargs=2, metavar=("SIZE", "SCHEME"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args.case:  # child: one rockjax case, own process (own compile cache and peak memory)
        rec = run_rockjax(args.case[0], args.case[1], reps=args.reps, blocks=args.blocks if args.scaling else None)
        print(json.dumps(rec), flush=True)
        return

    def emit(rec):
        emit_line(dict(rec, **_meta()) if "date" not in rec else rec, args.out)

    if args.scaling:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=ROOT).stdout.strip()
        for size in args.sizes:
            for scheme in args.schemes:
                cmd = [sys.executable, os.path.abspath(__file__), "--case", size, scheme, "--reps", str(args.reps),
                       "--scaling", "--blocks", str(args.blocks)]
                p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
                lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
                if p.returncode or not lines:
                    emit({"bench": "sph_scaling", "code": "rockjax", "scheme": scheme, "size": size,
                          "error": (p.stderr or p.stdout).strip().splitlines()[-1:]})
                    continue
                r = json.loads(lines[-1])
                r.update(bench="sph_scaling", code_version=f"git {commit}",
                         fluid_particle_steps_per_s=r["particle_steps_per_s"],
                         ms_per_step=round(1e3 * r["wall_s"] / r["steps"], 2),
                         cpu_ms_per_step=round(1e3 * r["cpu_s"] / r["steps"], 2))
                emit(r)
        return

    have_venv = os.path.isfile(os.path.join(PEER_VENV, "bin", "python"))
    run_peers = args.run_peers and have_venv and os.path.isdir(PEERS_DIR)
    if args.run_peers and not run_peers:
        print(f"# peers not run: venv {PEER_VENV} or scripts {PEERS_DIR} missing; using {args.peer_results}",
              file=sys.stderr)
    recorded = {}
    if not run_peers:
        if not os.path.isfile(args.peer_results):
            sys.exit(f"no peer results at {args.peer_results}; pass --peer-results or --run-peers")
        recorded = recorded_peers(args.peer_results)

    for size in args.sizes:
        ours = []
        for scheme in args.schemes:
            cmd = [sys.executable, os.path.abspath(__file__), "--case", size, scheme, "--reps", str(args.reps)]
            p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
            lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
            if p.returncode or not lines:
                emit({"code": "rockjax", "scheme": scheme, "size": size,
                      "error": (p.stderr or p.stdout).strip().splitlines()[-1:]})
                continue
            rec = json.loads(lines[-1])
            emit(rec)
            ours.append(rec)
        peers = []
        for code, scheme, script in PEER_CASES:
            if args.peer_cases and f"{code}:{scheme}" not in args.peer_cases:
                continue
            if run_peers:
                rec = run_peer(code, scheme, script, size, timeout=args.peer_timeout)
            else:
                rec = recorded.get((code, scheme, size))
                if rec is None:
                    continue
            emit(rec)
            if "error" not in rec:
                peers.append(rec)
        for r in ours:
            for q in peers:
                ratio = {"kind": "ratio", "case": "dambreak3d_throughput", "size": size,
                         "rockjax_scheme": r["scheme"], "peer": q["code"], "peer_scheme": q["scheme"],
                         "peer_source": q.get("source"),
                         "particle_steps_ratio": round(r["particle_steps_per_s"] / q["particle_steps_per_s"], 4),
                         "sim_time_ratio": round(r["sim_s_per_wall_s"] / q["sim_s_per_wall_s"], 4),
                         "rockjax_foreign_cpu": r.get("foreign_cpu"), "peer_foreign_cpu": q.get("foreign_cpu")}
                if r.get("cpu_particle_steps_per_s") and q.get("cpu_particle_steps_per_s"):
                    ratio["cpu_particle_steps_ratio"] = round(
                        r["cpu_particle_steps_per_s"] / q["cpu_particle_steps_per_s"], 4)
                emit(ratio)


if __name__ == "__main__":
    main()
