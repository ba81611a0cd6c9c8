"""Where a step's device time goes: a ``jax.profiler`` trace of one compiled dam-break chunk, summed.

The chunk is ``compare_peers.compiled_chunk`` (the peers' 3D dam break, the schedule ``simulate``
runs). After a warm run and ``--runs`` timed runs, ``--trace-runs`` runs are traced (``create_perfetto_trace``); the trace's
device-side events (on a GPU the ``XLA Ops`` line of ``/device:GPU:0``; on the CPU the host's XLA
op events) are summed per HLO instruction and mapped, through the compiled module's text, to the
instruction's ``op_name`` and ``source_file:line`` (the rockjax line that emitted it). JSON lines
out: one ``gpu_profile_total`` record per case (wall ms per step, summed op ms per step, their
ratio: below 1 the device idles between kernels) and one ``gpu_profile_op`` record per
instruction among the largest ``--top`` (ms per step, share of the summed op time, launches per
step). Also the shares grouped by source line (``gpu_profile_line``).

    python experiments/gpu_profile.py --size 1M --scheme wcsph          # on the device machine
    python experiments/gpu_profile.py --size 5k --scheme wcsph --top 10 # a dry run on the CPU
    python experiments/gpu_profile.py --grad 0.0125                     # the gradient's profile
"""

from __future__ import annotations

import argparse
import collections
import glob
import gzip
import json
import os
import re
import shutil
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from compare_peers import compiled_chunk  # noqa: E402
from jsonl_out import emit  # noqa: E402

_INSTR = re.compile(r"^\s*(?:ROOT\s+)?%?([\w.\-]+)\s*=.*?metadata=\{([^}]*)\}")
_FIELD = re.compile(r'(\w+)=("(?:[^"\\]|\\.)*"|\S+)')
_TABLE_ROW = re.compile(r'^(\d+)\s+(.*)$')


def _tables(text: str) -> dict:
    """The module text's FileNames / FunctionNames / FileLocations / StackFrames tables."""
    tables, cur = {}, None
    for line in text.splitlines():
        if line in ("FileNames", "FunctionNames", "FileLocations", "StackFrames"):
            cur = tables.setdefault(line, {})
            continue
        m = _TABLE_ROW.match(line) if cur is not None else None
        if m:
            v = m.group(2)
            cur[int(m.group(1))] = v.strip('"') if v.startswith('"') else {
                k: x.strip('"') for k, x in _FIELD.findall(v.strip("{}"))}
        elif cur is not None and line.strip() == "" and cur:
            cur = None
    return tables


def _frames(tables: dict, frame: int, *, depth: int = 2) -> str:
    """The innermost ``depth`` rockjax frames of a stack frame id, as ``file:line function``."""
    files, funcs = tables.get("FileNames", {}), tables.get("FunctionNames", {})
    locs, stack = tables.get("FileLocations", {}), tables.get("StackFrames", {})
    out, seen = [], set()
    while frame in stack and frame not in seen and len(out) < depth:
        seen.add(frame)
        loc = locs.get(int(stack[frame].get("file_location_id", 0)), {})
        fname = files.get(int(loc.get("file_name_id", 0)), "?")
        func = funcs.get(int(loc.get("function_name_id", 0)), "?")
        if "rockjax" in fname and not any(o.endswith(" " + func) for o in out):
            out.append(f"{fname.split('rockjax/')[-1]}:{loc.get('line', '?')} {func}")
        parent = int(stack[frame].get("parent_frame_id", 0))
        if parent == frame:
            break
        frame = parent
    return " < ".join(out) or "?"


def hlo_sources(text: str) -> dict:
    """``{instruction name: (op_name, "file:line function < caller")}`` from an HLO module's text:
    each instruction's metadata and the module's stack-frame tables (the rockjax frames only)."""
    tables = _tables(text)
    out = {}
    for line in text.splitlines():
        m = _INSTR.match(line)
        if not m:
            continue
        f = {k: v.strip('"') for k, v in _FIELD.findall(m.group(2))}
        src = _frames(tables, int(f["stack_frame_id"])) if "stack_frame_id" in f else \
            f"{os.path.basename(f.get('source_file', '?'))}:{f.get('source_line', '?')}"
        out[m.group(1)] = (f.get("op_name", ""), src)
    return out


