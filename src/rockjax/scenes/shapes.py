"""Host-side sampling of particles from plane-bounded regions (numpy only).

A convex region is a list of half-spaces ``n . x <= d`` (outward unit normals ``n``). Its
"clearance" ``phi(x) = min_k (d_k - n_k . x)`` is the signed distance to the boundary inside
(positive) and minus the largest violation outside. Scenes fill water where ``phi > 0`` and put
wall layers where ``-layers dx < phi <= 0`` -- on one cubic lattice, so walls and water never
overlap and inclined walls are a staircase at the lattice scale.
"""

from __future__ import annotations

import numpy as np

from .base import lattice

__all__ = ["HalfSpace", "clearance", "fill", "shell", "plane"]

HalfSpace = tuple  # (normal [3], offset d): the set n . x <= d


def plane(normal, point) -> HalfSpace:
    """The half-space ``n . (x - point) <= 0`` with ``n`` normalised (outward = ``normal``)."""
    n = np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    return (n, float(n @ np.asarray(point, float)))


def clearance(x: np.ndarray, halfspaces) -> np.ndarray:
    """phi(x) [n] m: min over half-spaces of ``d - n . x``."""
    return np.min(np.stack([d - x @ n for n, d in halfspaces], axis=1), axis=1)


def fill(lo, hi, dx: float, halfspaces, *, margin: float = 0.3) -> np.ndarray:
    """Lattice points in the box [lo, hi] with clearance > margin * dx (the water)."""
    pts = lattice(lo, hi, dx)
    return pts[clearance(pts, halfspaces) > margin * dx]


def shell(lo, hi, dx: float, halfspaces, layers: int) -> np.ndarray:
    """Lattice points in the box [lo, hi] with ``-layers dx < clearance <= 0`` (wall layers)."""
    pts = lattice(lo, hi, dx)
    phi = clearance(pts, halfspaces)
    return pts[(phi <= 0) & (phi > -layers * dx)]
