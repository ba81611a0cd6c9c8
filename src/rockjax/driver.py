"""The host driver: ``simulate(scene, t_end=...)`` runs jitted chunks, checks status bits after
each, regrows buffers and reruns a chunk on overflow, raises on fatal problems with the step and
the cause, writes frames (HDF5 or memory) and shows progress. Inputs no run can use (times, the
output path, params) are refused with a ValueError before anything is compiled.

A chunk is the steps between two output frames: ``lax.scan`` of ``rollout.scheduled_step``, which
rebuilds the neighbour list when a particle would move more than ``skin / 2`` (the displacement
trigger) and at least every ``rebuild_period`` steps (default ``max(Config.rebuild_every, 32)``:
with the trigger a list is never used stale, so the forced re-sort can be rarer than the fixed
schedule a vmapped or differentiated rollout needs). Frames are a whole number of steps apart,
independent of the rebuild period. A period of 32 is faster than 8 (fewer re-sorts; RESULTS.md
"Host driver: forced list-rebuild period").
"""

from __future__ import annotations

import dataclasses
import functools
import math
import signal
import sys
import threading
import time
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from .rollout import scheduled_step
from .scenes.base import Scene, check_params, empty_neighbours
from .step import prime, refresh
from .types import Config, Kind, State, Status

__all__ = ["simulate", "Result", "SimulationError", "Interrupted", "host_frame", "resize", "check_block_dt",
           "check_times", "check_out", "check_resume"]


class SimulationError(RuntimeError):
    """A run stopped on a fatal status bit; ``step``, ``status`` and ``fields`` say where and why.

    ``step`` is the first step that set a fatal bit (each chunk carries the index of its first
    such step through its scan); ``status`` holds the bits OR-ed over the chunk; ``fields`` the
    state fields (``"particles.v"``, ``"blocks.x"``, ...) that held a NaN or Inf after that step.
    """

    def __init__(self, message: str, *, step: int, status: int, fields: tuple = ()):
        super().__init__(message)
        self.step = step
        self.status = status
        self.fields = tuple(fields)


