"""Command line: ``rockjax list``, ``rockjax plot RUN.h5 [--out-dir D]`` and ``rockjax run NAME_OR_FILE [--t-end T] [--dx DX] [--scheme S]
[--coupling C] [--out run.h5] [--frame-dt DT] [--checkpoint-every N] [--resume run.h5] [--dry-run] [--devices N]
[--quiet]``.

``run`` takes a built-in scene name (``rockjax list``) or a TOML scene file (a path ending in
``.toml`` or any existing file; see ``rockjax.scenes.scenefile``). Flags given on the command line
override the file's values. ``--dry-run`` prints one JSON line (counts, dt, steps, stages, memory
estimate) without running; for a field-scale built-in scene (``fjord``) it prints an estimate without
building it: counts, memory per device over ``--devices N`` slabs and hours at measured throughputs. ``--resume run.h5`` continues an interrupted run (same scene and
flags) from the file's newest checkpoint, appending frames to it. Exit status: 0 done, 1 the run
failed (or writing its file failed), 2 bad input (refused before anything is compiled, also with
``--dry-run``: one line on stderr naming the field or flag), 130 / 143 interrupted (Ctrl-C /
SIGTERM: with an output file the run stops at the next frame and writes a checkpoint first).

The parser is built by :func:`build_parser`, one ``_add_<command>`` function per subcommand;
a new subcommand is one more such function registered there.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import sys

from .sph.terms import names

_EPILOG = """examples:
  rockjax list                                   the built-in scenes
  rockjax run dam_break --dx 0.05 --t-end 0.5    a built-in scene at a coarse resolution
  rockjax run examples/box_off_ramp.toml --dry-run
  rockjax run fjord --dry-run --devices 16 --t-end 60   field scale: counts, memory / device, hours
  rockjax run examples/box_off_ramp.toml --out run.h5
  rockjax run examples/box_off_ramp.toml --resume run.h5   continue it after Ctrl-C or a kill
  rockjax plot run.h5                            PNGs: gauges, run-up, block paths, energy
