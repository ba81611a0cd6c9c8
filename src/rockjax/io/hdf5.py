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

Every per-frame array of ``driver.host_frame`` becomes one extendable dataset ``[F, ...]``.
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

__all__ = ["Writer", "Run", "read", "config_to_json"]


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
    """Append frames of one run to an HDF5 file. Use ``append`` per frame, then ``close``."""

    def __init__(self, path: str, scene):
        self.path = str(path)
        self.f = h5py.File(self.path, "w")
        from .. import __version__

        self.f.attrs["rockjax_version"] = __version__
        self.f.attrs["scene"] = scene.name
        self.f.attrs["config"] = config_to_json(scene.config)
        self.f.attrs["meta"] = json.dumps(_jsonable(scene.meta))
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

    def append(self, t: float, frame: dict, status: int = 0, observed: dict | None = None) -> None:
        """Add one frame (``frame`` as from ``driver.host_frame``; ``observed`` as from an observer)."""
        frame = dict(frame, **{f"observed/{k}": v for k, v in (observed or {}).items()})
        if self._names is None:
            if "kind" in frame:
                self.f.create_dataset("kind", data=np.asarray(frame["kind"], np.int32))
            self._names = [k for k in frame if k != "kind"]
            for name in self._names:
                a = np.asarray(frame[name])
                self.f.create_dataset(name, shape=(0,) + a.shape, maxshape=(None,) + a.shape, dtype="f4",
                                      chunks=(1,) + a.shape, compression="gzip", compression_opts=1)
        k = self.f["time"].shape[0]
        for name in ["time", "status"] + self._names:
            self.f[name].resize(k + 1, axis=0)
        self.f["time"][k] = t
        self.f["status"][k] = status
        for name in self._names:
            self.f[name][k] = np.asarray(frame[name], np.float32)
        self.f.flush()

    def close(self) -> None:
        if self.f:
            self.f.close()
            self.f = None


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
    """Read a whole run written by ``Writer``."""
    with h5py.File(path, "r") as f:
        skip = {"params", "blocks", "time", "status", "kind", "observed", "xdmf"}
        frames = {k: f[k][()] for k in f.keys() if k not in skip and isinstance(f[k], h5py.Dataset)}
        observed = _group(f["observed"]) if "observed" in f else None
        return Run(scene=str(f.attrs["scene"]), config=json.loads(f.attrs["config"]), meta=json.loads(f.attrs["meta"]),
                   params=_group(f["params"]), time=f["time"][()], status=f["status"][()], frames=frames,
                   kind=f["kind"][()] if "kind" in f else None, x=frames.get("x"), v=frames.get("v"),
                   rho=frames.get("rho"), p=frames.get("p"), blocks=_group(f["blocks"]) if "blocks" in f else None,
                   observed=observed)