def check_times(t_end, frame_dt=None, *, names=("t_end", "frame_dt")) -> None:
    """Refuse a run's times (host, before anything is compiled): ``t_end`` [s] must be positive
    and finite, ``frame_dt`` [s] (None: the default) positive, finite and at most ``t_end`` (a run
    ends on the first whole frame at or after ``t_end``, so a longer frame would run past it).
    ``names``: how the ValueError names the two (the CLI gives its flags)."""
    def number(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return math.nan

    t = number(t_end)
    if not (t > 0 and math.isfinite(t)):
        raise ValueError(f"{names[0]} must be a positive finite time in seconds (got {t_end!r})")
    if frame_dt is None:
        return
    f = number(frame_dt)
    if not (f > 0 and math.isfinite(f)):
        raise ValueError(f"{names[1]} must be a positive finite time in seconds (got {frame_dt!r})")
    if f > t * (1 + 1e-9):
        raise ValueError(f"{names[1]} = {f:g} s exceeds {names[0]} = {t:g} s (the run ends on a whole frame); "
                         f"use {names[1]} <= {names[0]}")


def check_out(out) -> None:
    """Refuse an output path the run could not write (host, before the run starts): its folder
    must exist and be writable, and the path must not be a folder or a read-only file. A
    ValueError naming ``out`` and what to change."""
    import os

    if out is None:
        return
    path = os.fspath(out)
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ValueError(f"out = {path!r} is a folder; give a file path such as {os.path.join(path, 'run.h5')!r}")
    if not os.path.isdir(folder):
        raise ValueError(f"out = {path!r}: the folder {folder!r} does not exist; create it or write elsewhere")
    if not os.access(folder, os.W_OK | os.X_OK) or (os.path.exists(path) and not os.access(path, os.W_OK)):
        raise ValueError(f"out = {path!r} is not writable (permissions); write elsewhere")


@dataclasses.dataclass
class Result:
    """What ``simulate`` returns.

    Attributes:
        scene: the scene actually run (its config may have grown capacities).
        state: the final state.
        times: [F] frame times s.
        frames: dict of stacked host arrays in original particle order (``x`` [F, N, 3], ``v``,
            ``rho``, ``p``, ``kind``), or None when frames went only to a file.
        path: the HDF5 file written, if any.
        stats: wall time, steps, regrows.
        observed: ``observe``'s outputs stacked over frames (dict of [F, ...] arrays), or None.
    """

    scene: Scene
    state: State
    times: np.ndarray
    frames: Optional[dict]
    path: Optional[str]
    stats: dict
    observed: Optional[dict] = None


def host_frame(state: State) -> dict:
    """Host copy of the per-frame fields: particles in original order (undoing the cell sort) as
    ``x``, ``v``, ``rho``, ``p``, ``kind``; blocks as ``block_x``, ``block_q``, ``block_v``,
    ``block_omega``."""
    out = {}
    if state.particles is not None:
        P = jax.device_get(state.particles)
        order = np.argsort(P.pid)
        out.update(x=P.x[order], v=P.v[order], rho=P.rho[order], p=P.p[order], kind=P.kind[order])
    if state.blocks is not None:
        B = jax.device_get(state.blocks)
        out.update(block_x=B.x, block_q=B.q, block_v=B.v, block_omega=B.omega)
    return out


def resize(state: State, config: Config) -> State:
    """The state with its buffers shaped for ``config`` (neighbours rebuilt at next refresh; block
    buffers re-made by ``blocks.resize_pairs`` when the pair capacity grew, the shear history
    shaped by ``blocks.fit_history``)."""
    state = state.replace(status=jnp.zeros((), jnp.int32))
    if state.nbrs is not None:
        state = state.replace(nbrs=empty_neighbours(config, state.particles.x))
    if state.blocks is not None:
        from . import blocks

        b = state.blocks
        if b.history.pairs.shape[0] != config.blocks.pair_capacity:
            _, b = blocks.resize_pairs(config.blocks, b, config.blocks.pair_capacity)
        state = state.replace(blocks=blocks.fit_history(config.blocks, b))
    return state


#: the driver's default forced-rebuild period (steps); the displacement trigger does the rest
DEFAULT_REBUILD_PERIOD = 32


#: the state fields whose NaN / Inf a SimulationError names (bit k of the carried field mask)
_FIELDS = (("particles", "x"), ("particles", "v"), ("particles", "rho"), ("particles", "p"), ("particles", "a"),
           ("blocks", "x"), ("blocks", "v"), ("blocks", "q"), ("blocks", "omega"))


def _non_finite_fields(state: State) -> jax.Array:
    """Bit mask (int32) of the ``_FIELDS`` holding a NaN or Inf (in jit)."""
    mask = jnp.zeros((), jnp.int32)
    for k, (part, name) in enumerate(_FIELDS):
        obj = getattr(state, part)
        if obj is not None:
            mask |= jnp.where(jnp.all(jnp.isfinite(getattr(obj, name))), 0, 1 << k).astype(jnp.int32)
    return mask


def _field_names(mask: int) -> tuple:
    return tuple(f"{part}.{name}" for k, (part, name) in enumerate(_FIELDS) if int(mask) & (1 << k))


@functools.lru_cache(maxsize=32)
def _compiled_chunk(config: Config, n_steps: int, period: int):
    """``n_steps`` of ``rollout.scheduled_step`` in one ``lax.scan``, jitted: ``(state, first,
    fields)`` with ``first`` the step index after which a fatal status bit first showed (-1:
    none) and ``fields`` the mask of ``_FIELDS`` non-finite then (a ``lax.cond`` evaluated only
    at that step). The carried index leaves the state's arithmetic as it was."""
    one = scheduled_step(config, period=period)
    fatal = ~int(Status.growable())

    def run(state, params):
        def body(carry, _):
            s, first, fields = carry
            s = one(s, params)
            new = (first < 0) & ((s.status & fatal) != 0)
            fields = jax.lax.cond(new, _non_finite_fields, lambda _: fields, s)
            return (s, jnp.where(new, s.step, first), fields), None

        none = jnp.asarray(-1, jnp.int32)
        return jax.lax.scan(body, (state, none, jnp.zeros((), jnp.int32)), None, length=n_steps)[0]

    return jax.jit(run)


def _round8(n: float) -> int:
    return int(math.ceil(n / 8.0) * 8)


def _grow(config: Config, period: int, state: State, bits: int) -> tuple[Config, int]:
    """Capacities grown for the overflow bits; the forced-rebuild period halved for a stale list."""
    changes = {}
    b = config.blocks
    grown = {}  # BlockCapacities fields
    if bits & Status.CONTACT_OVERFLOW:
        grown["pairs"] = _round8(2 * b.pair_capacity)
    if bits & Status.JOINT_PATCH_OVERFLOW:
        grown["joint_patch_points"] = 2 * b.joint_patch_points
    if bits & Status.BLOCK_CELL_OVERFLOW:
        grown["cell_blocks"] = 2 * b.grid_cell_capacity
    if bits & Status.CONTACT_POINT_OVERFLOW:
        grown["law_slots"] = min(2 * b.law_slots, b.contact_slots)
    if bits & Status.CROSSING_EDGE_OVERFLOW:
        grown["crossing_edges"] = min(2 * b.crossing_edges, b.max_edges)
    if bits & Status.SUPPORT_EDGE_OVERFLOW:
        grown["support_edges"] = min(2 * b.support_edges, b.max_edges)
    if bits & Status.FCP_CROSS_OVERFLOW:
        grown["fcp_crosses"] = min(2 * b.fcp_crosses, b.support_edges ** 2)
    if grown:
        changes["blocks"] = b.grown(**grown)
    caps = {}  # Capacities fields
    if bits & Status.NEIGHBOUR_OVERFLOW:
        caps["neighbours"] = max(_round8(1.2 * int(state.nbrs.max_count)), config.neighbour_capacity + 8)
    if bits & Status.CELL_OVERFLOW:
        caps["cells"] = max(_round8(1.2 * int(state.nbrs.max_run)), config.cell_capacity + 8)
    if bits & Status.WALL_PAIR_OVERFLOW:
        caps["wall_pairs"] = max(_round8(1.5 * int(state.nbrs.max_wall_count)), config.wall_pair_capacity + 64)
    if bits & Status.BODY_PAIR_OVERFLOW:
        caps["body_pairs"] = max(_round8(1.5 * int(state.nbrs.max_body_count)), config.body_pair_capacity + 64)
    if caps:
        changes["capacities"] = config.capacities.replace(**caps)
    if bits & Status.NEIGHBOUR_STALE:
        if period == 1:
            raise SimulationError("neighbour list stale with a rebuild every step: particles move more than "
                                  "skin/2 per step; the time step is too large for these speeds: rebuild the scene "
                                  "with a smaller cfl= (DFSPH's velocity CFL: its dt scales with it) or a larger "
                                  "skin_factor=", step=int(state.step), status=bits)
        period = max(1, period // 2)
    return config.replace(**changes), period


def _grow_rollout(config: Config, state: State, bits: int) -> Config:
    """``_grow`` for a fixed-schedule rollout (``make_rollout``, as the benchmarks run it), whose
    forced rebuild period is ``config.rebuild_every``: a stale list halves ``rebuild_every``."""
    config, period = _grow(config, config.rebuild_every, state, bits)
    return config.replace(rebuild_every=period)


def _clear(state: State) -> State:
    zero = jnp.zeros((), jnp.int32)
    state = state.replace(status=zero)
    if state.nbrs is not None:
        state = state.replace(nbrs=state.nbrs.replace(max_count=zero, max_run=zero, max_wall_count=zero,
                                                      max_body_count=zero))
    return state


def simulate(scene: Scene, *, t_end: float, out: Optional[str] = None, frame_dt: Optional[float] = None,
             keep_frames: Optional[bool] = None, progress: Optional[bool] = None, max_regrows: int = 8,
             observe=None, rebuild_period: Optional[int] = None, tuning=None,
             checkpoint_every: Optional[int] = None, resume: Optional[str] = None) -> Result:
    """Run ``scene`` to ``t_end`` [s]: output frames are a whole number of steps
    (``round(frame_dt / dt)``) apart, and the run ends on the first frame at or after ``t_end``
    (within half a step).

    Args:
        t_end: end time s.
        out: HDF5 path to write frames to (chunk by chunk), or None; XDMF sidecars for ParaView
            are written next to it at the end (``rockjax.io.xdmf``). Its folder must exist and be
            writable (checked before the run starts). With ``out`` the run also writes a
            checkpoint at its end and when interrupted (Ctrl-C), so it can be resumed or extended.
        frame_dt: output interval s (default: ~50 frames over the run); at most ``t_end``.
        keep_frames: keep frames in memory (default: when ``out`` is None).
        progress: show a progress bar (default: when stderr is a terminal).
        max_regrows: how many buffer regrowths to try before giving up.
        observe: optional ``observe(state, params, config) -> dict`` of arrays (gauges, run-up, ...),
            jitted and evaluated at every frame; stacked into ``Result.observed``.
        rebuild_period: rebuild the neighbour list (and re-sort the particles) at least every this
            many steps; between, the displacement trigger rebuilds it whenever a particle would
            move more than ``skin / 2`` (module docstring). Default ``max(Config.rebuild_every,
            32)``; halved by the driver if a list is ever found stale.
        tuning: speed settings (``rockjax.Tuning``) replacing the scene's ``config.tuning``, or None.
        checkpoint_every: also write a checkpoint every this many frames (needs ``out``): the full
            State and the driver's own state (frame, rebuild period, grown buffer sizes), replacing
            the previous one once complete (``io.hdf5``).
        resume: a run file written with ``out`` (by this scene: same config and params): continue
            from its newest complete checkpoint to ``t_end``, appending frames to that file (the
            frames after the checkpoint, and a torn last frame, are dropped first). The resumed
            trajectory is the one the run would have taken uninterrupted, bit for bit (same
            compiled steps, same state, same buffer sizes after a regrow, same rebuild schedule).
            ``frame_dt`` (None: the file's) and ``out`` (None: the file) must match the file.

    Raises:
        ValueError: inputs no run can use, checked on the host before anything is compiled:
            ``t_end`` / ``frame_dt`` (``check_times``), ``out`` (``check_out``), params the config
            cannot run (``scenes.check_params``, ``check_block_dt``), ``rebuild_period``,
            ``checkpoint_every``, a ``resume`` file without a checkpoint or of another scene.
        SimulationError: a fatal status bit (non-finite values, particles off the grid, unstable
            dt), naming the first step that set it and, for NaN / Inf, the fields that held them.
        Interrupted: Ctrl-C (a ``KeyboardInterrupt``), after writing a checkpoint to ``out``.
        OSError: writing ``out`` failed mid-run (disk full): the frames written so far are kept.
    """
    config, params, state = scene.config, scene.params, scene.state
    if tuning is not None:
        config = config.replace(tuning=tuning)
        scene = scene.replace(config=config)
    if state.blocks is not None:  # a scene whose BlockConfig slots were changed after it was built
        from . import blocks

        state = state.replace(blocks=blocks.fit_history(config.blocks, state.blocks))
    ckpt = None
    if resume is not None:
        ckpt = check_resume(resume, out)
        out = resume
        if frame_dt is None:
            frame_dt = ckpt.driver["steps_per_frame"] * config.dt
    check_times(t_end, frame_dt)
    if resume is None:
        check_out(out)
    check_params(config, params)
    check_block_dt(config, params, state)
    if checkpoint_every is not None and (int(checkpoint_every) != checkpoint_every or checkpoint_every < 1
                                         or out is None):
        raise ValueError(f"checkpoint_every must be a positive number of frames, with out set "
                         f"(got {checkpoint_every!r}, out = {out!r})")
    frame_dt = t_end / 50 if frame_dt is None else float(frame_dt)
    keep_frames = out is None if keep_frames is None else keep_frames
    progress = sys.stderr.isatty() if progress is None else progress

    steps_per_frame = max(1, round(frame_dt / config.dt))
    # the last frame is the first at or after t_end, within half a step (a frame_dt rounded to
    # whole steps adds no frame for the rounding)
    n_frames = max(1, math.ceil((t_end - 0.5 * config.dt) / (steps_per_frame * config.dt)))
    if rebuild_period is None:
        period = max(config.rebuild_every, DEFAULT_REBUILD_PERIOD)
    elif int(rebuild_period) != rebuild_period or rebuild_period < 1:
        raise ValueError(f"simulate: rebuild_period must be a positive number of steps (got {rebuild_period})")
    else:
        period = int(rebuild_period)

    frames: list[dict] = []
    times: list[float] = []
    observed: list[dict] = []
    regrows = 0
    steps_done = 0
    frame = 0
    t0 = time.perf_counter()
    if ckpt is not None:
        config, period, state, frame, steps_done, regrows = _resumed(ckpt, resume, scene.replace(config=config),
                                                                     state, params, steps_per_frame, t_end)
        earlier = _earlier_frames(resume, frame + 1, keep_frames)
        times, frames, observed = earlier["times"], earlier["frames"], earlier["observed"]
    else:
        state = prime(state, params, config)
        bits = int(state.status)
        if bits:
            config, period, state, regrows = _handle(config, period, state, scene.state, params, bits, regrows,
                                                     max_regrows, primed=False)
        state = _clear(state)

    writer = None
    if out is not None:
        from .io.hdf5 import Writer

        writer = Writer.reopen(out, frame + 1) if ckpt is not None else Writer(out, scene)

    obs_fn = None
    if observe is not None:
        obs_fn = jax.jit(lambda s, p: observe(s, p, scene.config))

    def record(s: State):
        t = float(s.step) * config.dt
        obs = None
        if obs_fn is not None:
            obs = jax.device_get(obs_fn(s, params))
        frame_arrays = host_frame(s)
        if writer is not None:
            try:
                writer.append(t, frame_arrays, int(s.status), observed=obs)
            except OSError as e:
                n = writer.n_frames
                raise OSError(e.errno, f"writing frame {n} (t = {t:.6g} s) to {out!r} failed ({e}); the "
                                       f"{n} frames written before it are kept (rockjax.io.read)") from e
        times.append(t)
        if obs is not None:
            observed.append(obs)
        if keep_frames:
            frames.append(frame_arrays)

    def checkpoint():
        leaves = jax.tree_util.tree_flatten_with_path(jax.device_get(state))[0]
        writer.write_checkpoint(frame, [(jax.tree_util.keystr(k), v) for k, v in leaves], dict(
            frame=frame, step=int(state.step), steps_done=steps_done, period=period, regrows=regrows,
            steps_per_frame=steps_per_frame, dt=config.dt, x64=bool(jax.config.jax_enable_x64),
            capacities=dataclasses.asdict(config.capacities),
            block_capacities=dataclasses.asdict(config.blocks.capacities) if config.blocks is not None else None,
            config=_config_json(config)))

    bar = None
    stop = _StopRequest() if writer is not None else None
    try:
        if stop is not None:
            stop.install()
        if ckpt is None:
            record(state)
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=n_frames, initial=frame, unit="frame", dynamic_ncols=True)
        steps_run, t_run = steps_done, time.perf_counter()
        while frame < n_frames:
            if stop is not None and stop.signum:
                raise KeyboardInterrupt
            new, first, fields = _compiled_chunk(config, steps_per_frame, period)(state, params)
            bits = int(new.status)
            if bits:
                config, period, state, regrows = _handle(config, period, new, state, params, bits, regrows,
                                                         max_regrows, first=int(first), fields=int(fields))
                continue
            record(new)
            state, frame, steps_done = new, frame + 1, steps_done + steps_per_frame
            if checkpoint_every is not None and frame % int(checkpoint_every) == 0 and frame < n_frames:
                checkpoint()
            if bar is not None:
                now = time.perf_counter()
                if frame == 1:  # the first chunk includes the compile: the rate counts from here on
                    t_run, steps_run = now, steps_done
                rate = (steps_done - steps_run) / max(now - t_run, 1e-9) if steps_done > steps_run else float("nan")
                bar.set_postfix_str(f"t={times[-1]:.4g}/{t_end:.4g} s steps/s={rate:.0f}", refresh=False)
                bar.update(1)
        if writer is not None:
            checkpoint()
    except KeyboardInterrupt as e:
        if writer is None:
            raise
        if stop is not None:
            stop.restore()  # a second Ctrl-C while the checkpoint is written stops at once
        checkpoint()  # the state after the last complete frame
        signum = stop.signum if stop is not None and stop.signum else signal.SIGINT
        raise Interrupted(f"interrupted ({signal.Signals(signum).name}) at t = "
                          f"{frame * steps_per_frame * config.dt:.6g} s (frame {frame}); checkpoint written to "
                          f"{out!r}: resume with simulate(..., resume={out!r}) or `rockjax run ... --resume {out}`",
                          path=out, frame=frame, signum=int(signum)) from e
    finally:
        if stop is not None:
            stop.restore()
        if bar is not None:
            bar.close()
        if writer is not None:
            writer.close()
    if out is not None:
        from .io.xdmf import write_xdmf

        write_xdmf(out)  # ParaView sidecars next to the HDF5 (run.xdmf, run_blocks.xdmf)
    wall = time.perf_counter() - t0
    stacked = None
    if keep_frames:
        stacked = {k: np.stack([f[k] for f in frames]) for k in frames[0]}
    n_fluid = 0
    if scene.state.particles is not None:
        n_fluid = int(np.sum(np.asarray(scene.state.particles.kind) == Kind.FLUID))
    stats = {"wall_s": wall, "steps": steps_done, "regrows": regrows, "n_fluid": n_fluid, "rebuild_period": period,
             "particle_steps_per_s": n_fluid * steps_done / max(wall, 1e-9)}
    obs = {k: np.stack([np.asarray(o[k]) for o in observed]) for k in observed[0]} if observed else None
    return Result(scene=scene.replace(config=config, state=state), state=state, times=np.asarray(times),
                  frames=stacked, path=out, stats=stats, observed=obs)


class Interrupted(KeyboardInterrupt):
    """A run stopped by Ctrl-C (SIGINT) or SIGTERM after writing a checkpoint: ``path`` (the run
    file), ``frame`` (the last complete frame, where ``simulate(..., resume=path)`` continues) and
    ``signum`` (the signal; the CLI exits with 128 + signum)."""

    def __init__(self, message: str, *, path: str, frame: int, signum: int = signal.SIGINT):
        super().__init__(message)
        self.path = path
        self.frame = frame
        self.signum = signum


class _StopRequest:
    """SIGINT / SIGTERM during a run with an output file: remembered (``signum``) instead of raised
    inside a running computation, so the driver stops at the next frame boundary, writes a
    checkpoint and raises ``Interrupted``. Only from the main thread (where Python runs signal
    handlers); a second signal gets the previous handler (Ctrl-C twice: stop at once)."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.signum = 0
        self._old = {}

    def install(self) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        for sig in self.SIGNALS:
            self._old[sig] = signal.signal(sig, self._handle)

    def _handle(self, signum, _frame) -> None:
        self.signum = signum
        self.restore()

    def restore(self) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old = {}


def _config_json(config: Config) -> str:
    from .io.hdf5 import config_to_json

    return config_to_json(config)


def check_resume(resume, out=None):
    """The newest complete checkpoint (``io.hdf5.Checkpoint``) of the run file ``resume``; a
    ValueError naming ``resume`` when the file cannot be resumed (missing, unwritable, not a run
    file, no complete checkpoint); ``out`` must be None or the same file. Host only, no compile."""
    import os

    from .io.hdf5 import read_checkpoint

    if out is not None and os.path.abspath(os.fspath(out)) != os.path.abspath(os.fspath(resume)):
        raise ValueError(f"out = {out!r} differs from resume = {resume!r}; a resumed run appends to its own file "
                         f"(leave out unset)")
    if not os.path.isfile(resume):
        raise ValueError(f"resume = {resume!r} is not a file; give the HDF5 file a run wrote with out=...")
    if not os.access(resume, os.W_OK):
        raise ValueError(f"resume = {resume!r} is not writable; a resumed run appends its frames to it")
    try:
        ckpt = read_checkpoint(resume)
    except OSError as e:
        raise ValueError(f"resume = {resume!r} cannot be read as a run file ({e})") from e
    if ckpt is None:
        raise ValueError(f"resume = {resume!r} holds no complete checkpoint (a run writes one at its end, on "
                         f"Ctrl-C and every checkpoint_every frames); start the run again")
    return ckpt


def _resumed(ckpt, resume, scene: Scene, state: State, params, steps_per_frame: int, t_end: float):
    """``(config, period, state, frame, steps_done, regrows)`` of a checkpoint, after checking that
    it belongs to this scene (config with the run's grown buffer sizes, params, state layout)."""
    from .io.hdf5 import _params_items

    d = ckpt.driver
    config = scene.config
    if d["steps_per_frame"] != steps_per_frame or not math.isclose(d["dt"], config.dt, rel_tol=1e-12):
        raise ValueError(f"frame_dt: resume = {resume!r} was run with {d['steps_per_frame']} steps of dt = "
                         f"{d['dt']:.6g} s per frame; resume with frame_dt unset (the file's)")
    if d["x64"] != bool(jax.config.jax_enable_x64):
        raise ValueError(f"resume = {resume!r} was run with jax_enable_x64 = {d['x64']}; resume with the same "
                         f"precision")
    from .types import Capacities

    config = config.replace(capacities=Capacities(**d["capacities"]))
    if config.blocks is not None and d["block_capacities"] is not None:
        caps = config.blocks.capacities
        config = config.replace(blocks=config.blocks.replace(capacities=type(caps)(**d["block_capacities"])))
    import json

    mine, theirs = json.loads(_config_json(config)), json.loads(d["config"])
    if mine != theirs:
        keys = sorted(k for k in set(mine) | set(theirs) if mine.get(k) != theirs.get(k))
        raise ValueError(f"resume = {resume!r} was run with another config (fields {', '.join(keys)} differ); "
                         f"resume with the same scene, options and tuning")
    import h5py

    with h5py.File(resume, "r") as f:
        for name, value in _params_items(params):
            stored = f["params"][name][()] if name in f["params"] else None
            if stored is None or np.shape(stored) != np.shape(value) or not np.array_equal(stored, value):
                raise ValueError(f"resume = {resume!r} was run with other params (Params.{name.replace('/', '.')}: "
                                 f"file {stored!r}, scene {value!r}); resume with the same scene and options")
    template = resize(state, config)
    paths, treedef = jax.tree_util.tree_flatten_with_path(template)
    if len(paths) != len(ckpt.leaves):
        raise ValueError(f"resume = {resume!r}: its state has {len(ckpt.leaves)} arrays, this scene's "
                         f"{len(paths)}; resume with the same scene")
    arrays = []
    for (key, ref), (name, a) in zip(paths, ckpt.leaves):
        if jax.tree_util.keystr(key) != name or np.shape(ref) != a.shape or np.dtype(ref.dtype) != a.dtype:
            raise ValueError(f"resume = {resume!r}: state array {name} {a.dtype}{list(a.shape)} does not fit this "
                             f"scene's {jax.tree_util.keystr(key)} {ref.dtype}{list(np.shape(ref))}; resume with "
                             f"the same scene")
        arrays.append(jnp.asarray(a))
    state = jax.tree_util.tree_unflatten(treedef, arrays)
    frame = int(d["frame"])
    if t_end < frame * steps_per_frame * config.dt * (1 - 1e-9):
        raise ValueError(f"t_end = {t_end:g} s is before the checkpoint of resume = {resume!r} "
                         f"({frame * steps_per_frame * config.dt:.6g} s); give a later t_end")
    return config, int(d["period"]), state, frame, int(d["steps_done"]), int(d["regrows"])


def _earlier_frames(path, n: int, keep_frames: bool) -> dict:
    """The first ``n`` frame times (and, when ``keep_frames``, frames; observations) of a run file,
    as the resumed run's Result starts with them (frames as stored, float32)."""
    import h5py

    from .io.hdf5 import _frame_datasets

    with h5py.File(path, "r") as f:
        times = [float(t) for t in f["time"][:n]]
        names = [k for k in _frame_datasets(f) if not k.startswith("observed/")]
        frames = []
        if keep_frames:
            data = {k: f[k][:n] for k in names}
            kind = {"kind": f["kind"][()]} if "kind" in f else {}
            frames = [dict({k: data[k][i] for k in names}, **kind) for i in range(n)]
        observed = []
        if "observed" in f:
            obs = {k: f["observed"][k][:n] for k in f["observed"].keys()}
            observed = [{k: v[i] for k, v in obs.items()} for i in range(n)]
    return {"times": times, "frames": frames, "observed": observed}


def _host_non_finite_fields(state: State) -> tuple:
    """The ``_FIELDS`` of ``state`` holding a NaN or Inf (host)."""
    out = []
    for part, name in _FIELDS:
        obj = getattr(state, part)
        if obj is not None and not np.all(np.isfinite(np.asarray(getattr(obj, name)))):
            out.append(f"{part}.{name}")
    return tuple(out)


def _handle(config, period, bad_state, start_state, params, bits, regrows, max_regrows, primed=True,
            first: int = -1, fields: int = 0):
    """Grow buffers for growable bits and return ``(config, period, state, regrows)`` with the
    chunk's start state re-made for the new buffers (its list rebuilt, or primed at the start of
    the run), or raise on a fatal bit or after ``max_regrows``. ``first`` / ``fields``: the
    chunk's first step with a fatal bit and its non-finite field mask (``_compiled_chunk``; -1:
    the state is a single step's, ``bad_state`` itself)."""
    while True:
        fatal = bits & ~int(Status.growable())
        if fatal:
            if first >= 0:
                step, names = first, _field_names(fields)
            else:
                step, names = int(bad_state.step), _host_non_finite_fields(bad_state)
            where = f" in {', '.join(names)}" if names and fatal & Status.NON_FINITE else ""
            raise SimulationError(
                f"simulation stopped at step {step} (t = {step * config.dt:.6g} s): {Status.describe(fatal)}{where}. "
                + _advice(fatal), step=step, status=bits, fields=names if where else ())
        if regrows >= max_regrows:
            raise SimulationError(f"gave up after {regrows} buffer regrowths ({Status.describe(bits)})",
                                  step=int(bad_state.step), status=bits)
        config, period = _grow(config, period, bad_state, bits)
        regrows += 1
        state = _clear(resize(start_state, config))
        # the resized list is empty: build it now (the chunk need not start with a rebuild)
        state = refresh(state, config) if primed else prime(state, params, config)
        bits = int(state.status)
        if not bits:
            return config, period, state, regrows
        bad_state, first = state, -1


def check_block_dt(config: Config, params, state: State) -> None:
    """Refuse a Config.dt above the blocks' stable step (seed Eq 8) for these Params (host side)."""
    if not config.has_blocks:
        return
    from . import blocks

    limit = float(blocks.stable_dt(config.blocks, params.blocks, state.blocks))
    if config.block_dt > limit * (1 + 1e-6):
        raise ValueError(
            f"Config.dt = {config.dt:.4g} s over block_substeps = {config.block_substeps} ({config.block_dt:.4g} s) "
            f"exceeds the block stability limit {limit:.4g} s "
            "(seed Eq 8: stiffest contact, lightest block) for these Params; use a smaller dt (Config.replace(dt=...)), "
            "more Config.block_substeps, a lower Params.blocks.normal_stiffness or heavier blocks.")


def _advice(bits: int) -> str:
    tips = []
    if bits & Status.NON_FINITE:
        tips.append("NaN/Inf appeared: reduce dt or check Params (speed of sound, viscosity).")
    if bits & Status.OUT_OF_DOMAIN:
        tips.append("A particle left the domain: enlarge the domain (tank height/length) or check the inflow.")
    if bits & Status.UNSTABLE_DT:
        tips.append("The time step exceeds the CFL/viscous limit for the current speeds: reduce Config.dt or raise c0.")
    if bits & Status.SOLVER_NOT_CONVERGED:
        tips.append("The pressure solve did not reach its tolerance within DFSPH(max_iterations=...): raise "
                    "max_iterations, loosen DFSPH(tolerance=...) or reduce Config.dt.")
    if bits & Status.BLOCK_UNSTABLE:
        tips.append("The time step exceeds the block stability limit (seed Eq 8) for these Params (stiffer "
                    "contacts or lighter blocks): reduce Config.dt or the penalty stiffness.")
    if bits & Status.BLOCK_PENETRATION:
        tips.append("Blocks interpenetrated too deeply: raise the contact stiffness or reduce dt / impact speed.")
    return " ".join(tips)
