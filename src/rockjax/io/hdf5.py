"""HDF5 output of a run, written frame by frame so a long run never holds all frames in memory.

Layout::

    /                attrs: rockjax_version, scene (name), config (JSON), meta (JSON)
    /params/...      one dataset per Params leaf (path-like names, e.g. fluid/rho0)
    /kind            [N] int32 particle kinds (original particle order)
    /time            [F] s
    /status          [F] int32 status bits at each frame
    /x, /v           [F, N, 3] m, m/s          (scenes with particles)
    /rho, /p         [F, N] kg/m^3, Pa
    /block_x         [F, B, 3] m block centroids (scenes with blocks)
    /block_q         [F, B, 4] unit quaternions (w, x, y, z), body -> world
    /block_v, /block_omega  [F, B, 3] m/s, rad/s
    /blocks/...      static block geometry for viewers: vertices [B, V, 3] m (body frame, about the
                     centroid), vertex_mask, face_mask, he_vert, he_next, he_face, halfedge_mask
    /observed/NAME   [F, ...] what ``simulate(observe=...)`` recorded at each frame (gauges [F, M] m,
                     runup, smooth_runup [F] m, energies [F] J, ...)
    /xdmf/...        views for the XDMF sidecars, added by ``io.xdmf.write_xdmf`` (see there)
    /checkpoints/cNNNNNNNN  the full State after frame NNNNNNNN (one dataset per leaf, its exact
                     dtype, attr ``path`` = the leaf's key path) and the driver's own state (attr
                     ``driver``, JSON: frame, step, rebuild period, regrows, steps per frame, dt,
                     grown buffer sizes, config JSON); attr ``complete`` written last

Every per-frame array of ``driver.host_frame`` becomes one extendable dataset ``[F, ...]``.

Torn writes. The root attr ``frames_complete`` is set after a frame's datasets are written and
flushed, and a checkpoint's ``complete`` attr after its datasets; a process killed mid-write
(SIGKILL, power) leaves at most one torn frame (datasets one longer than ``frames_complete``)
and one torn checkpoint (no ``complete``), which ``read`` and ``read_checkpoint`` ignore and a
resumed run (``simulate(resume=...)``) truncates. A new checkpoint is complete before the
previous one is deleted, so a file that held one always holds one.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import enum
import hashlib
import json
from typing import Any

import h5py
import jax
import numpy as np

__all__ = ["Writer", "Run", "read", "config_to_json", "Checkpoint", "read_checkpoint", "frames_complete"]


def _jsonable(obj: Any):
    if isinstance(obj, enum.Enum):
        return obj.value
    if isinstance(obj, collections.abc.Mapping):  # dicts and the scene's meta (scenes.meta)
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if dataclasses.is_dataclass(obj):
        fields = {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
        name = getattr(type(obj), "name", None)  # a named choice of maths (a scheme, term, coupling, law)
        if isinstance(name, str) and "name" not in fields:
            return {"name": name or type(obj).__name__, **fields}
        if not fields and not isinstance(obj, type):  # a choice with no name and no fields: its class
            return {"name": type(obj).__name__}
        return fields
    if isinstance(obj, (tuple, list)):
        return [_jsonable(o) for o in obj]
    if isinstance(obj, (np.generic,)):
        return obj.item()
    if isinstance(obj, np.ndarray):  # a path's table: short ones in full, long ones by shape and digest
        if obj.size <= 64:
            return obj.tolist()
        return {"shape": list(obj.shape), "first": obj.ravel()[0].item(), "last": obj.ravel()[-1].item(),
                "sha1": hashlib.sha1(np.ascontiguousarray(obj).tobytes()).hexdigest()}
    return obj


def config_to_json(config) -> str:
    """The static config as JSON (enums by value; scheme, term, coupling and contact-law objects as
    ``{"name": ..., their fields...}``)."""
    return json.dumps(_jsonable(config))


def _params_items(params):
    leaves = jax.tree_util.tree_flatten_with_path(params)[0]
    for path, leaf in leaves:
        name = "/".join(str(getattr(k, "name", getattr(k, "key", k))) for k in path)
        yield name, np.asarray(leaf)


class Writer:
    """Append frames of one run to an HDF5 file. Use ``append`` per frame, ``write_checkpoint``
    when the run should be resumable from there, then ``close``. ``Writer.reopen`` continues a
    file for a resumed run."""

    def __init__(self, path: str, scene):
        self.path = str(path)
        self.f = h5py.File(self.path, "w")
        from .. import __version__

        self.f.attrs["rockjax_version"] = __version__
        self.f.attrs["scene"] = scene.name
        self.f.attrs["config"] = config_to_json(scene.config)
        self.f.attrs["meta"] = json.dumps(_jsonable(scene.meta))
        self.f.attrs["frames_complete"] = 0
        g = self.f.create_group("params")
        for name, value in _params_items(scene.params):
            g.create_dataset(name, data=value)
        self.f.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8")
        self.f.create_dataset("status", shape=(0,), maxshape=(None,), dtype="i4")
        blocks = getattr(scene.state, "blocks", None)
        if blocks is not None:
            gb = self.f.create_group("blocks")
            for name in ("vertices", "vertex_mask", "face_mask", "he_vert", "he_next", "he_face",
                         "halfedge_mask"):
                value = getattr(blocks.shape, name, None)
                if value is not None:
                    gb.create_dataset(name, data=np.asarray(value))
        self._names: list[str] | None = None
        self.f.flush()

    @classmethod
    def reopen(cls, path: str, n_frames: int) -> "Writer":
        """The writer of an existing run file, its frames cut to the first ``n_frames`` (those a
        resumed run keeps; later and torn frames and the XDMF views are dropped), the next
        ``append`` writing frame ``n_frames``."""
        self = cls.__new__(cls)
        self.path = str(path)
        self.f = h5py.File(self.path, "r+")
        names = _frame_datasets(self.f)
        for name in ["time", "status"] + names:
            if self.f[name].shape[0] > n_frames:
                self.f[name].resize(n_frames, axis=0)
        if "xdmf" in self.f:
            del self.f["xdmf"]
        self.f.attrs["frames_complete"] = n_frames
        self._names = names if names else None
        self.f.flush()
        return self

    @property
    def n_frames(self) -> int:
        """Frames written completely so far."""
        return int(self.f.attrs["frames_complete"])

    def append(self, t: float, frame: dict, status: int = 0, observed: dict | None = None) -> None:
        """Add one frame (``frame`` as from ``driver.host_frame``; ``observed`` as from an
        observer); it counts (``frames_complete``) once all its datasets are written and flushed."""
        frame = dict(frame, **{f"observed/{k}": v for k, v in (observed or {}).items()})
        if self._names is None:
            if "kind" in frame and "kind" not in self.f:
                self.f.create_dataset("kind", data=np.asarray(frame["kind"], np.int32))
            self._names = [k for k in frame if k != "kind"]
            for name in self._names:
                a = np.asarray(frame[name])
                self.f.create_dataset(name, shape=(0,) + a.shape, maxshape=(None,) + a.shape, dtype="f4",
                                      chunks=(1,) + a.shape, compression="gzip", compression_opts=1)
        k = self.n_frames
        for name in ["time", "status"] + self._names:
            self.f[name].resize(k + 1, axis=0)
        self.f.flush()  # the frame's slot is on disk, not yet counted: torn until frames_complete says so
        self.f["time"][k] = t
        self.f["status"][k] = status
        for name in self._names:
            self.f[name][k] = np.asarray(frame[name], np.float32)
        self.f.flush()
        self.f.attrs["frames_complete"] = k + 1
        self.f.flush()

    def write_checkpoint(self, frame: int, leaves: list, driver: dict) -> None:
        """Store a resumable point: ``leaves`` = ``[(key_path, array)]`` of the State after frame
        ``frame`` (exact dtypes), ``driver`` = the driver's own state (JSON-able). Written under
        ``/checkpoints/c<frame>``, marked complete, then the older checkpoints are deleted."""
        root = self.f.require_group("checkpoints")
        name = f"c{frame:08d}"
        if name in root:
            del root[name]
        g = root.create_group(name)
        self.f.flush()  # on disk without ``complete``: torn until that attr is written
        for i, (path, value) in enumerate(leaves):
            a = np.asarray(value)
            big = a.size >= 4096
            d = g.create_dataset(f"{i:04d}", data=a, compression="gzip" if big else None,
                                 compression_opts=1 if big else None)
            d.attrs["path"] = path
        g.attrs["frame"] = int(frame)
        g.attrs["driver"] = json.dumps(_jsonable(driver))
        self.f.flush()
        g.attrs["complete"] = 1
        self.f.flush()
        for old in [k for k in root.keys() if k != name]:
            del root[old]
        self.f.flush()

    def close(self) -> None:
        if self.f:
            self.f.close()
            self.f = None


def _frame_datasets(f) -> list[str]:
    """The per-frame datasets of a run file other than /time and /status (``Writer.append`` order
    does not matter: each is cut or extended alone)."""
    skip = {"params", "blocks", "time", "status", "kind", "observed", "xdmf", "checkpoints"}
    names = [k for k in f.keys() if k not in skip and isinstance(f[k], h5py.Dataset)]
    if "observed" in f:
        names += [f"observed/{k}" for k in f["observed"].keys()]
    return names


def frames_complete(f) -> int:
    """Frames fully written in an open run file (``frames_complete``; a file written before that
    attr existed: the length of /time)."""
    n = f["time"].shape[0]
    return min(int(f.attrs.get("frames_complete", n)), n)


@dataclasses.dataclass
class Checkpoint:
    """The newest complete checkpoint of a run file (``read_checkpoint``).

    Attributes:
        frame: the frame it follows (frames ``0..frame`` are the run's so far).
        leaves: ``[(key_path, array)]`` of the State, in ``jax.tree_util`` flattening order.
        driver: the driver's own state (dict, see ``driver.simulate``).
    """

    frame: int
    leaves: list
    driver: dict


def read_checkpoint(path: str) -> Checkpoint | None:
    """The newest complete checkpoint in ``path`` (torn ones, without ``complete``, are skipped),
    or None when the file holds none."""
    with h5py.File(path, "r") as f:
        if "checkpoints" not in f:
            return None
        done = [g for g in f["checkpoints"].values() if int(g.attrs.get("complete", 0)) == 1]
        if not done:
            return None
        g = max(done, key=lambda g: int(g.attrs["frame"]))
        leaves = [(str(g[k].attrs["path"]), g[k][()]) for k in sorted(g.keys())]
        return Checkpoint(frame=int(g.attrs["frame"]), leaves=leaves, driver=json.loads(g.attrs["driver"]))


@dataclasses.dataclass
class Run:
    """A run read back from HDF5: arrays in original particle order, config and meta as dicts.

    Particle fields (``kind``, ``x``, ``v``, ``rho``, ``p``) are None in a blocks-only run;
    ``frames`` holds every per-frame dataset by name (including ``block_x``, ``block_q``, ...);
    ``blocks`` the static block geometry, or None; ``observed`` the observer's records by name, or None.
    """

    scene: str
    config: dict
    meta: dict
    params: dict
    time: np.ndarray
    status: np.ndarray
    frames: dict
    kind: np.ndarray | None = None
    x: np.ndarray | None = None
    v: np.ndarray | None = None
    rho: np.ndarray | None = None
    p: np.ndarray | None = None
    blocks: dict | None = None
    observed: dict | None = None


def _group(g) -> dict:
    out = {}
    g.visititems(lambda name, obj: out.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
    return out


def read(path: str) -> Run:
    """Read a whole run written by ``Writer``: its complete frames (a torn last frame, from a
    process killed while writing it, is left out)."""
    with h5py.File(path, "r") as f:
        n = frames_complete(f)
        skip = {"params", "blocks", "time", "status", "kind", "observed", "xdmf", "checkpoints"}
        frames = {k: f[k][:n] for k in f.keys() if k not in skip and isinstance(f[k], h5py.Dataset)}
        observed = {k: v[:n] for k, v in _group(f["observed"]).items()} if "observed" in f else None
        return Run(scene=str(f.attrs["scene"]), config=json.loads(f.attrs["config"]), meta=json.loads(f.attrs["meta"]),
                   params=_group(f["params"]), time=f["time"][:n], status=f["status"][:n], frames=frames,
                   kind=f["kind"][()] if "kind" in f else None, x=frames.get("x"), v=frames.get("v"),
                   rho=frames.get("rho"), p=frames.get("p"), blocks=_group(f["blocks"]) if "blocks" in f else None,
                   observed=observed)
