"""Rock masses: a rock volume cut into convex blocks along joint sets (Shi's block cutting, for
persistent joints), on the host in float64.

A ``JointSet`` is a family of parallel planes given as a geologist does: dip and dip direction
(degrees), spacing and the offset of one plane (m), with an optional seeded jitter of the
spacing. ``cut(domain, joint_sets)`` intersects the domain (a box, a convex block, a closed
convex mesh, or a list of such convex parts, e.g. a slope and its toe) with the half-spaces
between consecutive planes of every set: each block is the convex hull of the clipped vertex
set, so its half-edge geometry is the same ``ConvexPolyhedron`` the rest of ``rockjax.blocks``
takes (``make_blocks(rock.polyhedra, positions=rock.positions)``). Blocks below ``min_volume``
(slivers where a plane grazes a corner) are dropped, and the volume lost is reported
(``RockMass.dropped_volume``), never hidden.

Conventions: x east, y north, z up; a plane of dip ``delta`` and dip direction ``alpha``
(azimuth, clockwise from north) has the upward unit normal
``n = (sin delta sin alpha, sin delta cos alpha, cos delta)``; the set's planes are
``n . x = offset + k spacing`` for all integers k (with jitter: consecutive gaps
``spacing (1 + jitter u_k)``, ``u_k`` uniform in [-1, 1) from ``seed``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional, Sequence, Union

import numpy as np

from .geometry import ConvexPolyhedron, box

__all__ = ["JointSet", "RockMass", "cut", "joint_normal", "region"]


def joint_normal(dip_deg: float, dip_direction_deg: float) -> np.ndarray:
    """[3] upward unit normal of a plane of this dip and dip direction (degrees; x east, y north)."""
    d, a = math.radians(dip_deg), math.radians(dip_direction_deg)
    return np.array([math.sin(d) * math.sin(a), math.sin(d) * math.cos(a), math.cos(d)])


@dataclasses.dataclass(frozen=True)
class JointSet:
    """A set of parallel persistent joints.

    Attributes:
        dip_deg: dip in [0, 90] degrees (0: horizontal bedding, 90: vertical).
        dip_direction_deg: dip direction (azimuth, clockwise from north = +y) in degrees.
        spacing: normal distance between consecutive joints (m), > 0.
        offset: ``n . x`` of one joint (m): where the set is anchored.
        jitter: relative spread of the gaps, in [0, 1): gap k is ``spacing (1 + jitter u_k)``.
        seed: the random seed of the jitter.
        friction_angle_deg: the joints' friction angle (degrees), or None (the material's);
            read by scene builders that give joints their own friction.
    """

    dip_deg: float
    dip_direction_deg: float
    spacing: float
    offset: float = 0.0
    jitter: float = 0.0
    seed: int = 0
    friction_angle_deg: Optional[float] = None

    def __post_init__(self):
        for name, lo, hi in (("dip_deg", 0.0, 90.0), ("dip_direction_deg", -360.0, 360.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"JointSet.{name} must be a finite angle in [{lo:g}, {hi:g}] degrees (got {v!r})")
        if not (isinstance(self.spacing, (int, float)) and math.isfinite(self.spacing) and self.spacing > 0):
            raise ValueError(f"JointSet.spacing must be a positive length in m (got {self.spacing!r})")
        if not (isinstance(self.offset, (int, float)) and math.isfinite(self.offset)):
            raise ValueError(f"JointSet.offset must be a finite length in m (got {self.offset!r})")
        if not (isinstance(self.jitter, (int, float)) and 0.0 <= self.jitter < 1.0):
            raise ValueError(f"JointSet.jitter must be in [0, 1) (got {self.jitter!r})")
        f = self.friction_angle_deg
        if f is not None and not (isinstance(f, (int, float)) and 0.0 <= f < 90.0):
            raise ValueError(f"JointSet.friction_angle_deg must be in [0, 90) degrees or None (got {f!r})")

    @property
    def normal(self) -> np.ndarray:
        """[3] the joints' upward unit normal."""
        return joint_normal(self.dip_deg, self.dip_direction_deg)

    def offsets(self, lo: float, hi: float) -> np.ndarray:
        """The planes' ``n . x`` values strictly inside ``(lo, hi)`` (m), ascending."""
        if self.jitter == 0.0:
            k0, k1 = math.floor((lo - self.offset) / self.spacing), math.ceil((hi - self.offset) / self.spacing)
            d = self.offset + self.spacing * np.arange(k0, k1 + 1)
        else:
            # gaps drawn outwards from the anchor, the same for every range (seeded per side)
            n_up = max(0, math.ceil((hi - self.offset) / (self.spacing * (1 - self.jitter)))) + 1
            n_dn = max(0, math.ceil((self.offset - lo) / (self.spacing * (1 - self.jitter)))) + 1
            up = np.random.default_rng([self.seed, 1]).uniform(-1.0, 1.0, n_up)
            dn = np.random.default_rng([self.seed, 2]).uniform(-1.0, 1.0, n_dn)
            d = np.concatenate([self.offset - np.cumsum(self.spacing * (1 + self.jitter * dn))[::-1], [self.offset],
                                self.offset + np.cumsum(self.spacing * (1 + self.jitter * up))])
        return d[(d > lo) & (d < hi)]


