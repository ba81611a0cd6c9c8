"""The rock blocks: explicit 3D-DDA convex polyhedra (seed sections 2-5).

* ``geometry`` (host, numpy): convex polyhedra with half-edge tables, mass properties, packing;
  shape helpers ``box``, ``wedge``, ``prism``, ``slab`` (floor), ``slope`` (inclined plane).
* ``model``: ``Motion``, ``Broadphase``, ``BlockConfig`` (static; its buffer sizes ``BlockCapacities``
  and speed settings ``BlockTuning``), ``BlockParams``, ``BlockShape``,
  ``BlockState`` (with its ``ContactHistory``); ``make_blocks`` (host builder: ``block_geometry``,
  ``BlockMaterial``, ``block_capacities``, ``block_tuning``, ``block_config``), ``stable_dt`` (seed Eq 8),
  world geometry, energies.
* ``broadphase``: AABBs, all-pairs or sorted uniform grid, fixed-capacity pair buffer.
* ``fcp``: the Fast Common Plane narrow phase (Nezami et al. 2004).
* ``contact``: contact points and ``contact_forces`` (FCP -> points -> law -> loads on the blocks).
* ``laws``: the contact law, a static choice on ``BlockConfig.law``: ``ContactLaw`` (the interface),
  ``PenaltyCoulomb`` (penalty springs, closing-only damping, Coulomb cap on a shear spring),
  ``SmoothPenaltyCoulomb`` (the same with its switches spread over stated widths: smooth gradients).
* ``joint_water``: hydrostatic water pressure on contact patches (``BlockConfig.joint_water``).
* ``paths``: prescribed motions of any kind (tables, flaps; wave-maker signals: regular, Goring
  solitary, focused group, JONSWAP, CSV records; Biesel transfer functions).
* ``integrate``: ``advance_blocks``, one central-difference step (seed Eq 5-7).
* ``cutting`` (host, numpy): rock masses cut into convex blocks along joint sets (``JointSet``,
  ``cut`` -> ``RockMass``; Shi's block cutting for persistent joints).

This package does not import ``rockjax.sph``.
"""

from .contact import contact_forces
from .geometry import ConvexPolyhedron, PackedBlocks, box, pack, prism, slab, slope, wedge
from . import cutting, paths
from .cutting import JointSet, RockMass, cut
from .integrate import advance_blocks, prescribed_motion
from .laws import ContactLaw, ContactPoint, LawResult, PenaltyCoulomb, SmoothPenaltyCoulomb
from .model import (
    BlockCapacities,
    BlockConfig,
    BlockGeometry,
    BlockMaterial,
    BlockParams,
    BlockShape,
    BlockState,
    BlockTuning,
    Broadphase,
    ContactHistory,
    Motion,
    block_capacities,
    block_config,
    block_geometry,
    block_mass,
    block_tuning,
    auto_pair_segment,
    check_block_params,
    energies,
    initial_overlaps,
    make_blocks,
    resize_pairs,
    fit_history,
    stable_dt,
    world_inertia,
    world_planes,
    world_vertices,
)
from .rotation import quat_from_axis_angle, quat_matrix

__all__ = [
    "paths",
    "cutting",
    "JointSet",
    "RockMass",
    "cut",
    "BlockCapacities",
    "BlockConfig",
    "BlockGeometry",
    "BlockMaterial",
    "BlockParams",
    "BlockShape",
    "BlockState",
    "BlockTuning",
    "check_block_params",
    "initial_overlaps",
    "Broadphase",
    "ContactHistory",
    "ContactLaw",
    "ContactPoint",
    "ConvexPolyhedron",
    "LawResult",
    "Motion",
    "PackedBlocks",
    "PenaltyCoulomb", "SmoothPenaltyCoulomb",
    "advance_blocks",
    "block_capacities",
    "block_config",
    "block_geometry",
    "block_mass",
    "block_tuning",
    "auto_pair_segment",
    "box",
    "contact_forces",
    "energies",
    "make_blocks",
    "pack",
    "prescribed_motion",
    "prism",
    "quat_from_axis_angle",
    "quat_matrix",
    "resize_pairs",
    "fit_history",
    "slab",
    "slope",
    "stable_dt",
    "wedge",
    "world_inertia",
    "world_planes",
    "world_vertices",
]
