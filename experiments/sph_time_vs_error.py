"""Accuracy against wall time: the 2D Martin & Moyce (1952) dam break (n^2 = 2 column, run as a
periodic slab of the 3D code, ``rockjax.validation.dam_break_2d``) at several resolutions.

For each (scheme, a/dx) it runs ``rockjax.simulate`` to T = t sqrt(2 g / a) = 3.05 and prints one
JSON line: surge-front RMS relative error of Z(T) at the 13 reference times 0 < T <= 3
(``validation.front_error``; reference data/validation/martin_moyce_1952_surge_front_n2_2.csv,
Table 2), unshifted and after the best time shift in [0, 0.4] (gate release), the wall time of
the run with everything compiled (``wall_s``: the best of two runs after a first one, whose
time with compiles is ``wall_s_with_compile``), steps, CPU utilisation and the load average (other agents share the 2 cores: compare within one
run). With ``--out`` the records go to a JSONL file and a PNG plots error
against wall time, with the peer codes' figures from ``experiments/results/peers_*.jsonl`` (same
metric, measured on the same machine; ``peers_SOURCE.md``).

Usage: ``python experiments/sph_time_vs_error.py [--res 8 10 14 20] [--schemes wcsph]
[--out experiments/results/sph_time_vs_error]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import resource
import time

import numpy as np

A = 0.1  # column width a [m]
WARM_RUNS = 2  # timed runs after the compiling one; the best is kept


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run(scheme: str, res: int, *, kernel: str | None = None, h_factor: float | None = None,
        cfl: float | None = None, viscosity: str | None = None) -> dict:
    import rockjax as rj
    from rockjax.validation import dam_break_2d, front_error, front_history, martin_moyce_n2_2

    kw = {k: v for k, v in (("h_factor", h_factor), ("cfl", cfl)) if v is not None}
    scene = dam_break_2d(a=A, resolution=res, scheme=rj.sph.from_names(scheme, kernel=kernel, viscosity=viscosity), **kw)
    t_end = 3.05 / math.sqrt(2 * 9.81 / A)
    load0 = os.getloadavg()[0]
    w0 = time.perf_counter()
    rj.simulate(scene, t_end=t_end, frame_dt=t_end / 120, progress=False)  # cold: includes compiles
    wall_cold = time.perf_counter() - w0
    wall = cpu = math.inf
    for _ in range(WARM_RUNS):  # warm: compiled; best of WARM_RUNS (the machine is shared)
        c0, w0 = _cpu(), time.perf_counter()
        result = rj.simulate(scene, t_end=t_end, frame_dt=t_end / 120, progress=False)
        w = time.perf_counter() - w0
        if w < wall:
            wall, cpu = w, _cpu() - c0
    T, Z = front_history(result, a=A)
    Tr, Zr = martin_moyce_n2_2()
    shifts = np.arange(0, 0.41, 0.02)
    errs = [front_error(T, Z, Tr, Zr, shift=s) for s in shifts]
    k = int(np.argmin(errs))
    cfg = result.scene.config
    h_dx = round(float(scene.params.fluid.h) * res / A, 3)
    return {"case": "dambreak2d_mm_n2_2", "code": "rockjax", "scheme": scheme,
            "label": _label(scheme, cfg.scheme.kernel.name, h_dx, cfl, cfg.scheme.viscosity.name,
                            getattr(cfg.scheme, "wall_pressure", None)),
            "kernel": cfg.scheme.kernel.name, "h_dx": h_dx, "viscosity": cfg.scheme.viscosity.name,
            "wall_pressure": getattr(cfg.scheme, "wall_pressure", None),
            "dt": cfg.dt, "a_over_dx": res, "dx": A / res,
            "n_fluid": scene.counts()["fluid"], "n_wall": scene.counts()["wall"], "steps": result.stats["steps"],
            "regrows": result.stats["regrows"], "wall_s": round(wall, 2), "wall_s_with_compile": round(wall_cold, 2),
            "fluid_particle_steps_per_s": round(scene.counts()["fluid"] * result.stats["steps"] / wall),
            "cpu_util": round(cpu / wall, 2),
            "front_rms_rel_err": round(errs[0], 4), "front_rms_rel_err_best_shift": round(errs[k], 4),
            "best_shift_T": round(float(shifts[k]), 2), "Z_sim_at_ref": np.round(np.interp(Tr, T, Z), 3).tolist(),
            "K": cfg.neighbour_capacity, "rebuild_every": cfg.rebuild_every, "skin_dx": round(cfg.skin * res / A, 3),
            "load_before": round(load0, 2), "load_after": round(os.getloadavg()[0], 2)}


def _label(scheme: str, kernel: str, h_dx: float, cfl, viscosity: str, walls: str | None = None) -> str:
    """The plot's name of a rockjax setting: the scheme, its kernel and h / dx, its viscous term,
    and a CFL number given on the command line."""
    return (f"{scheme} ({kernel}, h/dx {h_dx:g}, {viscosity}" + (f", {walls} walls" if walls else "")
            + (f", cfl {cfl:g})" if cfl is not None else ")"))


def _peers(results: pathlib.Path) -> list[dict]:
    """The peers' 2D dam-break records in ``results/peers_*.jsonl`` (the campaign copied next to
    rockjax's results, measured on the same machine; ``peers_SOURCE.md`` says where from)."""
    out = []
    for f in sorted(results.glob("peers_*.jsonl")):
        for line in f.read_text().splitlines():
            try:
                d = json.loads(line)
            except json.JSONDecodeError:
                continue
            if d.get("case") == "dambreak2d" and "front_rms_rel_err" in d and "wall_s" in d:
                out.append(d)
    return out


