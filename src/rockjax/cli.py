"""Command line: ``rockjax list`` and
``rockjax run SCENE [--t-end T] [--dx DX] [--scheme S] [--coupling C] [--out run.h5] [--dry-run]``."""

from __future__ import annotations

import argparse
import inspect
import json
import sys


def _cmd_list(_args) -> int:
    from .scenes import BUILTIN

    for name, builder in BUILTIN.items():
        doc = (inspect.getdoc(builder) or "").splitlines()[0]
        print(f"{name:20s} {doc}")
    return 0


def _cmd_run(args) -> int:
    from .driver import SimulationError, simulate
    from .scenes import BUILTIN
    from .observables import scene_observer
    from .types import Coupling, Scheme

    if args.scene not in BUILTIN:
        print(f"rockjax: unknown scene {args.scene!r}; `rockjax list` shows the built-in scenes", file=sys.stderr)
        return 2
    builder = BUILTIN[args.scene]
    accepted = inspect.signature(builder).parameters
    kwargs = {}
    for key, value in (("dx", args.dx), ("scheme", args.scheme and Scheme(args.scheme)),
                       ("coupling", args.coupling and Coupling(args.coupling))):
        if value is None:
            continue
        if key not in accepted:
            print(f"rockjax: scene {args.scene!r} has no option --{key}", file=sys.stderr)
            return 2
        kwargs[key] = value
    try:
        scene = builder(**kwargs)
    except ValueError as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 2
    info = describe(scene, args.t_end)
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    if args.dry_run:
        print(json.dumps(info))
        return 0
    try:
        result = simulate(scene, t_end=args.t_end, out=args.out, frame_dt=args.frame_dt,
                          progress=not args.quiet and None, keep_frames=False, observe=scene_observer(scene.meta))
    except (SimulationError, ValueError) as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 1
    summary = {"scene": scene.name, "t_end": float(result.times[-1]), "frames": len(result.times), "out": args.out,
               **{k: round(v, 3) if isinstance(v, float) else v for k, v in result.stats.items()}}
    if result.observed and "runup" in result.observed:
        summary["max_runup_m"] = round(float(max(result.observed["runup"])), 4)
    print(json.dumps(summary))
    return 0


def describe(scene, t_end: float) -> dict:
    """What a run of ``scene`` to ``t_end`` involves: counts, dt, steps, stages, memory estimate."""
    c = scene.config
    counts = scene.counts() if scene.state.particles is not None else {"fluid": 0, "wall": 0, "pad": 0}
    n_blocks = c.blocks.n_blocks if c.blocks is not None else 0
    # per particle: ~20 float fields + the [K] neighbour row (int32) for the fluid rows; x4 for temporaries
    bytes_est = 4 * (counts["fluid"] + counts["wall"]) * 24 + 4 * c.n_fluid * c.neighbour_capacity
    return {"scene": scene.name, "fluid": counts["fluid"], "wall": counts["wall"], "blocks": n_blocks,
            "dt_s": float(f"{c.dt:.4g}"), "steps": int(round(t_end / c.dt)),
            "stages": ",".join(s for s, on in (("sph-" + c.scheme.value, c.n_fluid > 0), ("blocks", n_blocks > 0),
                                             ("coupling-" + c.coupling.value, c.coupling.value != "none")) if on),
            "memory_MB_est": round(4 * bytes_est / 2**20, 1)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="rockjax", description="Differentiable SPH + 3D-DDA rock-slide simulator")
    sub = parser.add_subparsers(dest="cmd", required=True)
    p_list = sub.add_parser("list", help="list the built-in scenes")
    p_list.set_defaults(func=_cmd_list)
    p_run = sub.add_parser("run", help="run a built-in scene")
    p_run.add_argument("scene", help="built-in scene name (see `rockjax list`)")
    p_run.add_argument("--t-end", type=float, default=1.0, help="end time in seconds (default 1.0)")
    p_run.add_argument("--dx", type=float, default=None, help="particle spacing in metres (scene default if omitted)")
    p_run.add_argument("--scheme", choices=["wcsph", "seed"], default=None, help="SPH scheme (default wcsph)")
    p_run.add_argument("--out", default=None, help="HDF5 output file")
    p_run.add_argument("--frame-dt", type=float, default=None, help="output interval in seconds")
    p_run.add_argument("--coupling", choices=["penalty", "boundary_particles"], default=None,
                       help="fluid-block coupling (scenes with blocks)")
    p_run.add_argument("--dry-run", action="store_true",
                       help="print counts, dt, steps, stages and a memory estimate without running")
    p_run.add_argument("--quiet", action="store_true", help="no progress bar")
    p_run.set_defaults(func=_cmd_run)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