@dataclasses.dataclass(frozen=True)
class RockMass:
    """Blocks cut from a domain (``cut``).

    Attributes:
        polyhedra: the blocks (``ConvexPolyhedron``, body frame about the centroid).
        positions: [B, 3] their centroids (m), in the domain's frame.
        volumes: [B] m^3.
        domain_volume: the uncut domain's volume (m^3).
        dropped: how many slivers below ``min_volume`` were dropped.
        dropped_volume: their total volume (m^3): ``volumes.sum() + dropped_volume ==
            domain_volume`` to round-off.
    """

    polyhedra: tuple
    positions: np.ndarray
    volumes: np.ndarray
    domain_volume: float
    dropped: int
    dropped_volume: float

    @property
    def n_blocks(self) -> int:
        return len(self.polyhedra)

    def size_distribution(self) -> dict:
        """The blocks' equivalent diameters ``(6 V / pi)^(1/3)`` (m): count, min, the 10/50/90 %
        quantiles, max; and the dropped volume as a fraction of the domain's."""
        d = np.cbrt(6.0 * self.volumes / math.pi)
        q = np.quantile(d, [0.1, 0.5, 0.9]) if len(d) else [math.nan] * 3
        return {"blocks": self.n_blocks, "d_min_m": float(d.min()) if len(d) else math.nan,
                "d10_m": float(q[0]), "d50_m": float(q[1]), "d90_m": float(q[2]),
                "d_max_m": float(d.max()) if len(d) else math.nan,
                "dropped": self.dropped, "dropped_volume_fraction": self.dropped_volume / self.domain_volume}


Domain = Union[ConvexPolyhedron, tuple, Sequence]


def _domain_parts(domain) -> list[np.ndarray]:
    """The domain as a list of convex parts, each its [V, 3] world vertices."""
    if isinstance(domain, ConvexPolyhedron):
        return [domain.vertices + domain.centroid_world]
    if hasattr(domain, "vertices") and hasattr(domain, "faces"):  # a trimesh mesh
        try:
            poly = ConvexPolyhedron.from_trimesh(domain)
        except ValueError as e:
            raise ValueError(f"domain: the mesh is not a closed convex solid ({e}); give a list of convex parts "
                             f"(e.g. the slope and its toe)") from e
        return [poly.vertices + poly.centroid_world]
    if isinstance(domain, tuple) and len(domain) == 2 and np.shape(domain[0]) == (3,):
        lo, hi = np.asarray(domain[0], float), np.asarray(domain[1], float)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
            raise ValueError(f"domain: a box (lo, hi) needs finite corners with hi > lo on every axis (got {domain})")
        b = box(*(hi - lo))
        return [b.vertices + 0.5 * (lo + hi)]
    if isinstance(domain, (list, tuple)) and domain:
        parts = []
        for i, d in enumerate(domain):
            try:
                parts += _domain_parts(d)
            except ValueError as e:
                raise ValueError(f"domain[{i}]: {e}") from e
        return parts
    raise ValueError(f"domain must be a box (lo, hi), a ConvexPolyhedron, a closed convex trimesh mesh or a "
                     f"list of those (got {type(domain).__name__})")


def _split(verts: np.ndarray, edges: np.ndarray, n: np.ndarray, d: float, eps: float):
    """The vertex sets of the two sides of ``n . x = d`` of a convex polyhedron (world vertices,
    edges as vertex pairs), or None when the plane misses it (within ``eps``)."""
    s = verts @ n - d
    s = np.where(np.abs(s) <= eps, 0.0, s)  # a vertex within eps of the plane lies on it
    if s.min() >= 0.0 or s.max() <= 0.0:
        return None
    a, b = edges[:, 0], edges[:, 1]
    crossing = (s[a] * s[b]) < 0.0
    t = s[a[crossing]] / (s[a[crossing]] - s[b[crossing]])
    cuts = verts[a[crossing]] + t[:, None] * (verts[b[crossing]] - verts[a[crossing]])
    on = verts[s == 0.0]
    below = np.concatenate([verts[s < 0.0], on, cuts])
    above = np.concatenate([verts[s > 0.0], on, cuts])
    return below, above