scene files: examples/*.toml (every built-in scene, and general scenes); format in
rockjax/scenes/scenefile.py. Units are SI (m, s, kg/m^3)."""


def _cmd_list(_args) -> int:
    from .scenes import BUILTIN

    for name, builder in BUILTIN.items():
        doc = (inspect.getdoc(builder) or "").splitlines()[0]
        print(f"{name:20s} {doc}")
    return 0


def is_scene_file(target: str) -> bool:
    """Whether ``rockjax run TARGET`` means a scene file: a path ending in .toml, or an existing file."""
    return target.lower().endswith(".toml") or os.path.isfile(target)


def _load(args):
    """(scene, t_end, frame_dt, out) from a name or a scene file, command-line flags first."""
    from .scenes import BUILTIN
    from .scenes.scenefile import load, load_builtin

    overrides = dict(dx=args.dx, scheme=args.scheme, coupling=args.coupling)
    if is_scene_file(args.scene):
        sf = load(args.scene, **overrides)
        run = sf.run
        pick = (lambda flag, file, default: flag if flag is not None else (file if file is not None else default))
        return sf.scene, pick(args.t_end, run.t_end, 1.0), pick(args.frame_dt, run.frame_dt, None), \
            pick(args.out, run.out, None)
    if args.scene not in BUILTIN:
        raise LookupError(f"unknown scene {args.scene!r}; `rockjax list` shows the built-in scenes, "
                          "or give a scene file (a path ending in .toml)")
    scene = load_builtin(args.scene, **overrides)
    return scene, (args.t_end if args.t_end is not None else 1.0), args.frame_dt, args.out


def _refuse(exc) -> int:
    """Print ``rockjax: <message>`` as one line on stderr; exit status 2 (bad input)."""
    print("rockjax: " + " ".join(str(exc).split()), file=sys.stderr)
    return 2


def _check_flags(args) -> None:
    """Refuse flags no run can use (ValueError naming the flag), before a scene is built."""
    if args.rebuild_period is not None and args.rebuild_period < 1:
        raise ValueError(f"--rebuild-period must be a positive number of steps (got {args.rebuild_period})")
    if args.devices < 1:
        raise ValueError(f"--devices must be a positive number of devices (got {args.devices})")
    if args.checkpoint_every is not None and args.checkpoint_every < 1:
        raise ValueError(f"--checkpoint-every must be a positive number of frames (got {args.checkpoint_every})")
    if args.resume is not None and args.settle:
        raise ValueError("--settle cannot be combined with --resume (the checkpoint holds the settled state)")
    if not (args.settle >= 0 and math.isfinite(args.settle)):
        raise ValueError(f"--settle must be a finite time >= 0 in seconds (got {args.settle})")
    for flag, value in (("--t-end", args.t_end), ("--dx", args.dx), ("--frame-dt", args.frame_dt)):
        if value is not None and not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{flag} must be a positive finite number in SI units (got {value})")


def _estimate(args) -> dict | None:
    """A field-scale built-in scene's cost without building it (``scenes.ESTIMATES``), for
    ``--dry-run``; None for the others (they are built and described)."""
    from .scenes import ESTIMATES

    if not args.dry_run or is_scene_file(args.scene) or args.scene not in ESTIMATES:
        return None
    options = {k: v for k, v in (("dx", args.dx), ("scheme", args.scheme)) if v is not None}
    t_end = args.t_end if args.t_end is not None else 1.0
    return ESTIMATES[args.scene](n_devices=args.devices, t_end=t_end, **options)


def _cmd_run(args) -> int:
    from .driver import Interrupted, SimulationError, check_out, check_resume, check_times, simulate
    from .observables import scene_observer

    try:
        _check_flags(args)
        estimate = _estimate(args)
        if estimate is not None:
            print(json.dumps(estimate))
            return 0
        if args.devices != 1 and not args.dry_run:
            raise ValueError(f"--devices {args.devices}: the command line runs on one device; run a scene over "
                             "several with rockjax.decomposition.run_sharded (Python), or give --dry-run for "
                             "the estimate")
        scene, t_end, frame_dt, out = _load(args)
        if args.resume is not None:
            if out is not None and os.path.abspath(out) != os.path.abspath(args.resume):
                raise ValueError(f"--out {out} differs from --resume {args.resume}: a resumed run appends to its "
                                 f"own file (leave --out unset)")
            check_resume(args.resume)
            out = None
        check_times(t_end, frame_dt, names=("t_end (--t-end)", "frame_dt (--frame-dt)"))
        check_out(out)
    except (LookupError, ValueError, OSError) as e:
        return _refuse(e)
    info = describe(scene, t_end)
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    if args.dry_run:
        print(json.dumps(dict(info, t_end_s=t_end, frame_dt_s=frame_dt, out=out)))
        return 0
    if args.settle:
        from .scenes import settle

        try:
            scene = settle(scene, t_settle=args.settle, progress=not args.quiet and None)
        except ValueError as e:
            return _refuse(e)
    every = args.checkpoint_every if args.checkpoint_every is not None else (10 if out or args.resume else None)
    try:
        result = simulate(scene, t_end=t_end, out=out, frame_dt=frame_dt, rebuild_period=args.rebuild_period,
                          progress=not args.quiet and None, keep_frames=False, observe=scene_observer(scene.meta),
                          checkpoint_every=every, resume=args.resume)
    except ValueError as e:  # refused before the run started (simulate checks its inputs first)
        return _refuse(e)
    except (SimulationError, OSError) as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 1
    except Interrupted as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 128 + e.signum
    except KeyboardInterrupt:
        print("rockjax: interrupted (no output file, nothing saved)", file=sys.stderr)
        return 130
    out = out or args.resume
    summary = {"scene": scene.name, "t_end": float(result.times[-1]), "frames": len(result.times), "out": out,
               **{k: round(v, 3) if isinstance(v, float) else v for k, v in result.stats.items()}}
    if result.observed and "runup" in result.observed:
        summary["max_runup_m"] = round(float(max(result.observed["runup"])), 4)
    print(json.dumps(summary))
    return 0


def describe(scene, t_end: float) -> dict:
    """What a run of ``scene`` to ``t_end`` involves: counts, dt, steps, stages, memory estimate;
    for a scene with a cut rock mass its block count and size distribution."""
    c = scene.config
    counts = scene.counts() if scene.state.particles is not None else {"fluid": 0, "wall": 0, "pad": 0}
    n_blocks = c.blocks.n_blocks if c.blocks is not None else 0
    # per particle: ~20 float fields + the [K] neighbour row (int32) for the fluid rows; x4 for temporaries
    bytes_est = 4 * (counts["fluid"] + counts["wall"]) * 24 + 4 * c.n_fluid * c.neighbour_capacity
    return {"scene": scene.name, "fluid": counts["fluid"], "wall": counts["wall"], "blocks": n_blocks,
            "dt_s": float(f"{c.dt:.4g}"), "steps": int(round(t_end / c.dt)),
            "stages": ",".join(s for s, on in (("sph-" + c.scheme.name, c.n_fluid > 0), ("blocks", n_blocks > 0),
                                             ("joint-water", n_blocks > 0 and c.blocks.joint_water),
                                             ("coupling-" + c.coupling_method.name, c.coupling_method.name != "none")) if on),
            "memory_MB_est": round(4 * bytes_est / 2**20, 1), **_rock_mass(scene.meta)}


def _rock_mass(meta) -> dict:
    """A cut rock mass's block count and sizes (equivalent diameters, m), for ``describe``."""
    sizes = meta.get("rock_mass") if meta is not None else None
    if not sizes:
        return {}
    return {"rock_blocks": sizes["blocks"], "rock_d10_d50_d90_m": "/".join(
        f"{sizes[k]:.3g}" for k in ("d10_m", "d50_m", "d90_m")), "rock_dropped_slivers": sizes["dropped"]}


def _add_list(sub) -> None:
    p = sub.add_parser("list", help="list the built-in scenes", description="List the built-in scenes.")
    p.set_defaults(func=_cmd_list)


def _add_run(sub) -> None:
    p = sub.add_parser("run", help="run a built-in scene or a TOML scene file",
                       description="Run a built-in scene (`rockjax list`) or a TOML scene file; flags override "
                                   "the file's values.", epilog=_EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", metavar="NAME_OR_FILE",
                   help="built-in scene name (see `rockjax list`) or a scene file (*.toml)")
    p.add_argument("--t-end", type=float, default=None,
                   help="end time in seconds (default: the file's [run] t_end, else 1.0)")
    p.add_argument("--dx", type=float, default=None,
                   help="particle spacing in metres (default: the scene's or the file's)")
    p.add_argument("--scheme", choices=names("scheme"), default=None, help="SPH scheme (default wcsph)")
    p.add_argument("--out", default=None, help="HDF5 output file (default: the file's [output] out, else none)")
    p.add_argument("--frame-dt", type=float, default=None, help="output interval in seconds")
    p.add_argument("--checkpoint-every", type=int, default=None, metavar="N",
                   help="with --out: write a checkpoint (the full state) every N frames, keeping the newest "
                        "(default 10; one is also written at the end and on Ctrl-C)")
    p.add_argument("--resume", default=None, metavar="RUN.h5",
                   help="continue the run in RUN.h5 (killed, interrupted or finished) from its newest checkpoint "
                        "to --t-end, appending frames; give the same scene and flags as the first run")
    p.add_argument("--coupling", choices=["penalty", "boundary_particles", "boundary_integral"], default=None,
                   help="fluid-block coupling (scenes with blocks)")
    p.add_argument("--dry-run", action="store_true",
                   help="print counts, dt, steps, stages and a memory estimate (JSON) without running")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--devices", type=int, default=1, metavar="N",
                   help="with --dry-run on a field-scale scene (fjord): its cost over N devices (slabs along x), "
                        "estimated without building it")
    p.add_argument("--rebuild-period", type=int, default=None,
                   help="rebuild the neighbour list at least every this many steps (default 32; it is also "
                        "rebuilt whenever a particle would move more than half the skin)")
    p.add_argument("--settle", type=float, default=0.0, metavar="SECONDS",
                   help="first relax the water this long with the blocks held and strong artificial viscosity, "
                        "then run from it at t = 0 (scenes.settle; not for scenes with DYNAMIC blocks)")
    p.set_defaults(func=_cmd_run)


def _cmd_plot(args) -> int:
    from .plots import main as plot_main

    return plot_main(args)


def _add_plot(sub) -> None:
    p = sub.add_parser("plot", help="write PNG figures of a run (gauges, run-up, block trajectories, energy)",
                       description="Write PNG figures of a run written by `rockjax run --out run.h5`: gauge time "
                                   "series, run-up over time, block trajectories, energy budget. A figure whose "
                                   "data the run lacks is skipped (reason on stderr).")
    p.add_argument("run", metavar="RUN.h5", help="HDF5 file written by `rockjax run --out`")
    p.add_argument("--out-dir", default=None, help="folder for the PNGs (default: the run file's folder)")
    p.set_defaults(func=_cmd_plot)


def build_parser() -> argparse.ArgumentParser:
    """The ``rockjax`` argument parser: one ``_add_<command>(sub)`` per subcommand."""
    parser = argparse.ArgumentParser(prog="rockjax", description="Differentiable SPH + 3D-DDA rock-slide simulator",
                                     epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    _add_list(sub)
    _add_run(sub)
    _add_plot(sub)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