def plot(records: list[dict], png: pathlib.Path, peer_dir: pathlib.Path | None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharex=True)
    keys = [("front_rms_rel_err", "unshifted"), ("front_rms_rel_err_best_shift", "best time shift")]
    peers = _peers(peer_dir) if peer_dir is not None else []
    for ax, (key, title) in zip(axes, keys):
        for label in sorted({r.get("label", r["scheme"]) for r in records}):
            rs = sorted((r for r in records if r.get("label", r["scheme"]) == label), key=lambda r: r["wall_s"])
            ax.plot([r["wall_s"] for r in rs], [r[key] for r in rs], "o-", label=f"rockjax {label}")
            for r in rs:
                ax.annotate(f"a/dx={r['a_over_dx']}", (r["wall_s"], r[key]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        for code in sorted({(p["code"], p["scheme"]) for p in peers}):
            ps = sorted((p for p in peers if (p["code"], p["scheme"]) == code), key=lambda p: p["wall_s"])
            ax.plot([p["wall_s"] for p in ps], [p[key] for p in ps], "x--", alpha=0.6, label=f"{code[0]} {code[1]}")
        ax.set_xscale("log")
        ax.set_xlabel("wall time [s] (2 cores; rockjax: compiled, peers: run only)")
        ax.set_ylabel("surge front RMS relative error")
        ax.set_title(f"Martin & Moyce n^2=2, T <= 3, {title}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, nargs="+", default=[8, 10, 14, 20], help="a / dx values")
    ap.add_argument("--schemes", nargs="+", default=["wcsph"])
    ap.add_argument("--out", default=None, help="path stem for .jsonl and .png (e.g. experiments/results/sph_time_vs_error)")
    ap.add_argument("--kernel", default=None, help="the schemes' kernel (their default if omitted)")
    ap.add_argument("--h-factor", type=float, default=None, help="h / dx (the scene's default if omitted)")
    ap.add_argument("--cfl", type=float, default=None, help="the scene's CFL number (its default if omitted)")
    ap.add_argument("--viscosity", default=None, help="the schemes' viscous term (their default if omitted)")
    ap.add_argument("--plot-only", action="store_true", help="re-plot the records in OUT.jsonl")
    args = ap.parse_args(argv)
    peer_dir = pathlib.Path(__file__).resolve().parent / "results"
    records = []
    if args.out and args.plot_only:
        records = [json.loads(ln) for ln in pathlib.Path(args.out + ".jsonl").read_text().splitlines() if ln]
    else:
        for res in args.res:
            for scheme in args.schemes:
                rec = run(scheme, res, kernel=args.kernel, h_factor=args.h_factor, cfl=args.cfl, viscosity=args.viscosity)
                print(json.dumps(rec), flush=True)
                records.append(rec)
                if args.out:
                    p = pathlib.Path(args.out + ".jsonl")
                    p.parent.mkdir(parents=True, exist_ok=True)
                    with p.open("a") as fh:
                        fh.write(json.dumps(rec) + "\n")
    if args.out and records:
        plot(records, pathlib.Path(args.out + ".png"), peer_dir)


if __name__ == "__main__":
    main()