def _edges_of(poly: ConvexPolyhedron) -> np.ndarray:
    return np.asarray(poly.edges)


def region(lo, hi, planes=()) -> ConvexPolyhedron:
    """The convex region ``lo <= x <= hi`` ([3] each, m) where also ``n . (x - point) <= 0`` for
    every ``(point, normal)`` of ``planes`` (the normal points out of the region): a rock mass's
    domain such as a slope above its sliding plane. ValueError when the planes leave nothing."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    if not (lo.shape == hi.shape == (3,) and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
        raise ValueError(f"region: lo, hi must be finite [3] corners with hi > lo on every axis (got {lo}, {hi})")
    b = box(*(hi - lo))
    poly = ConvexPolyhedron.from_vertices(b.vertices + 0.5 * (lo + hi))
    for k, (point, normal) in enumerate(planes):
        n = np.asarray(normal, float)
        if not (n.shape == (3,) and np.linalg.norm(n) > 0):
            raise ValueError(f"region: planes[{k}].normal must be a non-zero [3] vector (got {normal})")
        n = n / np.linalg.norm(n)
        d = float(n @ np.asarray(point, float))
        w = poly.vertices + poly.centroid_world
        size = 2.0 * poly.bounding_radius
        if np.all(w @ n - d >= -1e-9 * size):
            raise ValueError(f"region: planes[{k}] (point {list(point)}, normal {list(normal)}) leaves nothing of "
                             f"the box; the normal points out of the region")
        halves = _split(w, _edges_of(poly), n, d, 1e-9 * size)
        if halves is not None:
            poly = ConvexPolyhedron.from_vertices(halves[0], angle_tol=0.0)
    return poly


def cut(domain: Domain, joint_sets: Sequence[JointSet], *, min_volume: Optional[float] = None) -> RockMass:
    """Cut ``domain`` into convex blocks along every plane of ``joint_sets`` (persistent joints).

    Args:
        domain: a box ``(lo, hi)`` ([3] each, m), a ``ConvexPolyhedron`` (placed at its
            ``centroid_world``), a closed convex ``trimesh.Trimesh``, or a list of those (a
            non-convex volume as convex parts; the parts are cut independently).
        joint_sets: the sets (``JointSet``), cut in order.
        min_volume: blocks smaller than this (m^3) are dropped and counted in
            ``RockMass.dropped_volume``; default 1e-3 x the cube of the smallest spacing.

    Returns:
        ``RockMass``: the blocks (polyhedra, centroids, volumes) and what was dropped.

    Raises:
        ValueError: a domain that is not a box / convex solid, a joint set that is not a
            ``JointSet``, a negative ``min_volume``.
    """
    sets = list(joint_sets)
    for i, js in enumerate(sets):
        if not isinstance(js, JointSet):
            raise ValueError(f"joint_sets[{i}] is {type(js).__name__}; give rockjax.blocks.cutting.JointSet values")
    if min_volume is None:
        min_volume = 1e-3 * min((js.spacing for js in sets), default=1.0) ** 3
    if not (math.isfinite(min_volume) and min_volume >= 0):
        raise ValueError(f"min_volume must be a finite volume >= 0 in m^3 (got {min_volume!r})")
    pieces = []
    domain_volume = 0.0
    for verts in _domain_parts(domain):
        poly = ConvexPolyhedron.from_vertices(verts)
        domain_volume += poly.volume
        pieces.append(poly)
    for js in sets:
        n = js.normal
        out = []
        for poly in pieces:
            work = [poly]
            w = poly.vertices + poly.centroid_world
            proj = w @ n
            size = 2.0 * poly.bounding_radius
            for d in js.offsets(float(proj.min()), float(proj.max())):
                nxt = []
                for p in work:
                    pw = p.vertices + p.centroid_world
                    halves = _split(pw, _edges_of(p), n, float(d), 1e-9 * size)
                    if halves is None:
                        nxt.append(p)
                        continue
                    for half in halves:
                        nxt.append(ConvexPolyhedron.from_vertices(half, angle_tol=0.0))
                work = nxt
            out += work
        pieces = out
    keep = [p for p in pieces if p.volume >= min_volume]
    lost = [p.volume for p in pieces if p.volume < min_volume]
    return RockMass(polyhedra=tuple(keep), positions=np.array([p.centroid_world for p in keep]).reshape(-1, 3),
                    volumes=np.array([p.volume for p in keep]), domain_volume=float(domain_volume),
                    dropped=len(lost), dropped_volume=float(sum(lost)))
