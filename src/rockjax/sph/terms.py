"""The base of every static choice of maths in a fluid scheme (kernels, viscosities, walls,
density diffusions, the schemes themselves), and the table of them by name.

A term is a frozen dataclass: hashable, compared by value, never traced. It chooses the maths;
the numbers it uses (``alpha``, ``nu``, ``delta``, ``h``, ...) stay in ``Params`` so that gradients
reach them. Subclassing registers a class under ``(family, name)``; scene files and the command
line look terms up there (``by_name``), so a new term needs no edit anywhere else.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

__all__ = ["Term", "by_name", "names"]

_REGISTRY: dict[tuple[str, str], type] = {}


class Term:
    """A static choice of maths. Subclasses set ``family`` (the slot they fill: ``"kernel"``,
    ``"viscosity"``, ``"walls"``, ``"diffusion"``, ``"seed_gradient"``, ``"scheme"``) and ``name``
    (the string scene files use), and are frozen dataclasses (``@dataclasses.dataclass(frozen=True)``)."""

    family: ClassVar[str] = ""
    name: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__ and cls.name:
            key = (cls.family, cls.name)
            if key in _REGISTRY and _REGISTRY[key].__qualname__ != cls.__qualname__:
                raise ValueError(f"two {cls.family} terms are named {cls.name!r}: {_REGISTRY[key]} and {cls}")
            _REGISTRY[key] = cls

    def replace(self, **changes):
        return dataclasses.replace(self, **changes)


def by_name(family: str, name: str, **kwargs) -> Term:
    """The ``family`` term called ``name`` (e.g. ``by_name("viscosity", "laminar")``), built with
    ``kwargs``; a ``ValueError`` listing the known names otherwise."""
    cls = _REGISTRY.get((family, str(name).lower()))
    if cls is None:
        raise ValueError(f"unknown {family} {name!r}; known: {', '.join(names(family))}")
    return cls(**kwargs)


def names(family: str) -> list[str]:
    """The registered names of a family, sorted."""
    return sorted(n for f, n in _REGISTRY if f == family)