def device_events(trace: dict) -> tuple[list, str]:
    """The op-level events of the trace (name, dur in us): the accelerator's ``XLA Ops`` line when
    there is one, else every complete event on a thread whose name says XLA ops (CPU)."""
    pname, tname = {}, {}
    for e in trace.get("traceEvents", []):
        if e.get("ph") == "M" and e.get("name") == "process_name":
            pname[e["pid"]] = e["args"]["name"]
        if e.get("ph") == "M" and e.get("name") == "thread_name":
            tname[(e["pid"], e["tid"])] = e["args"]["name"]
    dev = {p for p, n in pname.items() if "/device:" in n and "CPU" not in n}
    ops = [(e["name"], float(e.get("dur", 0.0))) for e in trace["traceEvents"]
           if e.get("ph") == "X" and e["pid"] in dev and tname.get((e["pid"], e["tid"]), "") == "XLA Ops"]
    if ops:
        return ops, "device XLA Ops"
    kern = [(e["name"], float(e.get("dur", 0.0))) for e in trace["traceEvents"]
            if e.get("ph") == "X" and e["pid"] in dev and "Stream" in tname.get((e["pid"], e["tid"]), "")]
    if kern:
        return kern, "device streams (kernels)"
    host = [(e["name"], float(e.get("dur", 0.0))) for e in trace["traceEvents"]
            if e.get("ph") == "X" and (e.get("args") or {}).get("hlo_op")]
    return host, "host hlo_op events"


def summarize(fn, args, *, steps: int, n_fluid: int, base: dict, runs: int, trace_runs: int, top: int,
              hlo_out: str | None = None) -> list[dict]:
    """Time the compiled ``fn(*args)`` (best of ``runs``), trace ``trace_runs`` more calls, and sum
    the trace's device events per instruction and per rockjax source line, per step of ``steps``.
    Records: ``gpu_profile_total``, the largest ``top`` ``gpu_profile_op`` and ``gpu_profile_line``,
    each with ``base``'s fields."""
    import jax

    text = fn.as_text()
    sources = hlo_sources(text)
    if hlo_out:  # the compiled module, to read the kernels no rockjax frame names (gzip text)
        with gzip.open(hlo_out, "wt") as fp:
            fp.write(text)
    jax.block_until_ready(fn(*args))
    walls = []
    for _ in range(runs):  # untraced wall time, best of runs
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        walls.append(time.perf_counter() - t0)
    d = tempfile.mkdtemp(prefix="rj_trace_")
    try:
        jax.profiler.start_trace(d, create_perfetto_trace=True)
        for _ in range(trace_runs):
            jax.block_until_ready(fn(*args))
        jax.profiler.stop_trace()
        path = sorted(glob.glob(os.path.join(d, "**", "perfetto_trace.json.gz"), recursive=True))[-1]
        with gzip.open(path) as fp:
            trace = json.load(fp)
    finally:
        shutil.rmtree(d, ignore_errors=True)
    events, where = device_events(trace)
    per = collections.defaultdict(lambda: [0.0, 0])
    for name, dur in events:
        per[name][0] += dur
        per[name][1] += 1
    n = trace_runs * steps
    total_us = sum(v[0] for v in per.values())
    base = dict(base, steps=steps, n_fluid=n_fluid, backend=jax.default_backend(), events_from=where)
    wall_ms = 1e3 * min(walls) / steps
    recs = [dict(base, bench="gpu_profile_total", wall_ms_per_step=round(wall_ms, 4),
                 op_ms_per_step=round(total_us / 1e3 / n, 4), busy_fraction=round(total_us / 1e3 / n / wall_ms, 3),
                 distinct_ops=len(per), launches_per_step=round(sum(v[1] for v in per.values()) / n, 1),
                 fluid_particle_steps_per_s=round(n_fluid / (wall_ms / 1e3), 1))]

    def source(name):  # a GPU kernel is named after its instruction with '_' for the last '.'
        hit = sources.get(name) or sources.get(re.sub(r"_(\d+)$", r".\1", name))
        return hit or ("", "?")

    lines = collections.defaultdict(float)
    for name, (us, _) in per.items():
        lines[source(name)[1]] += us
    for name, (us, cnt) in sorted(per.items(), key=lambda kv: -kv[1][0])[:top]:
        op, src = source(name)
        recs.append(dict(base, bench="gpu_profile_op", op=name, op_name=op[-160:], source=src,
                         ms_per_step=round(us / 1e3 / n, 4), share=round(us / max(total_us, 1e-9), 4),
                         launches_per_step=round(cnt / n, 2)))
    for src, us in sorted(lines.items(), key=lambda kv: -kv[1])[:top]:
        recs.append(dict(base, bench="gpu_profile_line", source=src, ms_per_step=round(us / 1e3 / n, 4),
                         share=round(us / max(total_us, 1e-9), 4)))
    return recs


