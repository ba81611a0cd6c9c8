"""PNG figures of a finished run (``rockjax plot run.h5``): gauge time series, run-up over time,
block trajectories and the energy budget, read from the HDF5 file that ``simulate(out=...)``
wrote (with ``observe=observables.scene_observer(meta)`` for gauges, run-up and energies).

This module owns the figure files; it draws with matplotlib's object API on the Agg canvas
(no pyplot state, no display needed). matplotlib is an optional dependency (``rockjax[plot]``).
A figure whose data the run does not hold is skipped, with the reason logged (logger
``rockjax.plots``) and printed by ``main``.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np

__all__ = ["plot_run", "plot_run_report", "main"]

log = logging.getLogger("rockjax.plots")

#: figure names, in the order they are drawn
FIGURES = ("gauges", "runup", "blocks", "energy")


def _figure(nrows=1, ncols=1, size=(7.0, 4.0)):
    try:
        from matplotlib.figure import Figure
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("rockjax plots need matplotlib: pip install 'rockjax[plot]'") from e
    fig = Figure(figsize=size, dpi=100, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def _gauges(run, path: Path):
    obs = run.observed or {}
    if "gauges" not in obs:
        return "no /observed/gauges (the scene has no gauges, or the run had no observer)"
    g = np.asarray(obs["gauges"])  # [F, M]
    names = (run.meta.get("gauges") or {}).get("names") or [f"gauge {i}" for i in range(g.shape[1])]
    xy = (run.meta.get("gauges") or {}).get("xy")
    fig, ax = _figure()
    ax = ax[0, 0]
    for i in range(g.shape[1]):
        label = str(names[i]) if i < len(names) else f"gauge {i}"
        if xy is not None and i < len(xy):
            label += f" (x = {xy[i][0]:.3g} m)"
        ax.plot(run.time, g[:, i], label=label)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("free-surface elevation above still water [m]")
    ax.set_title(f"{run.scene}: wave gauges")
    ax.legend(loc="best", fontsize="small")
    fig.savefig(path)


def _runup(run, path: Path):
    obs = run.observed or {}
    if "runup" not in obs and "smooth_runup" not in obs:
        return "no /observed/runup or /observed/smooth_runup (the scene has no run-up slope, or no observer)"
    fig, ax = _figure()
    ax = ax[0, 0]
    if "runup" in obs:
        ax.plot(run.time, obs["runup"], label="run-up (highest particle on the slope)")
    if "smooth_runup" in obs:
        ax.plot(run.time, obs["smooth_runup"], "--", label="smooth run-up (log-sum-exp)")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("run-up above still water [m]")
    ax.set_title(f"{run.scene}: run-up")
    ax.legend(loc="best", fontsize="small")
    fig.savefig(path)


def _moving_blocks(run, bx: np.ndarray) -> list[int]:
    motion = ((run.config or {}).get("blocks") or {}).get("motion")
    if motion is not None and len(motion) == bx.shape[1]:
        return [b for b, m in enumerate(motion) if m != "fixed"]
    return [b for b in range(bx.shape[1]) if np.ptp(bx[:, b], axis=0).max() > 0]


def _blocks(run, path: Path):
    bx = run.frames.get("block_x")
    if bx is None:
        return "no /block_x (the run has no blocks)"
    moving = _moving_blocks(run, bx)
    if not moving:
        return "no moving block (all blocks are fixed)"
    fig, ax = _figure(1, 2, size=(11.0, 4.0))
    for b in moving:
        line, = ax[0, 0].plot(run.time, bx[:, b, 0], label=f"block {b}: x")
        ax[0, 0].plot(run.time, bx[:, b, 2], "--", color=line.get_color(), label=f"block {b}: z")
        ax[0, 1].plot(bx[:, b, 0], bx[:, b, 2], "-", color=line.get_color(), label=f"block {b}")
        ax[0, 1].plot(bx[0, b, 0], bx[0, b, 2], "o", color=line.get_color())
        ax[0, 1].plot(bx[-1, b, 0], bx[-1, b, 2], "s", color=line.get_color())
    ax[0, 0].set_xlabel("time t [s]")
    ax[0, 0].set_ylabel("centroid coordinate [m]")
    ax[0, 0].set_title("centroid x (solid) and z (dashed)")
    ax[0, 0].legend(loc="best", fontsize="small")
    ax[0, 1].set_xlabel("x [m]")
    ax[0, 1].set_ylabel("z [m]")
    ax[0, 1].set_title("centroid path (o start, square end)")
    ax[0, 1].set_aspect("equal", adjustable="datalim")
    fig.suptitle(f"{run.scene}: block trajectories")
    fig.savefig(path)


_ENERGY_TERMS = (("fluid_kinetic", "fluid kinetic"), ("fluid_potential", "fluid potential"),
                 ("fluid_elastic", "fluid elastic (compression)"), ("block_kinetic", "block kinetic"),
                 ("block_potential", "block potential"))


def _energy(run, path: Path):
    obs = run.observed or {}
    terms = [(k, label) for k, label in _ENERGY_TERMS if k in obs]
    if not terms:
        return "no energy records (/observed/fluid_* or /observed/block_*; run with observe=scene_observer(meta))"
    E = {k: np.asarray(obs[k], np.float64) for k, _ in terms}
    total = sum(E.values())
    fig, ax = _figure(size=(8.0, 4.5))
    ax = ax[0, 0]
    # potential energies depend on the datum: show every term as its change since the first frame
    for k, label in terms:
        ax.plot(run.time, E[k] - E[k][0], label=label)
    ax.plot(run.time, total - total[0], color="k", lw=2, label="total")
    ax.plot(run.time, total[0] - total, color="k", lw=1.5, ls=":", label="dissipated = initial total - total")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("change since t = 0 [J]")
    ax.set_title(f"{run.scene}: energy budget (initial total {total[0]:.4g} J)")
    ax.legend(loc="best", fontsize="small")
    fig.savefig(path)


_DRAW = {"gauges": _gauges, "runup": _runup, "blocks": _blocks, "energy": _energy}


def plot_run_report(h5_path, out_dir=None) -> tuple[list[Path], dict[str, str]]:
    """Like ``plot_run``, also returning ``{figure name: why it was skipped}``."""
    from .io.hdf5 import read

    h5_path = Path(h5_path)
    if not h5_path.is_file():
        raise ValueError(f"plot: run file {str(h5_path)!r} does not exist; pass the HDF5 file of `rockjax run --out`")
    out_dir = h5_path.parent if out_dir is None else Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    try:
        run = read(str(h5_path))
    except KeyError as e:
        raise ValueError(f"plot: {str(h5_path)!r} is not a rockjax run file (missing {e}); pass the HDF5 file of "
                         "`rockjax run --out`") from e
    if len(run.time) == 0:
        raise ValueError(f"plot: {str(h5_path)!r} holds no frames")
    written, skipped = [], {}
    for name in FIGURES:
        path = out_dir / f"{h5_path.stem}_{name}.png"
        why = _DRAW[name](run, path)
        if why is None:
            written.append(path)
        else:
            skipped[name] = why
            log.info("plot %s skipped: %s", name, why)
    return written, skipped


def plot_run(h5_path, out_dir=None) -> list[Path]:
    """Write the PNG figures of a run.

    Args:
        h5_path: HDF5 file written by ``simulate(out=...)``.
        out_dir: folder for the figures (created; default the run file's folder). Files are named
            ``<run stem>_{gauges,runup,blocks,energy}.png``.

    Returns:
        The PNG files written. A figure whose data is absent (a scene without gauges, a run
        without blocks or without an observer) is skipped and the reason logged
        (``plot_run_report`` returns the reasons).

    Raises:
        ValueError: the file does not exist or holds no frames.
    """
    return plot_run_report(h5_path, out_dir)[0]


def main(args) -> int:
    """``rockjax plot RUN [--out-dir DIR]``: ``args.run`` the HDF5 file, ``args.out_dir`` or None.

    Prints one line per figure (written path, or ``skipped NAME: reason``) and returns 0, or 2
    when the file cannot be read.
    """
    try:
        written, skipped = plot_run_report(args.run, getattr(args, "out_dir", None))
    except (ValueError, OSError) as e:
        print(f"rockjax: {e}", file=sys.stderr)
        return 2
    for p in written:
        print(p)
    for name, why in skipped.items():
        print(f"skipped {name}: {why}", file=sys.stderr)
    return 0
