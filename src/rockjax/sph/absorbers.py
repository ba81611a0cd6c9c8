"""Absorbing zones for the water: damping (sponge) layers at the ends of a wave flume.

This module owns the ``Absorber`` interface and :class:`Sponge`. A scene lists its absorbers in
``Config.absorbers`` (static; empty by default, then nothing is traced); ``step.advance`` applies
each after the fluid step, to fluid particles only, so every fluid scheme gets them.

A sponge relaxes the velocity of the water in its zone towards rest,

    v <- v / (1 + sigma(s) dt),    sigma(s) = strength * s^2,    s = clip((x - start) . e / L, 0, 1),

with ``e`` the unit vector from ``start`` to ``end`` and ``L`` their distance: the damping grows
from 0 at the zone's entrance (so a wave meets no sudden change, which would itself reflect) to
``strength`` [1/s] at its end; the implicit form is stable for any ``strength * dt``. With the
orbital velocities gone, the free surface in the zone relaxes to the still level (the pressure
of the surrounding water levels it). Zones of one wavelength or more with ``strength`` of a few
wave frequencies absorb most of a wave (``experiments/wave_absorption.py`` measures the
reflection coefficient, RESULTS.md).
"""

from __future__ import annotations

import abc
import dataclasses
import math

import jax.numpy as jnp
import numpy as np

from ..types import Kind

__all__ = ["Absorber", "Sponge"]


class Absorber(abc.ABC):
    """An absorbing zone (static, hashable): ``apply(particles, dt)`` returns the particles with
    the zone's damping applied to the fluid rows after one step of ``dt`` seconds."""

    @abc.abstractmethod
    def apply(self, particles, dt: float):
        ...


@dataclasses.dataclass(frozen=True)
class Sponge(Absorber):
    """A damping layer from ``start`` to ``end`` (points [3], m; the zone is the slab between the
    planes through them normal to ``end - start``; its damping rises quadratically from 0 at
    ``start`` to ``strength`` [1/s] at ``end`` and stays there beyond).

    Attributes:
      start: [3] m, entrance of the zone (no damping).
      end: [3] m, far end of the zone (full damping); ``end - start`` sets the direction.
      strength: 1/s, the damping rate at the far end.
    """

    start: tuple
    end: tuple
    strength: float = 10.0

    def __post_init__(self):
        a, b = np.asarray(self.start, np.float64), np.asarray(self.end, np.float64)
        if a.shape != (3,) or b.shape != (3,) or not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            raise ValueError(f"Sponge.start and Sponge.end must be finite 3-vectors in m (got {self.start}, {self.end})")
        if np.linalg.norm(b - a) <= 0:
            raise ValueError("Sponge: end must differ from start (the zone needs a length)")
        if not (math.isfinite(self.strength) and self.strength > 0):
            raise ValueError(f"Sponge.strength must be a finite damping rate > 0 in 1/s (got {self.strength})")
        object.__setattr__(self, "start", tuple(float(c) for c in a))
        object.__setattr__(self, "end", tuple(float(c) for c in b))
        object.__setattr__(self, "strength", float(self.strength))

    @property
    def length(self) -> float:
        """m, the zone's length."""
        return float(np.linalg.norm(np.subtract(self.end, self.start)))

    def sigma(self, x):
        """Damping rate [N] 1/s at positions ``x`` [N, 3] m."""
        a = np.asarray(self.start)
        e = (np.asarray(self.end) - a) / self.length
        s = jnp.clip(((x - jnp.asarray(a, x.dtype)) @ jnp.asarray(e, x.dtype)) / self.length, 0.0, 1.0)
        return self.strength * s * s

    def apply(self, particles, dt: float):
        fluid = particles.kind == Kind.FLUID
        factor = jnp.where(fluid, 1.0 / (1.0 + self.sigma(particles.x) * dt), 1.0)
        return particles.replace(v=particles.v * factor[:, None].astype(particles.v.dtype))
