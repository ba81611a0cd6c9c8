"""A scene's metadata (``Scene.meta``): what the observers and the output read, typed.

Every scene has a ``name`` and a particle spacing ``dx`` [m] (None: blocks only). The observers
(``observables.scene_observer``) read the optional ``still_level`` [m], ``gauges`` and
``runup_slope``; these have fields here. Everything else a builder records (its geometry: tank
sizes, slope angles, the block stiffness it chose, the scene file) goes into ``extra``.

``SceneMeta`` is also a read-only mapping with the keys of the dict it replaced (``meta["dx"]``,
``meta.get("gauges")``, ``"runup_slope" in meta``, ``dict(meta)``), in the order the builder wrote
them, so that readers of the dict and the HDF5 ``meta`` attribute (``io.hdf5``) see the same keys
and values. Optional fields that are None are absent from the mapping, as the keys were.
"""

from __future__ import annotations

import collections.abc
import dataclasses
from typing import Any, Iterator

__all__ = ["SceneMeta", "Gauges", "RunupSlope"]


class _FieldMapping(collections.abc.Mapping):
    """Read-only mapping over a frozen dataclass's fields (equal to a dict of the same items)."""

    def _keys(self) -> tuple[str, ...]:
        return tuple(f.name for f in dataclasses.fields(self))

    def __getitem__(self, key: str) -> Any:
        if key not in self._keys():
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self._keys())

    def __len__(self) -> int:
        return len(self._keys())

    def as_dict(self) -> dict:
        """A plain dict of the items (nested metadata as dicts too)."""
        return {k: v.as_dict() if isinstance(v, _FieldMapping) else v for k, v in self.items()}


@dataclasses.dataclass(frozen=True, eq=False)
class Gauges(_FieldMapping):
    """Free-surface gauges: ``names`` [M], positions ``xy`` [M][2] m and the bed under each, ``bottom_z`` [M] m."""

    names: list
    xy: list
    bottom_z: list


@dataclasses.dataclass(frozen=True, eq=False)
class RunupSlope(_FieldMapping):
    """The slope run-up is measured on: a ``point`` [3] m on it, its outward unit ``normal`` [3], and
    ``x_min`` [m] (only water beyond this x counts; None: all of it)."""

    point: list
    normal: list
    x_min: float | None = None


_TYPED = ("name", "dx", "still_level", "gauges", "runup_slope")


@dataclasses.dataclass(frozen=True, eq=False)
class SceneMeta(_FieldMapping):
    """A scene's metadata: ``name``, ``dx`` [m] (None: no particles), the observers' optional
    ``still_level`` [m], ``gauges`` and ``runup_slope``, and the builder's ``extra`` items (SI units).

    Build one with ``SceneMeta.from_dict``; read it by attribute or as a mapping (``meta["dx"]``).
    """

    name: str = "scene"
    dx: float | None = None
    still_level: float | None = None
    gauges: Gauges | None = None
    runup_slope: RunupSlope | None = None
    extra: dict = dataclasses.field(default_factory=dict)
    order: tuple = dataclasses.field(default=(), repr=False)  # the mapping's key order

    @classmethod
    def from_dict(cls, items: collections.abc.Mapping) -> "SceneMeta":
        """The metadata of a builder's dict: its typed keys to fields (``gauges`` and ``runup_slope``
        given as dicts of their fields), the rest to ``extra``; the dict's key order is kept."""
        if isinstance(items, SceneMeta):
            return items
        items = dict(items)
        typed = {k: items[k] for k in _TYPED if k in items}
        try:
            if isinstance(typed.get("gauges"), collections.abc.Mapping):
                typed["gauges"] = Gauges(**typed["gauges"])
            if isinstance(typed.get("runup_slope"), collections.abc.Mapping):
                typed["runup_slope"] = RunupSlope(**typed["runup_slope"])
        except TypeError as exc:
            raise ValueError(f"scene meta: {exc} (gauges: names, xy, bottom_z; runup_slope: point, normal, "
                             "x_min)") from exc
        extra = {k: v for k, v in items.items() if k not in _TYPED}
        return cls(**typed, extra=extra, order=tuple(items))

    def with_items(self, **items) -> "SceneMeta":
        """This metadata with ``items`` added or replaced (new keys last)."""
        return SceneMeta.from_dict({**dict(self.items()), **items})

    def _keys(self) -> tuple[str, ...]:
        present = [k for k in _TYPED if k in ("name", "dx") or getattr(self, k) is not None] + list(self.extra)
        first = [k for k in self.order if k in present]
        return tuple(first + [k for k in present if k not in first])

    def __getitem__(self, key: str) -> Any:
        if key in self.extra:
            return self.extra[key]
        if key in _TYPED and (key in ("name", "dx") or getattr(self, key) is not None):
            return getattr(self, key)
        raise KeyError(key)
