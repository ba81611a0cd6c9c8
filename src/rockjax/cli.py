"""Command line: ``rockjax list`` and ``rockjax run SCENE [--t-end T] [--dx DX] [--out run.h5]``."""

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
    from .types import Scheme

    if args.scene not in BUILTIN:
        print(f"rockjax: unknown scene {args.scene!r}; `rockjax list` shows the built-in scenes", file=sys.stderr)
        return 2
    kwargs = {}
    if args.dx is not None:
        kwargs["dx"] = args.dx
    if args.scheme is not None:
        kwargs["scheme"] = Scheme(args.scheme)
    try:
        scene = BUILTIN[args.scene](**kwargs)
    except ValueError as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 2
    counts = scene.counts()
    print(f"scene {scene.name}: {counts['fluid']} fluid + {counts['wall']} wall particles, dt = {scene.config.dt:.3g} s, "
          f"scheme {scene.config.scheme.value}", file=sys.stderr)
    try:
        result = simulate(scene, t_end=args.t_end, out=args.out, frame_dt=args.frame_dt,
                          progress=not args.quiet and None, keep_frames=False)
    except (SimulationError, ValueError) as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 1
    summary = {"scene": scene.name, "t_end": float(result.times[-1]), "frames": len(result.times), "out": args.out,
               **{k: round(v, 3) if isinstance(v, float) else v for k, v in result.stats.items()}}
    print(json.dumps(summary))
    return 0


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
    p_run.add_argument("--quiet", action="store_true", help="no progress bar")
    p_run.set_defaults(func=_cmd_run)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
