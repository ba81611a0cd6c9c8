"""Shared helpers of the stress suite (``pytest -m stress``); not a test module.

* ``finite_blocks`` / ``finite_particles``: every block / particle value of a state is finite.
* ``impact_scene``: ``scenes.block_drop``'s tank with the box thrown down at a given speed.
* ``random_block``: a random convex block of fixed topology (an affine image of a box, wedge or
  hexagonal prism), so that random scenes share one compiled step per topology.
"""

from __future__ import annotations

import math

import numpy as np

import rockjax as rj
from rockjax.blocks import ConvexPolyhedron, Motion, box, prism, slab, wedge
from rockjax.scenes.coupled import _box_tank, coupled_scene
from rockjax.sph.kernels import SUPPORT_FACTOR


def finite_blocks(state) -> bool:
    B = state.blocks
    return bool(all(np.all(np.isfinite(np.asarray(a))) for a in (B.x, B.v, B.q, B.omega)))


def finite_particles(state) -> bool:
    P = state.particles
    return bool(all(np.all(np.isfinite(np.asarray(a))) for a in (P.x, P.v, P.rho)))


def impact_scene(*, speed: float, dx: float = 0.025, box_size=(0.1, 0.1, 0.1), density: float = 2500.0,
                 tank=(0.3, 0.3), water_depth: float = 0.1, gap: float = 0.02, coupling=rj.Coupling.PENALTY,
                 c0: float | None = None, polyhedron: ConvexPolyhedron | None = None,
                 block_kwargs: dict | None = None) -> rj.Scene:
    """``block_drop``'s set-up (tank ``tank`` [m] with ``water_depth`` [m] of water, a FIXED floor
    slab under z = 0, a DYNAMIC box ``gap`` [m] above the water) with the box moving straight down
    at ``speed`` [m/s]. ``c0`` defaults to 10 x max(speed, sqrt(2 g depth)) (WCSPH practice)."""
    L, W = tank
    layers = int(math.ceil(SUPPORT_FACTOR * 1.3))
    poly = box(*box_size) if polyhedron is None else polyhedron
    half_h = float(np.max(poly.vertices[:, 2]))
    pos = np.array([0.5 * L, 0.5 * W, water_depth + gap + half_h])
    floor = slab(L, W, 0.1)
    floor_pos = floor.centroid_world + np.array([0.5 * L, 0.5 * W, 0.0])
    height = water_depth + gap + 2 * half_h + 2 * dx
    water, walls = _box_tank(dx=dx, length=L, width=W, depth=water_depth, height=height, layers=layers)
    pad = layers * dx
    c0 = 10.0 * max(speed, math.sqrt(2 * 9.81 * water_depth)) if c0 is None else c0
    vel = np.array([[0.0, 0.0, -speed], [0.0, 0.0, 0.0]])
    return coupled_scene(name="impact", dx=dx, polyhedra=[poly, floor], positions=[pos, floor_pos],
                         motion=(Motion.DYNAMIC, Motion.FIXED), block_density=[density, 2500.0],
                         friction_angle_deg=30.0, fluid_x=water, wall_x=walls, domain_lo=[-pad, -pad, -pad],
                         domain_hi=[L + pad, W + pad, height + 0.5], still_level=water_depth, coupling=coupling,
                         c0=c0, velocities=vel, block_kwargs=block_kwargs,
                         meta=dict(tank=[L, W], water_depth=water_depth, speed=speed))


_HEX = [(math.cos(a), math.sin(a)) for a in np.arange(6) * math.pi / 3]
TOPOLOGIES = {"box": lambda: box(1.0, 1.0, 1.0), "wedge": lambda: wedge(1.0, 1.0, 1.0),
              "hexprism": lambda: prism([(0.5 * c, 0.5 * s) for c, s in _HEX], 1.0)}


def random_block(rng: np.random.Generator, kind: str, size: float) -> ConvexPolyhedron:
    """A random convex block of ``TOPOLOGIES[kind]``'s combinatorics: the unit shape stretched by
    factors in [0.5, 1.5], sheared by up to 0.3, rotated at random and scaled to ``size`` [m]
    (largest extent). Affine maps keep faces planar and the vertex/face/edge counts fixed."""
    base = TOPOLOGIES[kind]()
    S = np.diag(rng.uniform(0.5, 1.5, 3))
    S[0, 1], S[0, 2], S[1, 2] = rng.uniform(-0.3, 0.3, 3)
    qr, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    pts = base.vertices @ (qr @ S).T
    pts *= size / np.max(np.ptp(pts, axis=0))
    return ConvexPolyhedron.from_vertices(pts - pts.mean(0))
