"""HDF5 output of a run, written frame by frame so a long run never holds all frames in memory.

Layout::

    /                attrs: rockjax_version, scene (name), config (JSON), meta (JSON)
    /params/...      one dataset per Params leaf (path-like names, e.g. fluid/rho0)
    /kind            [N] int32 particle kinds (original particle order)
    /time            [F] s
    /status          [F] int32 status bits at each frame
    /x, /v           [F, N, 3] m, m/s
    /rho, /p         [F, N] kg/m^3, Pa
"""

from __future__ import annotations

import dataclasses
import enum
import json
from typing import Any

import h5py
import jax
import numpy as np

__all__ = ["Writer", "Run", "read", "config_to_json"]


def _jsonable(obj: Any):
    if isinstance(obj, enum.Enum):
        return obj.value
    if dataclasses.is_dataclass(obj):
        return {f.name: _jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (tuple, list)):
        return [_jsonable(o) for o in obj]
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (np.generic,)):
        return obj.item()
    return obj


def config_to_json(config) -> str:
    """The static config as JSON (enums by value)."""
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
        n = scene.config.n_particles
        self.f.create_dataset("time", shape=(0,), maxshape=(None,), dtype="f8")
        self.f.create_dataset("status", shape=(0,), maxshape=(None,), dtype="i4")
        for name, tail in (("x", (3,)), ("v", (3,)), ("rho", ()), ("p", ())):
            self.f.create_dataset(name, shape=(0, n) + tail, maxshape=(None, n) + tail, dtype="f4",
                                  chunks=(1, n) + tail, compression="gzip", compression_opts=1)
        self._kind_written = False

    def append(self, t: float, frame: dict, status: int = 0) -> None:
        """Add one frame (``frame`` as from ``driver.host_frame``)."""
        if not self._kind_written:
            self.f.create_dataset("kind", data=np.asarray(frame["kind"], np.int32))
            self._kind_written = True
        k = self.f["time"].shape[0]
        for name in ("time", "status", "x", "v", "rho", "p"):
            ds = self.f[name]
            ds.resize(k + 1, axis=0)
        self.f["time"][k] = t
        self.f["status"][k] = status
        for name in ("x", "v", "rho", "p"):
            self.f[name][k] = np.asarray(frame[name], np.float32)
        self.f.flush()

    def close(self) -> None:
        if self.f:
            self.f.close()
            self.f = None


@dataclasses.dataclass
class Run:
    """A run read back from HDF5: arrays in original particle order, config and meta as dicts."""

    scene: str
    config: dict
    meta: dict
    params: dict
    kind: np.ndarray
    time: np.ndarray
    status: np.ndarray
    x: np.ndarray
    v: np.ndarray
    rho: np.ndarray
    p: np.ndarray


def read(path: str) -> Run:
    """Read a whole run written by ``Writer``."""
    with h5py.File(path, "r") as f:
        params = {}
        f["params"].visititems(lambda name, obj: params.__setitem__(name, obj[()]) if isinstance(obj, h5py.Dataset) else None)
        return Run(scene=str(f.attrs["scene"]), config=json.loads(f.attrs["config"]), meta=json.loads(f.attrs["meta"]),
                   params=params, kind=f["kind"][()], time=f["time"][()], status=f["status"][()], x=f["x"][()],
                   v=f["v"][()], rho=f["rho"][()], p=f["p"][()])
