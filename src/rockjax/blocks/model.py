"""The block model: static ``BlockConfig``, calibratable ``BlockParams``, ``BlockShape`` / ``BlockState``.

This module owns the data layout of the explicit 3D-DDA rock blocks (the contact history a
state carries from step to step included, :class:`ContactHistory`; the config's buffer sizes
:class:`BlockCapacities` and speed settings :class:`BlockTuning`) and the host-side scene builder
:func:`make_blocks` (validation of every input, defaults), split by concern into
:func:`block_geometry` (shapes, poses, motions), :class:`BlockMaterial` (-> ``BlockParams``),
:func:`block_capacities`, :func:`block_tuning` and :func:`block_config`; the stable time step of
seed Eq 8, plus small pure helpers on the state (world vertices and planes, mass, inertia,
energies).  Contacts live in ``fcp`` / ``contact`` / ``broadphase``, the contact law in ``laws``;
the time step in ``integrate``.

Units: SI (m, kg, s, N, rad).  z points up.  Orientation ``q = (w, x, y, z)`` maps body to world.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Sequence
from typing import Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..types import _pytree_dataclass, float_dtype
from .geometry import ConvexPolyhedron, pack
from .laws import ContactLaw, PenaltyCoulomb
from .rotation import quat_matrix

__all__ = [
    "Motion",
    "check_block_params",
    "initial_overlaps",
    "Broadphase",
    "BlockConfig",
    "BlockCapacities",
    "BlockTuning",
    "auto_pair_segment",
    "BlockParams",
    "BlockShape",
    "BlockState",
    "ContactHistory",
    "make_blocks",
    "BlockMaterial",
    "BlockGeometry",
    "block_geometry",
    "block_capacities",
    "block_tuning",
    "block_config",
    "stable_dt",
    "stable_dt_jax",
    "world_vertices",
    "world_planes",
    "block_mass",
    "world_inertia",
    "energies",
    "resize_pairs",
    "fit_history",
]


class Motion(enum.Enum):
    """How a block moves."""

    DYNAMIC = "dynamic"  #: integrated from contact, gravity and external forces
    FIXED = "fixed"  #: never moves (slopes, floors, tanks); costs nothing beyond its contacts
    PRESCRIBED = "prescribed"  #: piston: x(t) = x0 + dir * S/2 * sin(2 pi t / T), orientation fixed


class Broadphase(enum.Enum):
    """How candidate block pairs are found."""

    ALL_PAIRS = "all_pairs"  #: every pair with a dynamic block, AABB test (few blocks)
    GRID = "grid"  #: uniform grid built by sorting (many blocks); large blocks tested against all


def _check_int(cls: str, name: str, value, lo: int) -> int:
    """``value`` as an int >= ``lo``, or a ValueError naming ``cls.name``."""
    import numbers

    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or value < lo:
        raise ValueError(f"{cls}.{name} must be an integer >= {lo} (got {value!r})")
    return int(value)


@dataclasses.dataclass(frozen=True)
class BlockCapacities:
    """Sizes of the block side's buffers (static): ``make_blocks`` sizes them from the blocks, a
    step sets an overflow status bit when one is too small, and the host driver grows it and
    reruns the chunk (``driver._grow``). Nothing is dropped silently; a size changes the shapes a
    step traces (so its time and memory), never which contacts are found. Read them on a
    ``BlockConfig`` under their old names (``pair_capacity``, ``grid_cell_capacity``,
    ``law_slots``, ...); change them with ``BlockConfig.grown(...)``.

    Attributes:
      pairs: P, the candidate-pair buffer (``BlockConfig.pair_capacity``); more overlapping AABB
        pairs set ``Status.CONTACT_OVERFLOW`` (the driver doubles it, rounded up to 8;
        :func:`resize_pairs` reshapes the state).
      cell_blocks: most blocks per broad-phase grid cell (GRID; ``BlockConfig.grid_cell_capacity``);
        more set ``Status.BLOCK_CELL_OVERFLOW`` (the driver doubles it).
      joint_patch_points: the most points one pair's joint patch is built from: its active contact
        points are gathered into this many slots before the O(slots^2) hull (a box pair has up to
        16; ``contact_slots`` is 81). More set ``Status.JOINT_PATCH_OVERFLOW`` (doubled). >= 3.
      law_slots: the contact law runs over this many slots per pair, into which the pair's active
        contact points are gathered (in slot order); the shear history is kept per law slot with
        the point's contact feature (``ContactHistory.contact_feature``) and follows the feature
        from step to step: a box pair has up to 16 points (of its 81 ``contact_slots``;
        ``make_blocks`` sets :func:`face_contact_points`). More set
        ``Status.CONTACT_POINT_OVERFLOW`` (doubled, at most ``contact_slots``). 0, or >=
        ``contact_slots``: the law runs over every slot (``BlockConfig.history_slots``).
      crossing_edges: the edge-edge crossings of a pair are sought among at most this many edges
        of each block: those with a part inside the other block (a box on a box has 4 each, 8 at
        most), gathered per pair, so a pair has ``crossing_edges^2`` crossing slots instead of
        ``max_edges^2`` (144 for boxes, ~900 for 12-vertex rocks). A block with more such edges
        sets ``Status.CROSSING_EDGE_OVERFLOW`` (doubled). 0, or >= ``max_edges``: every edge.
      support_edges: each FCP round builds its edge candidates (seed types c, d) from at most this
        many edge directions touching each block's support set, gathered per pair: a face's
        edges and those leaving its vertices, 12-19 of a 12-vertex rock's ~30 (14 on average)
        (``make_blocks`` sets the most any face of the blocks has,
        ``ConvexPolyhedron.support_directions``). A support set touching more (near-coplanar
        faces within round-off) sets ``Status.SUPPORT_EDGE_OVERFLOW`` (doubled). 0, or >= the
        blocks' edge directions: every direction (no gathering).
      fcp_crosses: with ``support_edges`` gathering, the ka x kb cross products of the directions
        touching the two support sets (seed type c) are enumerated into this many slots per round
        instead of ``support_edges^2`` (the same valid crosses in the same order, so the same
        plane). ``make_blocks`` sets 128 where ``support_edges^2`` is more: measured on a settled
        100-rock pile (12-vertex rocks, ``support_edges`` 19: 361 slots), 55 crosses on average and
        126 at most; a plane's generic support-set pairs, a face against a vertex (a face normal)
        and an edge against an edge (an edge cross), give at most the product of the directions
        touching each (``ConvexPolyhedron.support_directions``; averages over those rocks 14.4 x
        6.8 and 11.7 x 11.7, maxima 19 x 9 and 15 x 15). A round with more sets
        ``Status.FCP_CROSS_OVERFLOW`` (doubled, at most ``support_edges^2``). 0, or >=
        ``support_edges^2``: every slot. 128 instead of 361: 1.26x on the 100-rock pile (1.34x in
        an earlier A/B); on a 10-rock pile (one or two evaluated pairs a step) 128 instead of 256:
        0.92x (best of three, medians equal) (``bench_blocks.py --ab-fcp-crosses``, RESULTS.md).

    Raises:
      ValueError: naming ``BlockCapacities.<field>`` when a size is not an integer in range.
    """

    pairs: int
    cell_blocks: int = 32
    joint_patch_points: int = 32
    law_slots: int = 32
    crossing_edges: int = 8
    support_edges: int = 0
    fcp_crosses: int = 0

    #: the least value of each field
    _LOWEST = (("pairs", 1), ("cell_blocks", 1), ("joint_patch_points", 3), ("law_slots", 0),
               ("crossing_edges", 0), ("support_edges", 0), ("fcp_crosses", 0))

    def __post_init__(self):
        for name, lo in self._LOWEST:
            object.__setattr__(self, name, _check_int("BlockCapacities", name, getattr(self, name), lo))

    def replace(self, **changes) -> "BlockCapacities":
        return dataclasses.replace(self, **changes)


@dataclasses.dataclass(frozen=True)
class BlockTuning:
    """Speed settings of the block contacts (static): they change the time and memory of a step,
    not its results beyond float rounding (the same contacts, forces and history). Read them on a
    ``BlockConfig`` under their old names (``pair_segment``, ``skip_separated``); change them with
    ``BlockConfig.tuned(...)``. The particle side's counterpart is ``rockjax.tuning.Tuning``.

    Attributes:
      pair_segment: the narrow phase (FCP and contact points) runs over the pair buffer in
        segments of this many slots and skips a segment holding no pair to evaluate (the broad
        phase compacts the candidate pairs at the front of the buffer, and with
        ``skip_separated`` the pairs to evaluate are gathered before the separated ones, so a
        half-empty buffer costs about half). 0, or >= the pair capacity: one pass over every slot.
        None (default): :func:`auto_pair_segment` of the pair capacity and the blocks' edge
        directions: for boxes and prisms the buffer in 8 segments, for rocks 16 slots. Why: a
        live segment has a fixed cost on a CPU (the narrow phase's some hundred operations,
        dispatched once per segment, ~0.1-1 ms) besides its pairs' arithmetic (~5 us a box
        pair, ~35 us a rock pair), a skipped one ~15 us: a 1000-box pile (9001 slots, 1000
        evaluated) wants one segment of them all, a 100-rock pile (~30 evaluated) segments of
        16 (RESULTS.md, "pair segments").
      skip_separated: a pair whose stored common plane still separates it by more than the
        contact tolerances can reach across (``contact.separated_pairs``; for a 12-vertex rock
        ~1e-4 of its size, plus the joint aperture with joint water) is not evaluated that step: no
        contact points, zero forces, its plane kept. Such pairs are gathered behind the others,
        so segments of them are skipped (a settled rock pile: ~100 of its ~130 candidate pairs).
        False: every candidate pair runs the FCP every step.

    Raises:
      ValueError: naming ``BlockTuning.<field>`` for a bad value.
    """

    pair_segment: Optional[int] = None
    skip_separated: bool = True

    def __post_init__(self):
        if self.pair_segment is not None:
            object.__setattr__(self, "pair_segment", _check_int("BlockTuning", "pair_segment", self.pair_segment, 0))
        if not isinstance(self.skip_separated, (bool, np.bool_)):
            raise ValueError(f"BlockTuning.skip_separated must be True or False (got {self.skip_separated!r})")
        object.__setattr__(self, "skip_separated", bool(self.skip_separated))

    def replace(self, **changes) -> "BlockTuning":
        return dataclasses.replace(self, **changes)


@dataclasses.dataclass(frozen=True)
class BlockConfig:
    """Static description of the blocks (hashable; a static argument of ``jax.jit``).

    The physics and numerics of the contacts are its own fields; the buffer sizes the driver grows
    are ``capacities`` (:class:`BlockCapacities`) and the speed-only settings ``tuning``
    (:class:`BlockTuning`). Both are read through properties of their old names
    (``pair_capacity``, ``grid_cell_capacity``, ``joint_patch_points``, ``law_slots``,
    ``crossing_edges``, ``support_edges``, ``fcp_crosses``; ``pair_segment``, ``skip_separated``)
    and changed with :meth:`grown` / :meth:`tuned`.

    Attributes:
      n_blocks: B.
      max_vertices, max_faces, max_halfedges, max_edges: padded sizes V, F, E, nE.
      max_valence: K, the most edges at one vertex (padding of the vertex stars used by FCP).
      max_directions: nD, the padded edge-direction count (``BlockShape.direction_edge``; 0:
        unknown, taken as many).
      motion: per-block :class:`Motion`.
      capacities: :class:`BlockCapacities`, the buffers the driver grows on an overflow bit.
      fcp_iterations: fixed number of Fast Common Plane iterations per pair and step when a pair
        starts cold (no plane of its own from the previous step; default 1: from a cold start one
        iteration is exact on random overlaps, ``bench_blocks.py``'s accuracy table).
      fcp_warm_iterations: the iterations instead when every candidate pair of a narrow-phase
        segment (``pair_segment`` pairs, or the whole buffer) carries its plane from the previous
        step (default 0: the FCP's last, differentiable candidate round from that plane is then
        already exact: random overlaps with the pose moved 1 % of the block size and turned 0.01
        rad since the stored plane, 150/150 exact; a 100-rock pile within 2e-15 m of 8 iterations
        over 5000 steps; ``experiments/fcp_iterations_pile.py``). The choice is a ``lax.cond`` per
        segment: under ``jax.vmap`` both counts run. Neither is run
        for blocks with at most 8 edge directions each (boxes, prisms of up to 7 sides:
        ``fcp.sat_start``) without joint water: their start holds every separating axis, so an
        overlapping pair's plane is exact from the start.
      broadphase: :class:`Broadphase`.
      prescribed_direction: per block unit 3-vector of the piston motion ((0,0,0) if not PRESCRIBED).
      prescribed_ramp: s, soft start of the piston: the amplitude grows as
        ``(1 - cos(pi t / ramp)) / 2`` over the first ``ramp`` seconds (0: full amplitude at t = 0).
      paths: per block a ``paths.Path`` (a table translation, a flap rotation) or None; a
        PRESCRIBED block with a path follows it instead of the sinusoid of
        ``prescribed_direction`` (empty: no paths).
      path_stroke: m, the stroke the paths were built with: each path's motion is scaled by
        ``BlockParams.stroke / path_stroke`` (differentiable w.r.t. the stroke).
      locked: per block a 6-tuple of bools (x, y, z, rx, ry, rz: world translations and rotations)
        that are held at zero velocity, or empty (nothing locked): a guided DYNAMIC block (a slide
        on a flume's rails moves in its vertical plane; ``make_blocks(locked=...)``).
      aabb_margin: m, added to every AABB half-size in the broad phase.
      grid_cell_size: m, uniform-grid cell (GRID; default 1.5 x median block size, seed section 2).
      large_blocks: blocks bigger than a grid cell (GRID): tested against every block directly.
      edge_contacts: also use edge-edge crossings as contact points (default True).
      inside_tolerance: relative (to the block's bounding radius) tolerance of the
        point-in-block test that decides which vertices / crossings are contact points.
      penetration_limit: depth / min(bounding radius) above which BLOCK_PENETRATION is set.
      joint_water: the contact patches carry the hydrostatic pressure of a still water level
        (``BlockParams.joint_water_level``; module ``joint_water``). Off: nothing is traced.
      joint_aperture: m, faces closer than this form a joint (its load fades out as the gap opens
        from 0 to this); 0: only the penetrating contact's patch, with no fade.
      joint_fade_points: with ``joint_aperture`` > 0, each point of the near patch also fades in:
        it moves from the patch's weighted centre to its place as it closes from ``aperture / 2``
        to ``aperture / 4`` (``smoothstep`` weights), so the patch's area and load are continuous
        when a point enters or leaves the joint (otherwise they jump: a new corner adds its area at
        once). For gradients over whole events (``calibrate.smooth_config``). Default off.
      tuning: :class:`BlockTuning`, the settings that change only speed.
      law: the contact law (``laws.ContactLaw``; default ``laws.PenaltyCoulomb()``): the maths of
        the force at a contact point, a static choice; its constants are ``BlockParams``.
    """

    n_blocks: int
    max_vertices: int
    max_faces: int
    max_halfedges: int
    max_edges: int
    max_valence: int
    motion: tuple
    capacities: BlockCapacities
    fcp_iterations: int = 1
    broadphase: Broadphase = Broadphase.ALL_PAIRS
    prescribed_direction: tuple = ()
    prescribed_ramp: float = 0.0
    paths: tuple = ()
    path_stroke: float = 0.0
    locked: tuple = ()
    aabb_margin: float = 0.0
    grid_cell_size: float = 1.0
    large_blocks: tuple = ()
    edge_contacts: bool = True
    inside_tolerance: float = 1e-4
    penetration_limit: float = 0.1
    joint_water: bool = False
    joint_aperture: float = 0.0
    joint_fade_points: bool = False
    tuning: BlockTuning = BlockTuning()
    max_directions: int = 0
    law: ContactLaw = PenaltyCoulomb()
    fcp_warm_iterations: int = 0

    def __post_init__(self):
        if not isinstance(self.law, ContactLaw):
            raise ValueError(f"BlockConfig.law must be a rockjax.blocks.laws.ContactLaw (e.g. PenaltyCoulomb()), "
                             f"got {self.law!r}")
        if len(self.motion) != self.n_blocks:
            raise ValueError(f"BlockConfig.motion has {len(self.motion)} entries, n_blocks={self.n_blocks}")
        if not isinstance(self.capacities, BlockCapacities):
            raise ValueError(f"BlockConfig.capacities must be a rockjax.blocks.BlockCapacities (got {self.capacities!r})")
        if not isinstance(self.tuning, BlockTuning):
            raise ValueError(f"BlockConfig.tuning must be a rockjax.blocks.BlockTuning (got {self.tuning!r})")
        if self.fcp_iterations < 0:
            raise ValueError("BlockConfig.fcp_iterations must be >= 0")
        if self.fcp_warm_iterations < 0:
            raise ValueError("BlockConfig.fcp_warm_iterations must be >= 0")
        if not (self.prescribed_ramp >= 0.0 and math.isfinite(self.prescribed_ramp)):
            raise ValueError(f"BlockConfig.prescribed_ramp must be a finite time >= 0 s (got {self.prescribed_ramp})")
        if self.paths:
            from .paths import Path

            if len(self.paths) != self.n_blocks:
                raise ValueError(f"BlockConfig.paths has {len(self.paths)} entries, n_blocks={self.n_blocks}")
            for i, (p, m) in enumerate(zip(self.paths, self.motion)):
                if p is not None and (not isinstance(p, Path) or m != Motion.PRESCRIBED):
                    raise ValueError(f"BlockConfig.paths[{i}] must be None or a rockjax.blocks.paths.Path of a "
                                     f"PRESCRIBED block (got {type(p).__name__} for a {m.name} block)")
            if not (math.isfinite(self.path_stroke) and self.path_stroke > 0):
                raise ValueError(f"BlockConfig.path_stroke must be > 0 m with paths (got {self.path_stroke})")
        if self.locked:
            if len(self.locked) != self.n_blocks or not all(len(r) == 6 for r in self.locked):
                raise ValueError(f"BlockConfig.locked must hold one 6-tuple of bools per block ({self.n_blocks}), "
                                 f"got {self.locked!r}")
            for i, (r, m) in enumerate(zip(self.locked, self.motion)):
                if any(r) and m != Motion.DYNAMIC:
                    raise ValueError(f"BlockConfig.locked[{i}]: block {i} is {m.name}; only DYNAMIC blocks are guided")

    def replace(self, **changes) -> "BlockConfig":
        """This config with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def grown(self, **changes) -> "BlockConfig":
        """This config with some buffer sizes changed (:class:`BlockCapacities` fields), e.g.
        ``grown(pairs=64)``. A grown pair buffer or law slot count needs a reshaped state
        (``driver.resize``: :func:`resize_pairs`, :func:`fit_history`)."""
        return self.replace(capacities=self.capacities.replace(**changes))

    def tuned(self, **changes) -> "BlockConfig":
        """This config with some speed settings changed (:class:`BlockTuning` fields), e.g.
        ``tuned(pair_segment=0)``."""
        return self.replace(tuning=self.tuning.replace(**changes))

    # -- the buffer sizes and speed settings under their old names (read-only) --

    @property
    def pair_capacity(self) -> int:
        """P, the candidate-pair buffer (``capacities.pairs``)."""
        return self.capacities.pairs

    @property
    def grid_cell_capacity(self) -> int:
        """Most blocks per broad-phase grid cell (``capacities.cell_blocks``)."""
        return self.capacities.cell_blocks

    @property
    def joint_patch_points(self) -> int:
        """Slots a joint patch is built from (``capacities.joint_patch_points``)."""
        return self.capacities.joint_patch_points

    @property
    def law_slots(self) -> int:
        """Slots the contact law runs over per pair (``capacities.law_slots``; 0: every slot)."""
        return self.capacities.law_slots

    @property
    def crossing_edges(self) -> int:
        """Edges per block among which crossings are sought (``capacities.crossing_edges``; 0: all)."""
        return self.capacities.crossing_edges

    @property
    def support_edges(self) -> int:
        """Edge directions gathered per support set (``capacities.support_edges``; 0: all)."""
        return self.capacities.support_edges

    @property
    def fcp_crosses(self) -> int:
        """Cross-product slots per FCP round (``capacities.fcp_crosses``; 0: support_edges^2)."""
        return self.capacities.fcp_crosses

    @property
    def pair_segment(self) -> int:
        """Pair slots per narrow-phase segment (``tuning.pair_segment``, or
        :func:`auto_pair_segment` of the pair capacity when that is None; 0: one pass)."""
        seg = self.tuning.pair_segment
        if seg is not None:
            return seg
        from .fcp import sat_start  # (fcp imports nothing of this module's)
        return auto_pair_segment(self.pair_capacity, simple=0 < self.max_directions and sat_start(self.max_directions))

    @property
    def skip_separated(self) -> bool:
        """Whether pairs still separated by their stored plane skip the narrow phase
        (``tuning.skip_separated``)."""
        return self.tuning.skip_separated

    @property
    def dynamic(self) -> tuple:
        """Indices of DYNAMIC blocks."""
        return tuple(i for i, m in enumerate(self.motion) if m == Motion.DYNAMIC)

    @property
    def prescribed(self) -> tuple:
        """Indices of PRESCRIBED blocks."""
        return tuple(i for i, m in enumerate(self.motion) if m == Motion.PRESCRIBED)

    @property
    def crossing_slots(self) -> int:
        """Edges of each block of a pair among which crossings are sought (``crossing_edges``,
        or every edge); 0 without edge contacts."""
        if not self.edge_contacts:
            return 0
        k = self.crossing_edges
        return self.max_edges if k <= 0 or k >= self.max_edges else k

    @property
    def contact_slots(self) -> int:
        """Contact slots per pair: vertices of j in i, vertices of i in j, edge x edge crossings, fallback."""
        return 2 * self.max_vertices + self.crossing_slots**2 + 1

    @property
    def history_slots(self) -> int:
        """Slots of a pair's contact law and shear history: ``law_slots``, or every contact slot."""
        k = self.law_slots
        return self.contact_slots if k <= 0 or k >= self.contact_slots else k

    @property
    def static_pairs(self) -> tuple:
        """All pairs (i < j) with at least one DYNAMIC block (the ALL_PAIRS candidates)."""
        dyn = [m == Motion.DYNAMIC for m in self.motion]
        return tuple(
            (i, j) for i in range(self.n_blocks) for j in range(i + 1, self.n_blocks) if dyn[i] or dyn[j]
        )


@_pytree_dataclass
class BlockParams:
    """Calibratable block constants (array leaves; ``jax.grad`` and ``vmap`` go through them).

    Attributes:
      density: [B] kg/m^3 (mass = density x volume; FIXED/PRESCRIBED blocks use it for nothing).
      friction_angle: [] rad, Coulomb cap ``|f_t| <= f_n tan(phi) + cohesion`` per contact point.
      cohesion: [] N per contact point (added to the Coulomb cap of a compressed point).
      tensile_strength: [] N per contact point; must be 0 (bonded joints are not implemented).
      normal_stiffness: [] N/m, penalty spring per contact point.
      shear_stiffness: [] N/m, tangential spring per contact point.
      damping_ratio: [] ratio of critical damping of a contact pair: each of its n active points
        gets ``c = 2 zeta sqrt(k m_red / n)`` with the pair's reduced mass m_red (a FIXED block
        counts as infinitely heavy), so a flat face contact has ratio zeta. The normal
        dashpot acts only while the contact closes (never pulls); the tangential one
        (``sqrt(k_s m_red)``) only while the point sticks.
      stroke: [] m, piston stroke S (PRESCRIBED blocks).
      period: [] s, piston period T (PRESCRIBED blocks).
      joint_water_level: [] m, still water level whose hydrostatic pressure the joints carry
        (height along -gravity; used when ``BlockConfig.joint_water``).
      joint_water_density: [] kg/m^3, the joint water's density (``BlockConfig.joint_water``).
    """

    density: jax.Array
    friction_angle: jax.Array
    cohesion: jax.Array
    tensile_strength: jax.Array
    normal_stiffness: jax.Array
    shear_stiffness: jax.Array
    damping_ratio: jax.Array
    stroke: jax.Array
    period: jax.Array
    joint_water_level: jax.Array
    joint_water_density: jax.Array


@_pytree_dataclass
class BlockShape:
    """Constant padded block geometry, body frame (from ``geometry.PackedBlocks``).

    Index padding is 0 (always combine with the masks).  Float padding is 0.

    Attributes:
      vertices [B,V,3] m; vertex_mask [B,V] bool;
      face_normal [B,F,3] outward unit; face_offset [B,F] m (``n.x <= d`` inside); face_mask [B,F];
      edges [B,nE,2] int32 vertex pairs; edge_mask [B,nE];
      edge_direction [B,nE] int32, the direction group of each edge; direction_edge [B,nD] int32, the
      representative edge of each direction; direction_mask [B,nD] (parallel edges share a
      direction: the FCP scores each direction once, ``geometry.ConvexPolyhedron.edge_directions``);
      vertex_direction [B,V,nD] bool: which edge directions touch each vertex (the FCP's
      support-set gathering, ``fcp.vertex_directions``; shape only, built once);
      he_vert, he_next, he_pair, he_face [B,E] int32; halfedge_mask [B,E];
      star_face [B,V,K] faces around each vertex; star_vertex [B,V,K] the other end of each edge
      leaving the vertex; star_mask [B,V,K] (from half-edge walks: seed section 4; kept for local
      queries -- the FCP itself works on support sets over ``edges``, see ``fcp``);
      volume [B] m^3; inertia_unit [B,3,3] m^5 (inertia for unit density, body frame);
      inertia_unit_inverse [B,3,3] m^-5 and inertia_unit_min [B] m^5: its inverse and least
      principal moment (shape only, built once: a step scales them by the density instead of a
      3x3 solve and an eigenvalue problem per block, ~1.5 ms a step for 1000 blocks on a CPU);
      radius [B] m (bounding radius about the centroid).
    """

    vertices: jax.Array
    vertex_mask: jax.Array
    face_normal: jax.Array
    face_offset: jax.Array
    face_mask: jax.Array
    edges: jax.Array
    edge_mask: jax.Array
    edge_direction: jax.Array
    direction_edge: jax.Array
    direction_mask: jax.Array
    vertex_direction: jax.Array
    he_vert: jax.Array
    he_next: jax.Array
    he_pair: jax.Array
    he_face: jax.Array
    halfedge_mask: jax.Array
    star_face: jax.Array
    star_vertex: jax.Array
    star_mask: jax.Array
    volume: jax.Array
    inertia_unit: jax.Array
    inertia_unit_inverse: jax.Array
    inertia_unit_min: jax.Array
    radius: jax.Array


@_pytree_dataclass
class ContactHistory:
    """What the contacts carry from one step to the next (``BlockState.history``; written by
    ``contact.contact_forces``).

    Attributes:
      pairs: [P,2] int32 candidate pairs (i < j); pair_mask: [P] bool.
      plane: [P,3] last common-plane normal per pair (from i to j), the FCP warm start;
        plane_valid: [P] bool.
      shear: [P,L,3] the contact law's history slot per law slot (world frame; ``laws``), L =
        ``BlockConfig.history_slots``: for ``PenaltyCoulomb`` the tangential spring's
        displacement (m).
      contact_feature: [P,L] int32, the contact feature of each law slot's point (-1: none): a
        vertex of j inside i (its index v), a vertex of i inside j (V + v), the crossing of edge a
        of i with edge b of j (2 V + a nE + b), the fallback point (2 V + nE^2); the history slot
        of a feature carries over to the next step wherever that feature's point is gathered.
      box_lo, box_hi: [B,3] m, each block's axis-aligned box (no margin) when the candidate
        pairs were last built (``contact_forces``: the list is kept until a box has moved by more
        than half the AABB margin; +inf / -inf before the first build).
    """

    pairs: jax.Array
    pair_mask: jax.Array
    plane: jax.Array
    plane_valid: jax.Array
    shear: jax.Array
    contact_feature: jax.Array
    box_lo: jax.Array
    box_hi: jax.Array


@_pytree_dataclass
class BlockState:
    """Block poses, velocities and contact history.

    Attributes:
      shape: :class:`BlockShape`.
      x: [B,3] m centroid.   q: [B,4] unit quaternion (w,x,y,z), body -> world.
      v: [B,3] m/s and omega: [B,3] rad/s (world frame): leapfrog mid-step velocities
        (seed Eq 6: after a step from t to t+dt they are the velocities of t+dt/2).
      x0: [B,3], q0: [B,4] reference pose of FIXED / PRESCRIBED blocks.
      history: :class:`ContactHistory`, the candidate pairs, their planes and the contact law's
        per-point history.
    """

    shape: BlockShape
    x: jax.Array
    q: jax.Array
    v: jax.Array
    omega: jax.Array
    x0: jax.Array
    q0: jax.Array
    history: ContactHistory


# ------------------------------------------------------------------------------------------
# small pure helpers
# ------------------------------------------------------------------------------------------


def _rotate(R, v):
    """[B,3,3] rotations of the [B,K,3] body vectors v: [B,K,3] (``einsum('bij,bkj->bki')`` as
    multiply-adds: as a batched dot XLA:CPU ran it as a library call, not fused with its users)."""
    return (R[:, None, :, 0] * v[..., 0, None] + R[:, None, :, 1] * v[..., 1, None]
            + R[:, None, :, 2] * v[..., 2, None])


def world_vertices(state: BlockState) -> jax.Array:
    """[B,V,3] world positions of the (padded) vertices (m); padding slots sit at the centroid."""
    return _rotate(quat_matrix(state.q), state.shape.vertices) + state.x[:, None, :]


def world_planes(state: BlockState):
    """World face planes: ``(normals [B,F,3], offsets [B,F])`` with ``n.x <= d`` inside (m)."""
    n = _rotate(quat_matrix(state.q), state.shape.face_normal)
    x = state.x[:, None, :]
    d = state.shape.face_offset + (n[..., 0] * x[..., 0] + n[..., 1] * x[..., 1] + n[..., 2] * x[..., 2])
    return n, d


def block_mass(state: BlockState, params: BlockParams) -> jax.Array:
    """[B] kg."""
    return params.density * state.shape.volume


def world_inertia(state: BlockState, params: BlockParams) -> jax.Array:
    """[B,3,3] kg m^2 inertia tensors about the centroids, world frame."""
    R = quat_matrix(state.q)
    Ib = params.density[:, None, None] * state.shape.inertia_unit
    return jnp.einsum("bij,bjk,blk->bil", R, Ib, R)


def energies(state: BlockState, params: BlockParams, gravity, config: Optional[BlockConfig] = None) -> dict:
    """Kinetic and gravitational potential energy (J) of the DYNAMIC blocks.

    ``potential = -sum m g.x`` (zero at the origin).  With ``config`` None every block counts,
    so pass ``config`` whenever FIXED / PRESCRIBED blocks exist.

    Args:
      gravity: [3] m/s^2.
    Returns:
      dict(kinetic=[] J, potential=[] J).
    """
    m = block_mass(state, params)
    if config is not None:
        dyn = jnp.asarray([mo == Motion.DYNAMIC for mo in config.motion])
    else:
        dyn = jnp.ones(m.shape, bool)
    I = world_inertia(state, params)
    ke = 0.5 * m * jnp.sum(state.v**2, -1) + 0.5 * jnp.einsum("bi,bij,bj->b", state.omega, I, state.omega)
    pe = -m * (state.x @ jnp.asarray(gravity, state.x.dtype))
    return dict(kinetic=jnp.sum(jnp.where(dyn, ke, 0.0)), potential=jnp.sum(jnp.where(dyn, pe, 0.0)))


# ------------------------------------------------------------------------------------------
# stable time step (seed Eq 8)
# ------------------------------------------------------------------------------------------


def _omega_max_sq(k, m, radius, inertia_min, n_points):
    """Upper bound of omega^2 for one block on ``n_points`` springs of stiffness ``k``.

    A point spring at distance r <= radius from the centroid sees the generalised mass
    ``1 / (1/m + r^2 / I_min)``; ``n_points`` such springs in parallel bound the largest
    eigenvalue of M^-1 K by ``n_points k (1/m + radius^2 / I_min)`` (Gershgorin).
    """
    return n_points * k * (1.0 / m + radius**2 / inertia_min)


def stable_dt_jax(config: BlockConfig, params: BlockParams, shape: BlockShape, *, safety=1.0):
    """In-jit version of :func:`stable_dt` (a [] array; inf if there is no DYNAMIC block)."""
    dyn = config.dynamic
    if not dyn:
        return jnp.asarray(jnp.inf, params.normal_stiffness.dtype)
    idx = jnp.asarray(dyn)
    m = params.density[idx] * shape.volume[idx]
    Imin = params.density[idx] * shape.inertia_unit_min[idx]
    k = jnp.maximum(params.normal_stiffness, params.shear_stiffness)
    w2 = jnp.max(_omega_max_sq(k, m, shape.radius[idx], Imin, 2 * config.max_vertices))
    z = params.damping_ratio
    return safety * 2.0 / jnp.sqrt(w2) * (jnp.sqrt(1.0 + z * z) - z)


def stable_dt(config: BlockConfig, params: BlockParams, state: BlockState, *, safety: float = 0.5) -> float:
    """Stable explicit time step of the blocks (s), host side; seed Eq 8 ``dt <= 2 / omega_max``.

    ``omega_max`` comes from the stiffest contact spring ``k = max(k_n, k_s)`` on the lightest
    (in generalised mass) DYNAMIC block: ``omega_max^2 = n k (1/m + r^2 / I_min)`` with
    ``n = 2 V`` contact points (all its vertices against a face plus as many crossings or
    vertices of the other block), r the bounding radius and I_min the smallest principal
    inertia; the dashpot lowers the limit to ``2/omega (sqrt(1+zeta^2) - zeta)``.  This bound is
    conservative (a box resting on a face uses about 1/3 of it); ``safety`` (default 0.5)
    covers several simultaneous neighbours.  The in-jit check in ``advance_blocks`` uses the
    same formula with safety 1 and sets ``Status.BLOCK_UNSTABLE`` beyond it.

    At this step a box landing flat is in contact for only 15-20 steps (omega dt = 0.13-0.18 for
    its corners' springs); the default contact law resolves its normal force over the step
    (``laws.PenaltyCoulomb.resolve_step``), so that the restitution does not depend on where in
    a step the impact falls (within 0.5 % of the closed form; with the plain force that needs
    about 1/6 of this step).

    Returns:
      dt in s (``inf`` when there is no DYNAMIC block).
    """
    return float(stable_dt_jax(config, params, state.shape, safety=safety))


# ------------------------------------------------------------------------------------------
# host builder
# ------------------------------------------------------------------------------------------


def _scalar(name, value, *, lo=None, lo_open=False, hi=None, hi_open=False, unit=""):
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number ({unit}), got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite ({unit}), got {x}")
    if lo is not None and (x < lo or (lo_open and x == lo)):
        raise ValueError(f"{name} must be {'>' if lo_open else '>='} {lo} {unit}, got {x}")
    if hi is not None and (x > hi or (hi_open and x == hi)):
        raise ValueError(f"{name} must be {'<' if hi_open else '<='} {hi} {unit}, got {x}")
    return x


def _per_block(name, value, B, width, default=None):
    if value is None:
        return default
    a = np.asarray(value, dtype=np.float64)
    want = (B, width) if width else (B,)
    if a.shape != want:
        raise ValueError(f"{name} must have shape {want} (one per block), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or inf")
    return a


def _stars(poly: ConvexPolyhedron, V: int, K: int):
    sf = np.zeros((V, K), np.int32)
    sv = np.zeros((V, K), np.int32)
    sm = np.zeros((V, K), bool)
    for v in range(poly.n_vertices):
        hes = poly.halfedges_around_vertex(v)
        sf[v, : len(hes)] = poly.he_face[hes]
        sv[v, : len(hes)] = poly.he_vert[poly.he_next[hes]]
        sm[v, : len(hes)] = True
    return sf, sv, sm


#: ``make_blocks``' default ``BlockCapacities.fcp_crosses`` (where support_edges^2 is more)
FCP_CROSSES = 128

#: the block densities accepted, kg/m^3: from balsa wood to the densest metals (rock is ~2000-3000).
#: A lighter block makes the contact springs' stable step (seed Eq 8, ~sqrt(mass)) absurdly small.
DENSITY_RANGE = (100.0, 25000.0)


def _concrete(value) -> bool:
    return not isinstance(value, jax.core.Tracer)


def check_block_params(params: "BlockParams", *, prefix: str = "Params.blocks") -> None:
    """Refuse block constants a run cannot use (host side; fields that are traced are skipped):
    non-finite values, a density outside ``DENSITY_RANGE``, a friction angle outside [0, pi/2)
    rad, negative cohesion or damping, non-positive stiffness, piston period or joint water
    density. Raises ValueError naming ``Params.blocks.<field>`` and the range expected."""
    lo, hi = DENSITY_RANGE
    rules = {  # field: (lower bound, lower bound open, upper bound, upper bound open, unit)
        "density": (lo, False, hi, False, "kg/m^3 (rock is ~2000-3000)"),
        "friction_angle": (0.0, False, math.pi / 2, True, "rad"),
        "cohesion": (0.0, False, None, False, "N per contact point"),
        "tensile_strength": (0.0, False, 0.0, False, "N (bonded joints are not implemented)"),
        "normal_stiffness": (0.0, True, None, False, "N/m"),
        "shear_stiffness": (0.0, False, None, False, "N/m"),
        "damping_ratio": (0.0, False, None, False, "(ratio of critical)"),
        "stroke": (0.0, False, None, False, "m"),
        "period": (0.0, True, None, False, "s"),
        "joint_water_level": (None, False, None, False, "m"),
        "joint_water_density": (0.0, True, None, False, "kg/m^3"),
    }
    for name, (a, a_open, b, b_open, unit) in rules.items():
        value = getattr(params, name)
        if not _concrete(value):
            continue
        x = np.asarray(value, dtype=np.float64)
        bad = ~np.isfinite(x)
        if a is not None:
            bad |= (x <= a) if a_open else (x < a)
        if b is not None:
            bad |= (x >= b) if b_open else (x > b)
        if np.any(bad):
            parts = [f"{'>' if a_open else '>='} {a:g}"] if a is not None else []
            parts += [f"{'<' if b_open else '<='} {b:g}"] if b is not None else []
            want = "finite" + (" and " + " and ".join(parts) if parts else "")
            raise ValueError(f"{prefix}.{name} must be {want} {unit} (got {x.tolist()}); set it with "
                             f"params.replace(blocks=params.blocks.replace({name}=...))")


@dataclasses.dataclass(frozen=True)
class BlockMaterial:
    """The rock's and its joints' constants as ``make_blocks`` takes them (host, SI units but
    degrees); :meth:`params` turns them into the calibratable :class:`BlockParams`.

    Attributes:
      density: kg/m^3, a number or one per block ([B]; its length is checked by :meth:`params`).
      friction_angle_deg: Coulomb friction angle (degrees), in [0, 90).
      cohesion: N per contact point (>= 0).
      tensile_strength: must be 0 (bonded joints are not implemented).
      normal_stiffness: N/m per contact point; None: ``penalty_modulus x L`` with L the median
        block size (2 x bounding radius) of the DYNAMIC blocks -- the DDA practice of a penalty
        ~ E x length.
      shear_stiffness: N/m; None: 0.4 x normal_stiffness.
      penalty_modulus: Pa (> 0), the numerical modulus behind the default normal stiffness: the
        penetration under a column of rock of height H is about ``rho g H / E``.
      damping_ratio: closing-only ratio of critical damping per contact point (>= 0).
      joint_water_level: m, height (along -gravity) of the still water whose pressure the joints
        carry (used with ``BlockConfig.joint_water``).
      joint_water_density: kg/m^3 (> 0) of that water.

    Raises:
      ValueError: naming the field (the messages ``make_blocks`` gives), when built.
    """

    density: object = 2650.0
    friction_angle_deg: float = 30.0
    cohesion: float = 0.0
    tensile_strength: float = 0.0
    normal_stiffness: Optional[float] = None
    shear_stiffness: Optional[float] = None
    penalty_modulus: float = 1e9
    damping_ratio: float = 0.2
    joint_water_level: float = 0.0
    joint_water_density: float = 1000.0

    def __post_init__(self):
        self.constants(None)  # validates every field but the density's length

    def constants(self, geometry: Optional["BlockGeometry"]) -> dict:
        """The :class:`BlockParams` fields this material sets, as host numbers: ``density`` [B]
        kg/m^3, ``friction_angle`` rad, ``cohesion``, ``tensile_strength`` N, ``normal_stiffness``,
        ``shear_stiffness`` N/m, ``damping_ratio``, ``joint_water_level`` m,
        ``joint_water_density`` kg/m^3. ``geometry`` (:class:`BlockGeometry`) gives B and the
        block size L of the default stiffness (None: only validate, L = 1 m)."""
        out = {}
        if geometry is not None:
            B = geometry.n_blocks
            dens = np.asarray(self.density, dtype=np.float64)
            if dens.ndim == 0:
                dens = np.full(B, float(dens))
            if dens.shape != (B,) or not np.all(np.isfinite(dens)) or np.any(dens <= 0):
                raise ValueError(f"density must be a positive finite number or [B={B}] array (kg/m^3), "
                                 f"got {self.density}")
            lo, hi = DENSITY_RANGE
            if np.any(dens < lo) or np.any(dens > hi):
                raise ValueError(f"density must be in [{lo:g}, {hi:g}] kg/m^3 (rock is ~2000-3000; a lighter "
                                 f"block needs an absurdly small stable step), got {self.density}")
            out["density"] = dens
        phi = _scalar("friction_angle_deg", self.friction_angle_deg, lo=0.0, hi=90.0, hi_open=True, unit="degrees")
        out["friction_angle"] = math.radians(phi)
        out["cohesion"] = _scalar("cohesion", self.cohesion, lo=0.0, unit="N per contact point")
        ten = _scalar("tensile_strength", self.tensile_strength, lo=0.0, unit="N")
        if ten != 0.0:
            raise ValueError("tensile_strength: bonded (tensile) joints are not implemented; set 0")
        out["tensile_strength"] = ten
        L = 1.0 if geometry is None else geometry.size
        E = _scalar("penalty_modulus", self.penalty_modulus, lo=0.0, lo_open=True, unit="Pa")
        kn = E * L if self.normal_stiffness is None else _scalar("normal_stiffness", self.normal_stiffness, lo=0.0,
                                                                 lo_open=True, unit="N/m")
        ks = 0.4 * kn if self.shear_stiffness is None else _scalar("shear_stiffness", self.shear_stiffness, lo=0.0,
                                                                   unit="N/m")
        out.update(normal_stiffness=kn, shear_stiffness=ks)
        out["damping_ratio"] = _scalar("damping_ratio", self.damping_ratio, lo=0.0, unit="(ratio of critical)")
        out["joint_water_level"] = _scalar("joint_water_level", self.joint_water_level, unit="m")
        out["joint_water_density"] = _scalar("joint_water_density", self.joint_water_density, lo=0.0, lo_open=True,
                                             unit="kg/m^3")
        return out

    def params(self, geometry: "BlockGeometry") -> BlockParams:
        """The :class:`BlockParams` of these blocks (the piston's stroke and period come from
        ``geometry``), in ``float_dtype()``."""
        f = float_dtype()
        values = {**self.constants(geometry), "stroke": geometry.stroke, "period": geometry.period}
        return BlockParams(**{k: jnp.asarray(values[k], f) for k in (fl.name for fl in dataclasses.fields(BlockParams))})


@dataclasses.dataclass(frozen=True, eq=False)
class BlockGeometry:
    """The blocks' shapes, initial poses and motions, validated (host; ``block_geometry`` builds
    it). The piston's stroke and period travel here (they are :class:`BlockParams`, but describe
    the motion).

    Attributes:
      polyhedra: the B :class:`ConvexPolyhedron` (body frame at the centroid).
      packed: ``geometry.PackedBlocks``, the padded tables of all of them.
      motion: B :class:`Motion`.
      positions: [B,3] m centroids.  orientations: [B,4] unit quaternions (w,x,y,z), body -> world.
      velocities: [B,3] m/s.  omegas: [B,3] rad/s (world); 0 for blocks that are not DYNAMIC.
      stroke: m, piston stroke S.  period: s, piston period T.
      prescribed_direction: [B,3] unit piston directions (0 for blocks that are not PRESCRIBED).
      prescribed_ramp: s, soft start of the piston.
      paths: per block a ``paths.Path`` or None (empty: none); see :class:`BlockConfig`.
      locked: per block a 6-tuple of bools (x, y, z, rx, ry, rz) held still (empty: none).
    """

    polyhedra: tuple
    packed: object
    motion: tuple
    positions: np.ndarray
    orientations: np.ndarray
    velocities: np.ndarray
    omegas: np.ndarray
    stroke: float
    period: float
    prescribed_direction: np.ndarray
    prescribed_ramp: float
    paths: tuple = ()
    locked: tuple = ()

    @property
    def n_blocks(self) -> int:
        return len(self.polyhedra)

    @property
    def dynamic_mask(self) -> list:
        """[B] bool, which blocks are DYNAMIC."""
        return [m == Motion.DYNAMIC for m in self.motion]

    @property
    def radius(self) -> np.ndarray:
        """[B] m, bounding radii about the centroids."""
        return np.asarray(self.packed.bounding_radius)

    @property
    def size(self) -> float:
        """L, m: the median size (2 x bounding radius) of the DYNAMIC blocks (of all, if none is)."""
        dyn, radius = self.dynamic_mask, self.radius
        sizes = 2 * radius[np.asarray(dyn)] if any(dyn) else 2 * radius
        return float(np.median(sizes))

    @property
    def n_static_pairs(self) -> int:
        """Pairs (i < j) with at least one DYNAMIC block (``BlockConfig.static_pairs``)."""
        dyn, B = self.dynamic_mask, self.n_blocks
        return sum(1 for i in range(B) for j in range(i + 1, B) if dyn[i] or dyn[j])


def block_geometry(polyhedra: Sequence[ConvexPolyhedron], *, positions=None, motion=None, orientations=None,
                   velocities=None, omegas=None, stroke: float = 0.0, period: float = 1.0,
                   prescribed_direction=None, prescribed_ramp: float = 0.0, paths=None, locked=None,
                   check_overlap: Optional[float] = None) -> BlockGeometry:
    """Validate the blocks' shapes, poses and motions (``make_blocks``' arguments of those names,
    same defaults and messages) into a :class:`BlockGeometry`. ``check_overlap``: refuse a
    DYNAMIC block that starts deeper than this fraction of the pair's smaller bounding radius
    inside another block (:func:`initial_overlaps`); None: no check."""
    polys = list(polyhedra)
    if not polys:
        raise ValueError("polyhedra: need at least one block")
    for i, p in enumerate(polys):
        if not isinstance(p, ConvexPolyhedron):
            raise ValueError(f"polyhedra[{i}] is {type(p).__name__}; build blocks with rockjax.blocks.box/"
                             "wedge/slab/ConvexPolyhedron.from_vertices")
    B = len(polys)
    if motion is None:
        motion = (Motion.DYNAMIC,) * B
    motion = tuple(motion)
    if len(motion) != B or not all(isinstance(m, Motion) for m in motion):
        raise ValueError(f"motion must be {B} rockjax.blocks.Motion values (one per block), got {motion}")
    dyn = [m == Motion.DYNAMIC for m in motion]

    packed = pack(polys)
    pos = _per_block("positions", positions, B, 3, default=np.asarray(packed.centroid_world))
    ori = _per_block("orientations", orientations, B, 4, default=np.tile([1.0, 0, 0, 0], (B, 1)))
    nq = np.linalg.norm(ori, axis=1)
    if np.any(nq < 1e-6):
        raise ValueError("orientations: every quaternion (w, x, y, z) must be non-zero")
    ori = ori / nq[:, None]
    vel = _per_block("velocities", velocities, B, 3, default=np.zeros((B, 3)))
    om = _per_block("omegas", omegas, B, 3, default=np.zeros((B, 3)))
    for name, arr in (("velocities", vel), ("omegas", om)):
        bad = [i for i in range(B) if not dyn[i] and np.any(arr[i] != 0)]
        if bad:
            raise ValueError(f"{name}: blocks {bad} are not DYNAMIC; their velocity comes from their motion, set 0")
    lock = _locked(locked, motion)
    for i, r in enumerate(lock):
        for name, arr, axes in (("velocities", vel, r[:3]), ("omegas", om, r[3:])):
            moving = [_DOF_NAMES[3 * (name == "omegas") + a] for a in range(3) if axes[a] and arr[i, a] != 0]
            if moving:
                raise ValueError(f"{name}[{i}]: block {i} is locked in {moving} but starts moving along it; "
                                 f"set that component to 0 or unlock it")

    if check_overlap is not None:
        _refuse_overlaps(polys, pos, ori, motion, limit=check_overlap)
    S = _scalar("stroke", stroke, lo=0.0, unit="m")
    T = _scalar("period", period, lo=0.0, lo_open=True, unit="s")
    ramp = _scalar("prescribed_ramp", prescribed_ramp, lo=0.0, unit="s")
    pdir = np.zeros((B, 3))
    path_list = _paths(paths, motion)
    if path_list:
        given = [p.stroke for p in path_list if p is not None]
        S = given[0] if stroke in (None, 0.0) else S
    pending = [i for i, m in enumerate(motion) if m == Motion.PRESCRIBED and not (path_list and path_list[i] is not None)]
    if pending:
        if prescribed_direction is None:
            raise ValueError("prescribed_direction: [B,3] piston directions are needed for PRESCRIBED blocks")
        pd = _per_block("prescribed_direction", prescribed_direction, B, 3)
        for i in pending:
            n = np.linalg.norm(pd[i])
            if n == 0:
                raise ValueError(f"prescribed_direction[{i}] is zero for a PRESCRIBED block")
            pdir[i] = pd[i] / n
    return BlockGeometry(polyhedra=tuple(polys), packed=packed, motion=motion, positions=pos, orientations=ori,
                         velocities=vel, omegas=om, stroke=S, period=T, prescribed_direction=pdir,
                         prescribed_ramp=ramp, paths=tuple(path_list), locked=tuple(lock))


_DOF_NAMES = ("x", "y", "z", "rx", "ry", "rz")


def _locked(locked, motion) -> list:
    """``make_blocks(locked=...)`` as a per-block list of 6-tuples of bools (empty: none locked).

    ``locked``: None; one string for every DYNAMIC block; or a list with one spec (or None) per
    block. A spec is a string of degree-of-freedom names separated by spaces or commas (in the list,
    also a sequence of names):
    ``x y z`` (world translations) and ``rx ry rz`` (world rotations), e.g. ``"y rx rz"`` keeps a
    slide in the x-z plane and stops it pitching sideways or turning."""
    if locked is None:
        return []
    B = len(motion)

    def one(spec, where):
        if spec is None:
            return (False,) * 6
        names = spec.replace(",", " ").split() if isinstance(spec, str) else list(spec)
        bad = [n for n in names if n not in _DOF_NAMES]
        if bad or not all(isinstance(n, str) for n in names):
            raise ValueError(f"{where}: unknown degrees of freedom {bad or names}; use names from {list(_DOF_NAMES)} "
                             f"(e.g. 'y rx rz' for a slide guided in the x-z plane)")
        r = tuple(n in names for n in _DOF_NAMES)
        if all(r):
            raise ValueError(f"{where}: all six degrees of freedom are locked; make the block Motion.FIXED instead")
        return r

    if isinstance(locked, str):
        r = one(locked, "locked")
        out = [r if m == Motion.DYNAMIC else (False,) * 6 for m in motion]
    else:
        specs = list(locked)
        if len(specs) != B:
            raise ValueError(f"locked: {len(specs)} entries for {B} blocks; give one spec (e.g. 'y rx rz') for every "
                             f"DYNAMIC block, or one (a spec or None) per block")
        out = [one(sp, f"locked[{i}]") for i, sp in enumerate(specs)]
        for i, (r, m) in enumerate(zip(out, motion)):
            if any(r) and m != Motion.DYNAMIC:
                raise ValueError(f"locked[{i}]: block {i} is {m.name}; only DYNAMIC blocks can be guided")
    return out if any(any(r) for r in out) else []


def _paths(paths, motion) -> list:
    """``make_blocks(paths=...)`` as a per-block list (empty: none): one ``Path`` for the only
    PRESCRIBED block, or one entry (a Path or None) per block."""
    from .paths import Path

    if paths is None:
        return []
    B = len(motion)
    pre = [i for i, m in enumerate(motion) if m == Motion.PRESCRIBED]
    if isinstance(paths, Path):
        if len(pre) != 1:
            raise ValueError(f"paths: one Path was given for {len(pre)} PRESCRIBED blocks; give a list with "
                             f"one entry (a Path or None) per block")
        out = [None] * B
        out[pre[0]] = paths
        return out
    out = list(paths)
    if len(out) != B:
        raise ValueError(f"paths: {len(out)} entries for {B} blocks; give one (a Path or None) per block")
    for i, p in enumerate(out):
        if p is not None and not isinstance(p, Path):
            raise ValueError(f"paths[{i}] is {type(p).__name__}; give a rockjax.blocks.paths.Path (Table, Flap) "
                             f"or None")
        if p is not None and motion[i] != Motion.PRESCRIBED:
            raise ValueError(f"paths[{i}]: block {i} is {motion[i].name}; only PRESCRIBED blocks follow a path")
    return out if any(p is not None for p in out) else []


def initial_overlaps(polyhedra: Sequence[ConvexPolyhedron], positions, orientations=None, motion=None) -> list:
    """``[(i, j, depth)]``: the pairs of placed blocks (at least one DYNAMIC; ``motion`` None: all
    are) that overlap, with how deep (m, ``geometry.overlap_depth``), deepest first. Host numpy;
    only the pairs whose axis-aligned boxes overlap are tested (found by a sweep along x: a
    10,000-block pile in seconds, not the B^2 / 2 pair loop)."""
    from .geometry import overlap_depth, quat_to_matrix

    B = len(polyhedra)
    if B < 2:
        return []
    pos = np.asarray(positions, float).reshape(B, 3)
    ori = np.tile([1.0, 0, 0, 0], (B, 1)) if orientations is None else np.asarray(orientations, float)
    dyn = np.ones(B, bool) if motion is None else np.array([m == Motion.DYNAMIC for m in motion])
    R = [quat_to_matrix(q) for q in ori]
    world = [np.asarray(p.vertices, float) @ R[k].T + pos[k] for k, p in enumerate(polyhedra)]
    tol = 1e-9 * max(1.0, float(np.abs(pos).max(initial=0.0)))
    lo = np.array([w.min(0) for w in world]) - tol
    hi = np.array([w.max(0) for w in world]) + tol
    order = np.argsort(lo[:, 0], kind="stable")
    end = np.searchsorted(lo[order, 0], hi[order, 0], side="right")  # sorted a meets b in (a, end[a])
    count = np.maximum(end - np.arange(B) - 1, 0)
    a = np.repeat(np.arange(B), count)
    b = a + 1 + np.arange(a.size) - np.repeat(np.cumsum(count) - count, count)
    i, j = np.minimum(order[a], order[b]), np.maximum(order[a], order[b])
    ok = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), 1) & (dyn[i] | dyn[j])
    out = []
    for i, j in zip(i[ok].tolist(), j[ok].tolist()):
        depth = overlap_depth(polyhedra[i], pos[i], R[i], polyhedra[j], pos[j], R[j])
        if depth > 0:
            out.append((i, j, depth))
    return sorted(out, key=lambda t: (-t[2], t[0], t[1]))


#: the deepest start overlap ``make_blocks`` accepts, as a fraction of the smaller block's size
#: (2 x bounding radius): the scene files' tolerance. Deeper, the contact springs hold an energy
#: k d^2 / 2 that throws the blocks apart at the first steps (1 m blocks 3 cm deep at the default
#: stiffness: ~0.5 MJ), or the first step stops on BLOCK_PENETRATION.
START_OVERLAP = 1e-3


def _refuse_overlaps(polys, pos, ori, motion, *, limit: float) -> None:
    """ValueError naming ``positions`` for the deepest pair overlapping more than ``limit`` x the
    pair's smaller block size (2 x bounding radius)."""
    for i, j, depth in initial_overlaps(polys, pos, ori, motion):
        size = 2 * min(polys[i].bounding_radius, polys[j].bounding_radius)
        if depth > limit * size:
            raise ValueError(
                f"positions: block {i} ({motion[i].name}) and block {j} ({motion[j].name}) start {depth:.3g} m "
                f"inside each other (more than {limit:g} x the smaller block's size {size:.3g} m: the contact "
                f"springs would throw them apart); move them apart (check_overlap=False builds it anyway)")


def _contact_fields(geometry: BlockGeometry, *, fcp_iterations, fcp_warm_iterations, broadphase, aabb_margin,
                    grid_cell_size,
                    edge_contacts, inside_tolerance, penetration_limit, joint_water, joint_aperture, law) -> dict:
    """The ``BlockConfig`` fields of the contact search and law (``make_blocks``' arguments of
    those names, validated, defaults resolved from the blocks' sizes; ``large_blocks`` follows
    from the grid cell)."""
    B, radius = geometry.n_blocks, geometry.radius
    if broadphase is None:
        broadphase = Broadphase.ALL_PAIRS if B <= 32 else Broadphase.GRID
    if not isinstance(broadphase, Broadphase):
        raise ValueError(f"broadphase must be a rockjax.blocks.Broadphase, got {broadphase!r}")
    it = int(fcp_iterations)
    if it < 0 or it != fcp_iterations:
        raise ValueError(f"fcp_iterations must be a non-negative integer, got {fcp_iterations}")
    warm = int(fcp_warm_iterations)
    if warm < 0 or warm != fcp_warm_iterations:
        raise ValueError(f"fcp_warm_iterations must be a non-negative integer, got {fcp_warm_iterations}")
    margin = 0.05 * float(radius.min()) if aabb_margin is None else _scalar("aabb_margin", aabb_margin, lo=0.0,
                                                                             unit="m")
    jw_ap = _scalar("joint_aperture", joint_aperture, lo=0.0, unit="m")
    if joint_water:
        margin = max(margin, jw_ap)  # pairs within the aperture must be candidates
    cell = 1.5 * float(np.median(2 * radius)) if grid_cell_size is None else _scalar(
        "grid_cell_size", grid_cell_size, lo=0.0, lo_open=True, unit="m")
    # a block whose AABB (<= 2 r + 2 margin per axis) can exceed one cell is "large"
    large = tuple(int(i) for i in np.nonzero(2 * radius + 2 * margin > cell)[0]) if broadphase == Broadphase.GRID else ()
    _scalar("inside_tolerance", inside_tolerance, lo=0.0, unit="(relative)")
    _scalar("penetration_limit", penetration_limit, lo=0.0, lo_open=True, unit="(relative)")
    if law is None:
        law = PenaltyCoulomb()
    if not isinstance(law, ContactLaw):
        raise ValueError(f"law must be a rockjax.blocks.laws.ContactLaw (e.g. PenaltyCoulomb()), got {law!r}")
    return dict(fcp_iterations=it, fcp_warm_iterations=warm, broadphase=broadphase, aabb_margin=float(margin),
                grid_cell_size=float(cell),
                large_blocks=large, edge_contacts=bool(edge_contacts), inside_tolerance=float(inside_tolerance),
                penetration_limit=float(penetration_limit), joint_water=bool(joint_water),
                joint_aperture=float(jw_ap), law=law)


def block_capacities(geometry: BlockGeometry, *, broadphase: Broadphase = Broadphase.ALL_PAIRS,
                     large_blocks: tuple = (), pair_capacity: Optional[int] = None, grid_cell_capacity: int = 32,
                     joint_patch_points: int = 32, law_slots: Optional[int] = None, crossing_edges: int = 8,
                     support_edges: Optional[int] = None, fcp_crosses: Optional[int] = None) -> BlockCapacities:
    """The :class:`BlockCapacities` of these blocks: ``make_blocks``' arguments of those names
    (same messages), with the defaults sized from the blocks: ``pair_capacity`` every candidate
    pair (ALL_PAIRS) or ``8 x n_dynamic + (#large blocks x B)`` (GRID, at most every pair);
    ``support_edges`` the most edge directions touching one face of any block; ``fcp_crosses``
    ``FCP_CROSSES`` (128) where ``support_edges^2`` is more, else 0 (every slot); ``law_slots``
    :func:`face_contact_points` of the blocks."""
    B, n_static = geometry.n_blocks, geometry.n_static_pairs
    if pair_capacity is None:
        if broadphase == Broadphase.ALL_PAIRS:
            pair_capacity = max(1, n_static)
        else:
            pair_capacity = max(1, min(n_static, 8 * sum(geometry.dynamic_mask) + len(large_blocks) * B))
    pair_capacity = int(pair_capacity)
    if pair_capacity < 1:
        raise ValueError(f"pair_capacity must be >= 1, got {pair_capacity}")
    if int(grid_cell_capacity) < 1:
        raise ValueError("grid_cell_capacity must be >= 1")
    if support_edges is None:
        support_edges = max(p.support_directions() for p in geometry.polyhedra)
    if int(support_edges) != support_edges or support_edges < 0:
        raise ValueError(f"support_edges must be a non-negative integer (0: every edge direction), got {support_edges}")
    if fcp_crosses is None:
        fcp_crosses = FCP_CROSSES if 0 < int(support_edges) and FCP_CROSSES < int(support_edges) ** 2 else 0
    if int(fcp_crosses) != fcp_crosses or fcp_crosses < 0:
        raise ValueError(f"fcp_crosses must be a non-negative integer (0: support_edges^2 slots), got {fcp_crosses}")
    if law_slots is None:
        law_slots = face_contact_points(geometry.polyhedra)
    for name, value, lo in (("joint_patch_points", joint_patch_points, 3), ("law_slots", law_slots, 0),
                            ("crossing_edges", crossing_edges, 0)):
        if int(value) < lo:  # the messages BlockConfig gave when these were its fields
            raise ValueError(f"BlockConfig.{name} must be >= {lo} (got {int(value)})")
    return BlockCapacities(pairs=pair_capacity, cell_blocks=int(grid_cell_capacity),
                           joint_patch_points=int(joint_patch_points), law_slots=int(law_slots),
                           crossing_edges=int(crossing_edges), support_edges=int(support_edges),
                           fcp_crosses=int(fcp_crosses))


def face_contact_points(polyhedra) -> int:
    """The most contact points two of these blocks have pressed face to face: ``2 (n_a + n_b)``
    for the two largest faces (n vertices each) of two different blocks -- each face's vertices
    inside the other block, and the crossings of the two boundaries (a convex polygon's edge
    crosses another convex polygon's boundary at most twice: at most ``2 min(n_a, n_b)``). Two
    boxes: 16; 12-vertex rocks (triangles) on a box floor: 14. The default ``law_slots``: a
    deeper overlap may have more points and sets ``Status.CONTACT_POINT_OVERFLOW`` (the driver
    doubles the slots and reruns the chunk); the law's history is ``law_slots`` per pair, so a
    smaller buffer is a faster step (100 rocks: 16 slots instead of 32, 1.2x)."""
    faces = sorted((max(len(p.face_vertices(f)) for f in range(p.n_faces)) for p in polyhedra), reverse=True)
    if not faces:
        return 0
    return 2 * (faces[0] + (faces[1] if len(faces) > 1 else faces[0]))


#: ``auto_pair_segment``: the pair buffer's segments for simple blocks, and the least segment
PAIR_SEGMENTS = 8
PAIR_SEGMENT_MIN = 16
#: ``auto_pair_segment``: pair buffers from this many slots on get segments of 2 x PAIR_SEGMENT_MIN
#: (blocks that are not simple)
PAIR_SEGMENT_WIDE_FROM = 256


def auto_pair_segment(pair_capacity: int, *, simple: bool) -> int:
    """The default narrow-phase segment (``BlockTuning.pair_segment`` None) for a pair buffer of
    ``pair_capacity`` slots.

    ``simple`` blocks (few edge directions, ``fcp.sat_start``: boxes, prisms; a pair's narrow
    phase ~5 us on a CPU): the buffer in ``PAIR_SEGMENTS`` (8) segments, a multiple of
    ``PAIR_SEGMENT_MIN`` (16) slots (1136 for 9001 slots, 128 for 901, 16 for up to 128): a pile
    whose every block rests on another evaluates ~1 pair per block, one live segment. Others
    (rocks: ~35 us a pair, its FCP iterating): ``PAIR_SEGMENT_MIN``, so few evaluated pairs cost
    little more than themselves; twice that from ``PAIR_SEGMENT_WIDE_FROM`` (256) slots on, where
    tens of pairs are evaluated and a segment's ~200 kernels are shared by more of them (a 100-rock
    pile, 901 slots, ~27 evaluated pairs: 32 instead of 16 ran 1.18x faster; a 10-rock pile, 55
    slots, 1-2 pairs: 0.6x). The evaluated pairs are gathered to the front; a step runs about
    ``evaluated / segment + 1`` live segments and skips the rest. The sizes against each other on
    box and rock piles: ``experiments/bench_blocks.py --ab-segments`` (RESULTS.md, "Blocks vs
    MuJoCo")."""
    if not simple:
        return PAIR_SEGMENT_MIN * (2 if pair_capacity >= PAIR_SEGMENT_WIDE_FROM else 1)
    per = -(-int(pair_capacity) // PAIR_SEGMENTS)
    return PAIR_SEGMENT_MIN * max(1, -(-per // PAIR_SEGMENT_MIN))


def block_tuning(*, pair_segment: Optional[int] = None, skip_separated: bool = True) -> BlockTuning:
    """The :class:`BlockTuning` from ``make_blocks``' arguments of those names (same messages)."""
    if pair_segment is None:
        return BlockTuning(pair_segment=None, skip_separated=bool(skip_separated))
    if int(pair_segment) < 0:  # the message BlockConfig gave when this was its field
        raise ValueError(f"BlockConfig.pair_segment must be >= 0 (got {int(pair_segment)})")
    return BlockTuning(pair_segment=int(pair_segment), skip_separated=bool(skip_separated))


def _block_shape(geometry: BlockGeometry) -> BlockShape:
    """The padded body-frame tables of the blocks (``BlockShape``) in ``float_dtype()``."""
    packed, polys = geometry.packed, geometry.polyhedra
    K = _max_valence(polys)
    stars = [_stars(p, packed.max_vertices, K) for p in polys]
    f = float_dtype()
    i32 = jnp.int32

    def idx(a):
        return jnp.asarray(np.where(np.asarray(a) < 0, 0, a), i32)

    return BlockShape(
        vertices=jnp.asarray(packed.vertices, f),
        vertex_mask=jnp.asarray(packed.vertex_mask),
        face_normal=jnp.asarray(packed.face_normal, f),
        face_offset=jnp.asarray(packed.face_offset, f),
        face_mask=jnp.asarray(packed.face_mask),
        edges=idx(packed.edges),
        edge_mask=jnp.asarray(packed.edge_mask),
        edge_direction=idx(packed.edge_direction),
        direction_edge=idx(packed.direction_edge),
        direction_mask=jnp.asarray(packed.direction_mask),
        vertex_direction=jnp.asarray(_vertex_directions(packed)),
        he_vert=idx(packed.he_vert),
        he_next=idx(packed.he_next),
        he_pair=idx(packed.he_pair),
        he_face=idx(packed.he_face),
        halfedge_mask=jnp.asarray(packed.halfedge_mask),
        star_face=jnp.asarray(np.stack([s[0] for s in stars]), i32),
        star_vertex=jnp.asarray(np.stack([s[1] for s in stars]), i32),
        star_mask=jnp.asarray(np.stack([s[2] for s in stars])),
        volume=jnp.asarray(packed.volume, f),
        inertia_unit=jnp.asarray(packed.inertia_unit_density, f),
        inertia_unit_inverse=jnp.asarray(np.linalg.inv(np.asarray(packed.inertia_unit_density, np.float64)), f),
        inertia_unit_min=jnp.asarray(np.linalg.eigvalsh(np.asarray(packed.inertia_unit_density, np.float64))[:, 0], f),
        radius=jnp.asarray(packed.bounding_radius, f),
    )


def _vertex_directions(packed) -> np.ndarray:
    """[B,V,nD] bool: vertex v of block b is an end of a (valid) edge of direction d (the table
    ``fcp.vertex_directions`` builds per block)."""
    B, V, D = packed.vertices.shape[0], packed.max_vertices, packed.max_directions
    out = np.zeros((B, V, D), bool)
    em = np.asarray(packed.edge_mask, bool)
    b, e = np.nonzero(em)
    d = np.asarray(packed.edge_direction)[b, e]
    for end in (0, 1):
        out[b, np.asarray(packed.edges)[b, e, end], d] = True
    return out


def _max_valence(polyhedra) -> int:
    """K, the most edges at one vertex of any of ``polyhedra`` (``BlockConfig.max_valence``)."""
    return max(max(len(p.halfedges_around_vertex(v)) for v in range(p.n_vertices)) for p in polyhedra)


def block_config(geometry: BlockGeometry, contact: dict, capacities: BlockCapacities,
                 tuning: BlockTuning) -> BlockConfig:
    """The :class:`BlockConfig` of ``geometry``'s blocks with the contact fields ``contact``
    (``_contact_fields``), ``capacities`` and ``tuning``."""
    packed = geometry.packed
    return BlockConfig(
        n_blocks=geometry.n_blocks,
        max_vertices=packed.max_vertices,
        max_faces=packed.max_faces,
        max_halfedges=packed.max_halfedges,
        max_edges=packed.max_edges,
        max_valence=_max_valence(geometry.polyhedra),
        max_directions=packed.max_directions,
        motion=geometry.motion,
        capacities=capacities,
        prescribed_direction=tuple(tuple(float(c) for c in r) for r in geometry.prescribed_direction),
        prescribed_ramp=float(geometry.prescribed_ramp),
        paths=tuple(geometry.paths),
        path_stroke=next((p.stroke for p in geometry.paths if p is not None), 0.0),
        locked=tuple(geometry.locked),
        tuning=tuning,
        **contact,
    )


def make_blocks(
    polyhedra: Sequence[ConvexPolyhedron],
    *,
    positions=None,
    motion=None,
    orientations=None,
    velocities=None,
    omegas=None,
    density=2650.0,
    friction_angle_deg: float = 30.0,
    cohesion: float = 0.0,
    tensile_strength: float = 0.0,
    normal_stiffness: Optional[float] = None,
    shear_stiffness: Optional[float] = None,
    penalty_modulus: float = 1e9,
    damping_ratio: float = 0.2,
    stroke: float = 0.0,
    period: float = 1.0,
    prescribed_direction=None,
    prescribed_ramp: float = 0.0,
    paths=None,
    locked=None,
    pair_capacity: Optional[int] = None,
    fcp_iterations: int = 1,
    fcp_warm_iterations: int = 0,
    broadphase: Optional[Broadphase] = None,
    aabb_margin: Optional[float] = None,
    grid_cell_size: Optional[float] = None,
    grid_cell_capacity: int = 32,
    edge_contacts: bool = True,
    inside_tolerance: float = 1e-4,
    penetration_limit: float = 0.1,
    joint_water: bool = False,
    joint_water_level: float = 0.0,
    joint_water_density: float = 1000.0,
    joint_aperture: float = 0.0,
    joint_patch_points: int = 32,
    pair_segment: Optional[int] = None,
    law_slots: Optional[int] = None,
    crossing_edges: int = 8,
    support_edges: Optional[int] = None,
    fcp_crosses: Optional[int] = None,
    skip_separated: bool = True,
    law: Optional[ContactLaw] = None,
    check_overlap: bool = True,
):
    """Build ``(BlockConfig, BlockParams, BlockState)`` from convex polyhedra, validating every input.

    Its arguments fall into four groups, each validated by one function: the shapes, poses and
    motions (with the piston's stroke and period) by :func:`block_geometry`; the rock and joint
    constants (density, friction, cohesion, stiffnesses, damping, joint water level and density)
    by :class:`BlockMaterial`, whose :meth:`BlockMaterial.params` makes the ``BlockParams``; the
    contact search and law (FCP iterations, broad phase, margins, tolerances, joint water, law) by
    ``_contact_fields``; the buffer sizes by :func:`block_capacities` (:class:`BlockCapacities`)
    and the speed settings by :func:`block_tuning` (:class:`BlockTuning`). :func:`block_config`
    assembles the ``BlockConfig``.

    Args:
      polyhedra: B :class:`ConvexPolyhedron` (body frame at the centroid).
      positions: [B,3] m centroids; default each block's ``centroid_world`` (where it was built).
      motion: B :class:`Motion` (default all DYNAMIC).
      orientations: [B,4] quaternions (w,x,y,z) body -> world (normalised here); default identity.
      velocities: [B,3] m/s; omegas: [B,3] rad/s (world); default 0.
      density: kg/m^3, scalar or [B].
      friction_angle_deg: Coulomb friction angle (degrees), in [0, 90).
      cohesion: N per contact point (>= 0).  tensile_strength: must be 0 (not implemented).
      normal_stiffness: N/m per contact point; default ``penalty_modulus x L`` with L the median
        block size (2 x bounding radius) of the DYNAMIC blocks -- the DDA practice of a
        penalty ~ E x length.  ``penalty_modulus`` (Pa, default 1e9) is a numerical modulus:
        the penetration under a column of rock of height H is about ``rho g H / E``.
      shear_stiffness: N/m; default 0.4 x normal_stiffness.
      damping_ratio: closing-only ratio of critical damping per contact point (>= 0).
      stroke, period: piston stroke (m) and period (s) of PRESCRIBED blocks.
      prescribed_direction: [B,3] piston directions (needed for PRESCRIBED blocks; normalised).
      prescribed_ramp: s, soft start of the piston (amplitude ramped up with a half cosine over
        this time; 0 = full amplitude from t = 0).
      paths: motions of any kind for PRESCRIBED blocks (``rockjax.blocks.paths``: a ``Table`` or
        ``Flap``, e.g. ``paths.solitary(...).piston()``): one Path for the only PRESCRIBED block,
        or a list with one entry (Path or None) per block; a block with a path needs no
        ``prescribed_direction``. ``stroke`` then defaults to the first path's stroke, and the
        params' stroke scales every path (``BlockConfig.path_stroke``).
      locked: degrees of freedom of DYNAMIC blocks held at zero velocity (a guided slide): one
        string for every DYNAMIC block, or a list with one spec (or None) per block; a spec names
        world translations ``x y z`` and rotations ``rx ry rz`` (a string such as ``"y rx rz"``,
        or in the list also a sequence of names). The constraint's reaction is implied: the locked velocity components are zeroed
        after each step's update (``BlockConfig.locked``).
      pair_capacity: candidate-pair buffer; default all candidate pairs (ALL_PAIRS) or
        ``8 x n_dynamic + (#large blocks x B)`` (GRID).
      fcp_iterations: Fast Common Plane iterations per step of a pair starting cold (>= 0).
      fcp_warm_iterations: those of a segment of pairs warm-started from their last planes (>= 0;
        ``BlockConfig``).
      broadphase: default ALL_PAIRS for up to 32 blocks, GRID above.
      aabb_margin: m; default 0.05 x the smallest block radius.
      grid_cell_size: m; default 1.5 x the median block size (Nezami et al. 2004).
      grid_cell_capacity: blocks per grid cell.
      edge_contacts, inside_tolerance, penetration_limit: see :class:`BlockConfig`.
      joint_water: block faces pressed together carry the hydrostatic pressure of a still water
        at ``joint_water_level`` (m, height along -gravity) of ``joint_water_density`` (kg/m^3,
        > 0); see ``blocks.joint_water``.  joint_aperture: m (>= 0), see :class:`BlockConfig`;
        the broad-phase margin is raised to it.  joint_patch_points, pair_segment, law_slots,
        crossing_edges, support_edges, fcp_crosses, skip_separated: see :class:`BlockConfig`;
        ``support_edges`` defaults to the most edge directions touching one face of any of the
        blocks, ``fcp_crosses`` to 128 (0, every slot, where ``support_edges^2`` is not more),
        ``law_slots`` to :func:`face_contact_points` (16 for boxes).
      law: the contact law (``rockjax.blocks.laws``); default ``PenaltyCoulomb()``.
      check_overlap: refuse blocks that start inside each other (at least one of them DYNAMIC)
        deeper than ``START_OVERLAP`` (1e-3) of the smaller block's size, as scene files do;
        False builds them anyway (to study how a run stops on it).

    Returns:
      ``(config, params, state)``; state arrays in float32 (float64 under ``jax_enable_x64``).

    Raises:
      ValueError: naming the field and what to change.
    """
    geometry = block_geometry(polyhedra, positions=positions, motion=motion, orientations=orientations,
                              velocities=velocities, omegas=omegas, stroke=stroke, period=period,
                              prescribed_direction=prescribed_direction, prescribed_ramp=prescribed_ramp,
                              paths=paths, locked=locked,
                              check_overlap=START_OVERLAP if check_overlap else None)
    material = BlockMaterial(density=density, friction_angle_deg=friction_angle_deg, cohesion=cohesion,
                             tensile_strength=tensile_strength, normal_stiffness=normal_stiffness,
                             shear_stiffness=shear_stiffness, penalty_modulus=penalty_modulus,
                             damping_ratio=damping_ratio, joint_water_level=joint_water_level,
                             joint_water_density=joint_water_density)
    params = material.params(geometry)
    contact = _contact_fields(geometry, fcp_iterations=fcp_iterations, fcp_warm_iterations=fcp_warm_iterations,
                              broadphase=broadphase, aabb_margin=aabb_margin,
                              grid_cell_size=grid_cell_size, edge_contacts=edge_contacts,
                              inside_tolerance=inside_tolerance, penetration_limit=penetration_limit,
                              joint_water=joint_water, joint_aperture=joint_aperture, law=law)
    capacities = block_capacities(geometry, broadphase=contact["broadphase"], large_blocks=contact["large_blocks"],
                                  pair_capacity=pair_capacity, grid_cell_capacity=grid_cell_capacity,
                                  joint_patch_points=joint_patch_points, law_slots=law_slots,
                                  crossing_edges=crossing_edges, support_edges=support_edges, fcp_crosses=fcp_crosses)
    tuning = block_tuning(pair_segment=pair_segment, skip_separated=skip_separated)
    config = block_config(geometry, contact, capacities, tuning)
    state = _initial_state(config, _block_shape(geometry), geometry.positions, geometry.orientations,
                           geometry.velocities, geometry.omegas)
    return config, params, state


def _initial_state(config: BlockConfig, shape: BlockShape, pos, ori, vel, om) -> BlockState:
    f = shape.vertices.dtype
    P, L = config.pair_capacity, config.history_slots
    pairs = np.zeros((P, 2), np.int32)
    mask = np.zeros(P, bool)
    st = np.asarray(config.static_pairs, np.int32).reshape(-1, 2)
    if config.broadphase == Broadphase.ALL_PAIRS and len(st) <= P:
        pairs[: len(st)] = st
    return BlockState(
        shape=shape,
        x=jnp.asarray(pos, f),
        q=jnp.asarray(ori, f),
        v=jnp.asarray(vel, f),
        omega=jnp.asarray(om, f),
        x0=jnp.asarray(pos, f),
        q0=jnp.asarray(ori, f),
        history=ContactHistory(
            pairs=jnp.asarray(pairs),
            pair_mask=jnp.asarray(mask),
            plane=jnp.zeros((P, 3), f),
            plane_valid=jnp.zeros(P, bool),
            shear=jnp.zeros((P, L, 3), f),
            contact_feature=jnp.full((P, L), -1, jnp.int32),
            box_lo=jnp.full((config.n_blocks, 3), jnp.inf, f),
            box_hi=jnp.full((config.n_blocks, 3), -jnp.inf, f),
        ),
    )


def resize_pairs(config: BlockConfig, state: BlockState, pair_capacity: int):
    """Host: a new config and state with a different pair buffer (after ``CONTACT_OVERFLOW``).

    The contact history (planes, shear) is dropped: call between steps, re-run the chunk.
    Returns ``(config, state)``.
    """
    pair_capacity = int(pair_capacity)
    if pair_capacity < 1:
        raise ValueError(f"pair_capacity must be >= 1, got {pair_capacity}")
    config = config.grown(pairs=pair_capacity)
    fresh = _initial_state(config, state.shape, state.x, state.q, state.v, state.omega)
    return config, fresh.replace(x0=state.x0, q0=state.q0)


def fit_history(config: BlockConfig, state: BlockState) -> BlockState:
    """Host: the state with its shear history shaped for ``config.history_slots`` (after the
    driver grew ``law_slots`` or ``crossing_edges``): the slots kept, empty ones added (or the
    last ones dropped, if it shrank). Call between steps."""
    h = state.history
    L, old = config.history_slots, h.shear.shape[1]
    if L == old:
        return state
    if L < old:
        return state.replace(history=h.replace(shear=h.shear[:, :L], contact_feature=h.contact_feature[:, :L]))
    pad = L - old
    return state.replace(history=h.replace(
        shear=jnp.pad(h.shear, ((0, 0), (0, pad), (0, 0))),
        contact_feature=jnp.pad(h.contact_feature, ((0, 0), (0, pad)), constant_values=-1)))