def profile(size: str, scheme: str, *, runs: int, trace_runs: int, top: int, blocks: int,
            wall_sums: str | None = None, hlo_out: str | None = None) -> list[dict]:
    """``summarize`` one compiled chunk of the peers' dam break of ``size`` (``compiled_chunk``)."""
    from rockjax.tuning import WallSums

    c = compiled_chunk(size, scheme, blocks=blocks, tuning={"wall_sums": WallSums(wall_sums)} if wall_sums else None)
    cfg, state = c["config"], c["state"]
    base = {"size": size, "scheme": scheme, "n_wall": c["counts"]["wall"], "rebuild_period": c["period"],
            "K": cfg.neighbour_capacity, "dtype": str(state.particles.x.dtype),
            "wall_sums": cfg.tuning.wall_sums_form().value}
    return summarize(c["chunk"], (state, c["params"]), steps=c["steps"], n_fluid=c["counts"]["fluid"], base=base,
                     runs=runs, trace_runs=trace_runs, top=top, hlo_out=hlo_out)


def profile_grad(dx: float, *, steps: int | None, runs: int, trace_runs: int, top: int,
                 hlo_out: str | None = None, adjoint: str | None = None) -> list[dict]:
    """``summarize`` the forward and the checkpointed ``value_and_grad`` of ``bench_grad``'s dam
    scene at ``dx`` over ``steps`` steps (default two list periods): where the gradient's extra
    time goes (issue 47's target: gradient / forward <= 4.5)."""
    import jax

    from bench_grad import build, objective
    from rockjax.calibrate import observed
    from rockjax.step import prime

    from rockjax.tuning import Adjoint

    scene = build("dam", dx)
    config, params = scene.config, scene.params
    if adjoint:  # PAIR_SUMS with its reverse pass in one block (the accelerators' forward is one block)
        config = config.tuned(adjoint=Adjoint(adjoint), **({"backward_tile": 0} if adjoint == "pair_sums" else {}))
    n = steps or 2 * config.rebuild_every
    obj = objective(scene)
    state0 = jax.jit(prime, static_argnums=2)(scene.state, params, config)

    def run(p, ck):
        return obj(observed(config, p, n, None, state=state0, checkpoint=ck, prime=False)[0], p)

    base = {"scene": f"dam dx {dx}", "scheme": config.scheme.name, "n_wall": config.n_wall,
            "dtype": str(state0.particles.x.dtype), "adjoint": config.effective_adjoint.value,
            "gather": config.effective_gather.value, "wall_sums": config.tuning.wall_sums_form().value}
    recs = []
    for what, f in (("forward", lambda p: run(p, False)), ("grad_checkpointed", jax.value_and_grad(lambda p: run(p, True)))):
        compiled = jax.jit(f).lower(params).compile()
        hlo = hlo_out.format(size=f"dx{dx}", scheme=f"{what}_{adjoint or 'default'}", wall_sums="default") if hlo_out else None
        recs += summarize(compiled, (params,), steps=n, n_fluid=config.n_fluid, base=dict(base, program=what),
                          runs=runs, trace_runs=trace_runs, top=top, hlo_out=hlo)
    return recs


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", nargs="+", default=["1M"], help="dam-break sizes (compare_peers.NX)")
    ap.add_argument("--scheme", nargs="+", default=["wcsph"], help="fluid schemes")
    ap.add_argument("--runs", type=int, default=3, help="untimed-trace runs of the chunk (best wall time)")
    ap.add_argument("--trace-runs", type=int, default=1, help="traced runs of the chunk")
    ap.add_argument("--blocks", type=int, default=2, help="rebuild periods per chunk")
    ap.add_argument("--top", type=int, default=25, help="largest instructions / source lines kept")
    ap.add_argument("--wall-sums", nargs="+", default=[None], help="Tuning.wall_sums values (scatter, ranges); default: the backend's")
    ap.add_argument("--hlo-out", default=None,
                    help="write the compiled module's text here (gzip; {size} {scheme} {wall_sums} filled in)")
    ap.add_argument("--grad", type=float, default=None, metavar="DX",
                    help="instead: the forward and checkpointed gradient of bench_grad's dam scene at this dx")
    ap.add_argument("--grad-steps", type=int, default=None, help="steps of --grad (default two list periods)")
    ap.add_argument("--grad-adjoint", nargs="+", default=[None],
                    help="Tuning.adjoint values for --grad (autodiff, pair_sums: its reverse in one block)")
    ap.add_argument("--out", default=None, help="append JSON lines here too")
    a = ap.parse_args(argv)
    if a.grad:
        for adj in a.grad_adjoint:
            for r in profile_grad(a.grad, steps=a.grad_steps, runs=a.runs, trace_runs=a.trace_runs, top=a.top,
                                  hlo_out=a.hlo_out, adjoint=adj):
                emit(r, a.out)
        return
    for size in a.size:
        for scheme in a.scheme:
            for ws in a.wall_sums:
                hlo = a.hlo_out.format(size=size, scheme=scheme, wall_sums=ws or "default") if a.hlo_out else None
                for r in profile(size, scheme, runs=a.runs, trace_runs=a.trace_runs, top=a.top, blocks=a.blocks,
                                 wall_sums=ws, hlo_out=hlo):
                    emit(r, a.out)


if __name__ == "__main__":
    main()
