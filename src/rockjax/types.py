"""The three pytrees every stage shares: ``Config`` (static), ``Params`` (calibratable), ``State``.

* ``Config`` is a frozen, hashable dataclass: counts, capacities, scheme enums, the time step,
  the neighbour grid. It is a static argument of ``jax.jit``; changing it recompiles.
* ``Params`` holds every physical constant a user may calibrate or sweep, as array leaves:
  ``jax.grad(loss)(params)`` and ``jax.vmap(f, in_axes=(None, 0))`` work on it as is.
* ``State`` holds positions, velocities, densities, the neighbour list and a status bit-field.
  Every array has a fixed shape; padding particles (``Kind.PAD``) are inert.

Units are SI throughout; z points up.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any, Optional

import jax
import jax.numpy as jnp

from .tuning import Adjoint, GatherForm, Tuning, WallSums

__all__ = [
    "Adjoint",
    "GatherForm",
    "WallSums",
    "Coupling",
    "Kind",
    "Status",
    "GridSpec",
    "Capacities",
    "Config",
    "FluidParams",
    "CouplingParams",
    "Params",
    "Particles",
    "NeighbourList",
    "CouplingState",
    "State",
    "float_dtype",
]


# --------------------------------------------------------------------------------------------
# Choices that are not fluid terms (the fluid's are objects: ``rockjax.sph.schemes``)
# --------------------------------------------------------------------------------------------


class Coupling(enum.Enum):
    """How water and rock blocks exchange forces (seed section 7; DESIGN "Coupling")."""

    NONE = "none"  #: no exchange (or no blocks / no water)
    PENALTY = "penalty"  #: seed Eq 22 repulsion on fluid particles near block faces, reaction on the block
    BOUNDARY_PARTICLES = "boundary_particles"  #: particles on block faces take part in the SPH sums
    #: semi-analytical wall for block faces (WCSPH): each fluid particle within 2h of a face gets the
    #: pressure force of the kernel support the block cuts off, the block the reaction; the seed
    #: Eq 22 penalty within dx/4 keeps water out (``coupling.penalty``). Experimental: it does not
    #: converge for bodies in still water (a box held at its Archimedes draft: load +9 % at dx = 0.02 m,
    #: +16 % at 0.01 m, the dx/4 guard carrying about half; ``experiments/held_box_load.py``):
    #: use ``BOUNDARY_PARTICLES`` for floating bodies
    BOUNDARY_INTEGRAL = "boundary_integral"


class Kind(enum.IntEnum):
    """Particle kind, stored per particle in ``Particles.kind`` (int32)."""

    PAD = -1  #: padding slot: never a neighbour, never moves
    FLUID = 0
    WALL = 1  #: fixed boundary particle


class Status(enum.IntFlag):
    """Bits of ``State.status``, set inside jit and checked by the host driver after each chunk."""

    OK = 0
    NEIGHBOUR_OVERFLOW = 1  #: a particle has more neighbours than ``Config.neighbour_capacity``
    CELL_OVERFLOW = 2  #: a run of grid cells holds more particles than ``Config.cell_capacity``
    NEIGHBOUR_STALE = 4  #: a particle moved more than skin/2 since the last list build
    NON_FINITE = 8  #: NaN or Inf in positions, velocities or densities
    OUT_OF_DOMAIN = 16  #: a particle left the neighbour grid (non-periodic axis)
    UNSTABLE_DT = 32  #: dt exceeds the CFL / viscous / force limit for the current state
    CONTACT_OVERFLOW = 64  #: more candidate block pairs than ``BlockConfig.pair_capacity``
    BLOCK_UNSTABLE = 128  #: dt exceeds the block stability limit (seed Eq 8) for the current Params
    BLOCK_PENETRATION = 256  #: a block contact penetrated deeper than the allowed fraction of its size
    WALL_PAIR_OVERFLOW = 512  #: more fluid-wall pairs in the list than ``Config.wall_pair_capacity``
    JOINT_PATCH_OVERFLOW = 1024  #: a joint patch has more points than ``BlockConfig.joint_patch_points``
    BODY_PAIR_OVERFLOW = 2048  #: more (fluid, block particle) pairs in the list than ``Config.body_pair_capacity``
    CONTACT_POINT_OVERFLOW = 4096  #: a block pair has more contact points than ``BlockConfig.law_slots``
    BLOCK_CELL_OVERFLOW = 8192  #: a broad-phase grid cell holds more blocks than ``BlockConfig.grid_cell_capacity``
    CROSSING_EDGE_OVERFLOW = 16384  #: a block of a pair has more edges inside the other than ``BlockConfig.crossing_edges``
    SUPPORT_EDGE_OVERFLOW = 32768  #: an FCP support set touches more edge directions than ``BlockConfig.support_edges``
    FCP_CROSS_OVERFLOW = 65536  #: an FCP round had more edge crosses than ``BlockConfig.fcp_crosses``
    SOLVER_NOT_CONVERGED = 131072  #: an implicit pressure solve (``DFSPH``) ended above its tolerance at its iteration cap
    SLAB_OVERFLOW = 262144  #: a decomposed scene's owned, halo or migration buffer overflowed (``rockjax.decomposition``)

    @classmethod
    def growable(cls) -> "Status":
        """Bits that the driver cures by growing a buffer (or rebuilding more often) and rerunning."""
        return (cls.NEIGHBOUR_OVERFLOW | cls.CELL_OVERFLOW | cls.NEIGHBOUR_STALE | cls.CONTACT_OVERFLOW
                | cls.WALL_PAIR_OVERFLOW | cls.JOINT_PATCH_OVERFLOW | cls.BODY_PAIR_OVERFLOW
                | cls.CONTACT_POINT_OVERFLOW | cls.BLOCK_CELL_OVERFLOW | cls.CROSSING_EDGE_OVERFLOW
                | cls.SUPPORT_EDGE_OVERFLOW | cls.FCP_CROSS_OVERFLOW)

    @classmethod
    def describe(cls, bits: int) -> str:
        names = [b.name for b in cls if b.value and (int(bits) & b.value)]
        return ", ".join(names) if names else "OK"


def float_dtype():
    """float64 when ``jax_enable_x64`` is on, else float32."""
    return jnp.float64 if jax.config.jax_enable_x64 else jnp.float32


# --------------------------------------------------------------------------------------------
# Config (static)
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class GridSpec:
    """Uniform cell grid covering the simulation domain.

    The domain is ``[origin, origin + shape * cell_size)`` per axis. Along a periodic axis that
    length is the period. Cells are numbered x-fastest: ``id = ix + nx * (iy + ny * iz)``.
    """

    origin: tuple[float, float, float]
    cell_size: tuple[float, float, float]
    shape: tuple[int, int, int]
    periodic: tuple[bool, bool, bool] = (False, False, False)

    @property
    def n_cells(self) -> int:
        return int(self.shape[0] * self.shape[1] * self.shape[2])

    @property
    def lengths(self) -> tuple[float, float, float]:
        return tuple(float(c * n) for c, n in zip(self.cell_size, self.shape))  # type: ignore[return-value]

    @property
    def upper(self) -> tuple[float, float, float]:
        return tuple(o + L for o, L in zip(self.origin, self.lengths))  # type: ignore[return-value]

    @staticmethod
    def covering(lo, hi, *, min_cell: float, periodic=(False, False, False)) -> "GridSpec":
        """The grid over the box ``[lo, hi]`` with cells at least ``min_cell`` wide.

        Along a periodic axis the box length is the period and must hold at least 2 cells' worth
        of ``min_cell`` (the minimum-image convention needs period >= 2 * search radius).
        """
        origin, cell, shape = [], [], []
        for ax in range(3):
            length = float(hi[ax]) - float(lo[ax])
            if length <= 0:
                raise ValueError(f"grid: upper bound must exceed lower bound on axis {ax} (got {lo[ax]}..{hi[ax]})")
            if periodic[ax]:
                n = int(math.floor(length / min_cell + 1e-9))
                if n < 2:
                    raise ValueError(
                        f"grid: periodic axis {ax} has length {length:.4g} m but the neighbour search radius is "
                        f"{min_cell:.4g} m; the period must be at least twice the radius ({2 * min_cell:.4g} m). "
                        "Make the domain wider along that axis or use a smaller dx."
                    )
                origin.append(float(lo[ax]))
                cell.append(length / n)
                shape.append(n)
            else:
                n = max(int(math.ceil(length / min_cell - 1e-9)), 1)
                origin.append(float(lo[ax]))
                cell.append(float(min_cell))
                shape.append(n)
        return GridSpec(tuple(origin), tuple(cell), tuple(shape), tuple(bool(p) for p in periodic))  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class Capacities:
    """Sizes of the particle side's neighbour buffers (static): the scene builders size them from
    the initial state, a step sets an overflow bit when one is too small, and the host driver grows
    it and reruns the chunk (``driver``). Nothing is dropped silently.

    Attributes:
        neighbours: K, neighbours kept per fluid-segment particle (``NEIGHBOUR_OVERFLOW``).
        cells: the most particles a run of ``Config.run_length`` consecutive x-cells may hold
            (``CELL_OVERFLOW``).
        wall_pairs: length of the flat list of (fluid row, wall neighbour) pairs that the WCSPH step
            sums the walls' quantities over (``NeighbourList.wall_row``; ``WALL_PAIR_OVERFLOW``).
        body_pairs: with boundary particles, length of the sub-list of those pairs whose wall
            particle is carried by a block (``NeighbourList.body_row``), over which a step sums the
            loads on the blocks (0: no sub-list; the loads then come from the whole wall-pair list;
            ``BODY_PAIR_OVERFLOW``).
    """

    neighbours: int = 96
    cells: int = 96
    wall_pairs: int = 0
    body_pairs: int = 0

    def __post_init__(self):
        for name, lo in (("neighbours", 1), ("cells", 1), ("wall_pairs", 0), ("body_pairs", 0)):
            v = getattr(self, name)
            if not isinstance(v, (int,)) or isinstance(v, bool) or v < lo:
                raise ValueError(f"Capacities.{name} must be an integer >= {lo} (got {v!r})")

    def replace(self, **changes) -> "Capacities":
        return dataclasses.replace(self, **changes)


def _default_scheme():
    from .sph.schemes import WCSPH

    return WCSPH()


@dataclasses.dataclass(frozen=True)
class Config:
    """Static description of a simulation. Hashable; a static argument of jit.

    Attributes:
        n_fluid: length of the fluid segment ``[0, n_fluid)`` of the particle arrays (fluid + padding).
        n_wall: length of the wall segment ``[n_fluid, n_fluid + n_wall)`` (fixed wall particles).
        dt: time step [s]; never depends on a differentiated parameter.
        grid: neighbour grid (its cells are at least ``cutoff + skin`` wide).
        cutoff: the largest kernel support the list serves [m]; ``kernel_support(params) <= cutoff``.
        skin: Verlet skin [m]; the list holds pairs closer than ``cutoff + skin``.
        rebuild_every: the list is rebuilt (and particles re-sorted by cell) every this many steps.
        capacities: the neighbour buffers' sizes (``Capacities``), which scene builders size from
            the initial state and the driver grows on an overflow bit (``grown``); read them as
            ``neighbour_capacity``, ``cell_capacity``, ``wall_pair_capacity``, ``body_pair_capacity``.
        n_block_particles: the tail ``[n_particles - n_block_particles, n_particles)`` of the wall
            segment that blocks carry (boundary particles, ``Particles.body >= 0``): the list build
            sorts it apart from the fixed walls (which stay sorted) and merges the three sorted
            segments, so moving block particles never force a re-sort of every wall (0: none).
        scheme: the fluid scheme and its terms, a static object (``rockjax.sph.schemes``):
            ``WCSPH(kernel=..., viscosity=..., walls=..., diffusion=..., gamma=7)`` (default) or
            ``SeedScheme(gradient=..., walls=...)``.
        tuning: the speed settings (``rockjax.tuning.Tuning``: row blocks, gather form, adjoint
            form), apart from the physics; its defaults depend on the backend
            (``effective_row_tile``, ``effective_gather``, ``effective_adjoint``). ``tuned(...)``
            changes some of them.
        cfl: Courant number used for the host time step and the in-jit stability check.
        blocks: the static block description (``rockjax.blocks.BlockConfig``), or None for no blocks.
        coupling: how water and blocks exchange forces: a ``Coupling`` name (NONE when either is
            absent; ``BOUNDARY_INTEGRAL`` needs the WCSPH scheme) or a coupling method object
            (``rockjax.coupling``: ``Penalty()``, ``BoundaryParticles(guard=..., guard_fixed=...)``,
            ``BoundaryIntegral()``, or a new one); ``coupling_method`` is the object.
        coupling_guard: with ``Coupling.BOUNDARY_PARTICLES``, also apply the seed Eq 22 penalty
            (``coupling.penalty``, within ``CouplingParams.interaction_distance`` of a face, dx/4 by
            default) so that no water particle is pressed between a block's particles into it; the
            reaction goes to the block. Ignored by the other couplings.
        guard_fixed: with ``coupling_guard``, guard the FIXED blocks' faces too (met by the water
            as wall particles, which do not stop a particle pressed between them either): a kick,
            no load (``coupling.penalty.guard_fixed``). Off by default: it costs ~0.2 ms/step per
            fixed block at 4.3k water particles (5 % of the sliding wedge's step at dx = 0.04) for
            a rare artefact (the wedge: one particle trapped 0.34 dx inside the slope's toe).
            Ignored by the penalty coupling, like ``coupling_guard`` (there a guarded floor held a
            landing block 0.75 dx up on trapped water: ``coupling.penalty.guard_fixed``).
        block_substeps: block steps per step (``block_dt = dt / block_substeps``, the fluid load held
            over them): an incompressible fluid step (DFSPH, ~12x WCSPH's) need not soften the rock
            contacts to its own length (``scenes.coupled_scene``).
        absorbers: damping zones for the water (``rockjax.sph.Sponge``: a sponge layer at a
            flume's end), applied after each fluid step; empty (default): none, nothing traced.

    A scene with no particles (``n_fluid == n_wall == 0``, blocks only) has ``grid=None`` and
    traces no SPH code; a scene with ``blocks=None`` traces no block code.
    """

    n_fluid: int
    n_wall: int
    dt: float
    grid: Optional[GridSpec]
    cutoff: float
    skin: float
    rebuild_every: int = 10
    capacities: "Capacities" = dataclasses.field(default_factory=lambda: Capacities())
    n_block_particles: int = 0
    scheme: Any = dataclasses.field(default_factory=lambda: _default_scheme())
    tuning: Tuning = Tuning()
    cfl: float = 0.25
    blocks: Optional[Any] = None
    coupling: Any = Coupling.NONE
    coupling_guard: bool = True
    guard_fixed: bool = False
    absorbers: tuple = ()
    block_substeps: int = 1

    def __post_init__(self):
        # Host-side checks of the static description; scene builders catch most problems earlier.
        if self.n_fluid < 0 or self.n_wall < 0:
            raise ValueError(f"Config.n_fluid / n_wall must be >= 0 (got {self.n_fluid}, {self.n_wall})")
        if self.n_fluid + self.n_wall < 1 and self.blocks is None:
            raise ValueError("Config: a scene needs particles (n_fluid + n_wall >= 1) or blocks (Config.blocks)")
        if not (self.dt > 0 and math.isfinite(self.dt)):
            raise ValueError(f"Config.dt must be a positive finite time step in seconds (got {self.dt})")
        from .coupling.base import CouplingMethod, NoCoupling

        if not isinstance(self.coupling, (Coupling, CouplingMethod)):
            raise ValueError(f"Config.coupling must be a Coupling name or a coupling method object (rockjax.coupling), "
                             f"got {self.coupling!r}")
        method = self.coupling_method
        if not isinstance(method, NoCoupling) and (self.blocks is None or self.n_fluid == 0):
            raise ValueError("Config.coupling needs both water (n_fluid > 0) and blocks; set Coupling.NONE")
        from .sph.schemes import FluidScheme

        if not isinstance(self.scheme, FluidScheme):
            raise ValueError(f"Config.scheme must be a fluid scheme object (rockjax.WCSPH(...) or rockjax.SeedScheme(...)), "
                             f"got {self.scheme!r}")
        if method.needs_continuity and not self.scheme.continuity:
            raise ValueError("Config.coupling BOUNDARY_INTEGRAL needs scheme WCSPH (a scheme with the continuity "
                             "equation, for which its wall term is written); use PENALTY or BOUNDARY_PARTICLES")
        from .sph.absorbers import Absorber

        if not isinstance(self.absorbers, tuple) or not all(isinstance(a, Absorber) for a in self.absorbers):
            raise ValueError(f"Config.absorbers must be a tuple of absorbing zones (rockjax.sph.Sponge(...)), "
                             f"got {self.absorbers!r}")
        if not (isinstance(self.block_substeps, int) and not isinstance(self.block_substeps, bool)
                and self.block_substeps >= 1):
            raise ValueError(f"Config.block_substeps must be an integer >= 1 (got {self.block_substeps!r})")
        if self.absorbers and self.n_fluid == 0:
            raise ValueError("Config.absorbers: the scene has no water to absorb; set absorbers=()")
        if not self.has_particles:
            return
        if self.grid is None:
            raise ValueError("Config.grid is required when the scene has particles (GridSpec.covering(...))")
        if self.rebuild_every < 1:
            raise ValueError(f"Config.rebuild_every must be >= 1 (got {self.rebuild_every})")
        if not isinstance(self.capacities, Capacities):
            raise ValueError(f"Config.capacities must be a rockjax.Capacities (got {self.capacities!r})")
        if not 0 <= self.n_block_particles <= self.n_wall:
            raise ValueError(f"Config.n_block_particles must be in [0, n_wall = {self.n_wall}] (got {self.n_block_particles})")
        if not isinstance(self.tuning, Tuning):
            raise ValueError(f"Config.tuning must be a rockjax.Tuning (got {self.tuning!r})")
        if self.skin < 0:
            raise ValueError(f"Config.skin must be >= 0 (got {self.skin})")
        min_cell = min(c for c, n, p in zip(self.grid.cell_size, self.grid.shape, self.grid.periodic))
        if min_cell < self.cutoff + self.skin - 1e-12:
            raise ValueError(
                f"Config.grid: cells ({min_cell:.4g} m) must be at least cutoff + skin = "
                f"{self.cutoff + self.skin:.4g} m wide; build the grid with GridSpec.covering(min_cell=cutoff + skin)"
            )

    @property
    def n_particles(self) -> int:
        """N = n_fluid + n_wall."""
        return self.n_fluid + self.n_wall

    @property
    def has_body_pairs(self) -> bool:
        """Whether list builds fill the (fluid, block particle) sub-list (``NeighbourList.body_row``)
        and a step sums the blocks' loads over it."""
        return self.body_pair_capacity > 0 and self.coupling_method.body_pairs

    @property
    def needs_wall_pairs(self) -> bool:
        """Whether list builds fill the flat (fluid, wall) pair list (``NeighbourList.wall_row``): the
        scheme sums over it (``FluidScheme.uses_wall_pairs``), or the block sub-list is cut from it."""
        return bool(self.scheme.uses_wall_pairs) or self.has_body_pairs

    @property
    def neighbour_capacity(self) -> int:
        """K, neighbours kept per fluid-segment particle (``capacities.neighbours``)."""
        return self.capacities.neighbours

    @property
    def cell_capacity(self) -> int:
        """The most particles a run of ``run_length`` x-cells may hold (``capacities.cells``)."""
        return self.capacities.cells

    @property
    def wall_pair_capacity(self) -> int:
        """Length of the flat (fluid, wall) pair list (``capacities.wall_pairs``)."""
        return self.capacities.wall_pairs

    @property
    def body_pair_capacity(self) -> int:
        """Length of the (fluid, block particle) sub-list (``capacities.body_pairs``)."""
        return self.capacities.body_pairs

    @property
    def wall_ordered(self) -> bool:
        """Whether list builds order the flat (fluid, wall) list by wall and the steps sum onto the
        walls by a segmented scan over each wall's run (``tuning.wall_sums`` resolved to ``WallSums.RANGES``)."""
        return self.needs_wall_pairs and self.n_wall > 0 and self.tuning.wall_sums_form() is WallSums.RANGES

    def grown(self, **changes) -> "Config":
        """This config with some buffer sizes changed (``Capacities`` fields), e.g. ``grown(neighbours=128)``."""
        return self.replace(capacities=self.capacities.replace(**changes))

    @property
    def coupling_method(self):
        """The coupling method object (``coupling.base.method``): ``coupling`` itself if it is one,
        else the method its name stands for, with ``coupling_guard`` and ``guard_fixed``."""
        from .coupling.base import method

        return method(self)

    @property
    def has_particles(self) -> bool:
        """Whether any SPH stage is traced."""
        return self.n_fluid + self.n_wall > 0

    @property
    def has_blocks(self) -> bool:
        """Whether any block stage is traced."""
        return self.blocks is not None

    @property
    def block_dt(self) -> float:
        """The block stage's step [s]: ``dt / block_substeps``."""
        return self.dt / self.block_substeps

    @property
    def effective_row_tile(self) -> int:
        """Rows per block of the WCSPH pair sums (``tuning.row_tile`` resolved; 0 = one block)."""
        return self.tuning.row_tile_for(self.n_fluid, self.neighbour_capacity)

    @property
    def effective_gather(self) -> GatherForm:
        """``tuning.gather`` resolved (``Tuning``): row gathers on accelerators, 1-D gathers on the CPU."""
        return self.tuning.gather_form()

    @property
    def effective_adjoint(self) -> Adjoint:
        """``tuning.adjoint`` resolved (``Tuning``)."""
        return self.tuning.adjoint_for(self.effective_row_tile)

    def tuned(self, **changes) -> "Config":
        """This config with some speed settings changed (``Tuning`` fields), e.g. ``tuned(row_tile=0)``."""
        return self.replace(tuning=self.tuning.replace(**changes))

    @property
    def list_radius(self) -> float:
        """Pairs closer than this are kept in the Verlet list [m]."""
        return self.cutoff + self.skin

    @property
    def run_length(self) -> int:
        """Consecutive x-cells searched as one contiguous range of the sorted particles."""
        return 1 if (self.grid.periodic[0] or self.grid.shape[0] < 3) else 3

    def replace(self, **changes) -> "Config":
        return dataclasses.replace(self, **changes)


# --------------------------------------------------------------------------------------------
# Params (differentiable)
# --------------------------------------------------------------------------------------------


def _pytree_dataclass(cls):
    """Freeze ``cls`` and register it as a pytree whose fields are all data (array) leaves."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    jax.tree_util.register_dataclass(cls, data_fields=names, meta_fields=[])
    cls.replace = lambda self, **kw: dataclasses.replace(self, **kw)
    return cls


@_pytree_dataclass
class FluidParams:
    """Physical constants of the water (all scalar arrays).

    Attributes:
        rho0: rest density [kg/m^3].
        c0: numerical speed of sound [m/s] (Tait B = rho0 c0^2 / gamma; seed k = c0^2).
        h: smoothing length [m]; kernel support is 2h (``kernel_support``).
        alpha: Monaghan artificial-viscosity coefficient [-] (WCSPH, ``sph.viscosity.Artificial``).
        nu: kinematic viscosity [m^2/s] (WCSPH laminar term; seed Eq 18 with mu = rho0 nu).
        delta: delta-SPH density-diffusion coefficient [-].
        wall_viscosity: factor [-] on the viscous term between fluid and non-fluid (wall, block)
            particles (WCSPH; DualSPHysics' ``ViscoBoundFactor``): 1 treats them like fluid
            neighbours (an artificial no-slip layer as thick as the artificial viscosity makes it),
            0 gives free-slip walls (no viscous boundary layer: waves travel undamped by the bed).
    """

    rho0: jax.Array
    c0: jax.Array
    h: jax.Array
    alpha: jax.Array
    nu: jax.Array
    delta: jax.Array
    wall_viscosity: jax.Array


@_pytree_dataclass
class CouplingParams:
    """Constants of the fluid-block coupling (scalars).

    Attributes:
        penalty_stiffness: K_S of seed Eq 22, per unit fluid mass [1/s^2] (the force on a particle of
            mass m is ``m (K_S d - K_D v_n) n``, so one value fits every resolution).
        penalty_damping: K_D of seed Eq 22, per unit fluid mass [1/s].
        interaction_distance: distance from a block face within which the penalty acts [m]
            (with ``Coupling.BOUNDARY_PARTICLES``: the guard's, ``Config.coupling_guard``).
    """

    penalty_stiffness: jax.Array
    penalty_damping: jax.Array
    interaction_distance: jax.Array


@_pytree_dataclass
class Params:
    """Everything a user may calibrate or sweep. ``gravity`` is a [3] vector [m/s^2].

    ``fluid`` (``FluidParams``), ``blocks`` (``rockjax.blocks.BlockParams``: densities, friction
    angle, penalty constants of the rock contacts) and ``coupling`` (``CouplingParams``) are None
    when the scene has no such part.
    """

    gravity: jax.Array
    fluid: Optional[FluidParams] = None
    blocks: Optional[Any] = None
    coupling: Optional[CouplingParams] = None


# --------------------------------------------------------------------------------------------
# State (dynamic)
# --------------------------------------------------------------------------------------------


@_pytree_dataclass
class Particles:
    """Per-particle arrays, leading dimension N (sorted by grid cell at each list rebuild).

    Attributes:
        x: positions [N, 3] m.       v: velocities [N, 3] m/s.       a: accelerations [N, 3] m/s^2.
        rho: density [N] kg/m^3.     drho_dt: density rate [N] kg/m^3/s.   p: pressure [N] Pa.
        vol: reference volume dx^3 [N] m^3 (mass = rho0 * vol).
        kind: ``Kind`` codes [N] int32.   pid: original particle index [N] int32 (for output).
    body: [N] int32 block that carries the particle (boundary-particle coupling), -1 for none;
        None when the scene has no such particles.
    x_body: [N, 3] m, the particle's position in its block's body frame (None likewise).
    grad_rho: [N, 3] kg/m^4, renormalised density gradient at the last momentum pass (fluid rows;
        zero on walls), for ``sph.diffusion.Antuono``; None otherwise (``wcsph.prime`` fills it).
    solver: [N, 6] the implicit scheme's per-particle solve record (``sph.dfsph.SOLVER_COLUMNS``:
        the pressures that warm-start the next step, the last errors, the sweep counts); None for
        the explicit schemes (``dfsph.prime`` fills it).
    owned: [N] bool, the rows whose forces on the blocks count in this state's loads; None (the
        default): all. A decomposed scene (``rockjax.decomposition``) holds halo copies of other
        devices' water, whose reactions on the blocks their owners count.
    """

    x: jax.Array
    v: jax.Array
    a: jax.Array
    rho: jax.Array
    drho_dt: jax.Array
    p: jax.Array
    vol: jax.Array
    kind: jax.Array
    pid: jax.Array
    body: Optional[jax.Array] = None
    x_body: Optional[jax.Array] = None
    grad_rho: Optional[jax.Array] = None
    solver: Optional[jax.Array] = None
    owned: Optional[jax.Array] = None


@_pytree_dataclass
class NeighbourList:
    """Verlet lists. ``idx[i, k]`` is a neighbour of fluid row i, or i itself in unused slots.

    Attributes:
        idx: [n_fluid, K] int32, fluid and wall neighbours of each fluid-segment particle.
            Wall particles have no rows: what they need is a transpose of the fluid rows.
        x_ref: [N, 3] positions at the last build (for the skin check) m.
        max_count: the largest neighbour count seen at the builds since the driver reset it.
        max_run: the fullest run of cells seen (compare with ``Config.cell_capacity``).
        wall_row, wall_col: [wall_pair_capacity] int32, the (fluid row i, wall neighbour j) pairs
            of ``idx`` (fluid i, wall j), in row order (in wall order, rows ascending within a
            wall, where ``Config.wall_ordered``); slots past ``wall_count`` hold (0, 0) and are
            masked. Sums onto the walls run over this short list instead of all of ``idx``.
        wall_start: [n_wall + 1] int32, where ``Config.wall_ordered``: the first slot of wall
            particle ``n_fluid + j``'s pairs (the last entry ``wall_count``); zeros otherwise.
        wall_count: the number of such pairs at the last build; max_wall_count: the largest seen
            since the driver reset it (compare with ``Config.wall_pair_capacity``).
        body_row, body_col: [body_pair_capacity] int32, the pairs of ``wall_row`` / ``wall_col``
            whose wall particle is carried by a block (``Particles.body >= 0``), in the same order;
            (0, 0) past ``body_count``. body_count, max_body_count: as for the wall pairs.
    """

    idx: jax.Array
    x_ref: jax.Array
    max_count: jax.Array
    max_run: jax.Array
    wall_row: jax.Array
    wall_col: jax.Array
    wall_count: jax.Array
    max_wall_count: jax.Array
    wall_start: jax.Array
    body_row: jax.Array
    body_col: jax.Array
    body_count: jax.Array
    max_body_count: jax.Array


@_pytree_dataclass
class CouplingState:
    """Fluid loads on the blocks computed at the end of the last step (applied in the next one).

    Attributes:
        force: [B, 3] N, world frame.   torque: [B, 3] N m, about each block's centroid.
    """

    force: jax.Array
    torque: jax.Array


@_pytree_dataclass
class State:
    """Everything that changes in time.

    Attributes:
        step: step counter (int32 scalar); the time is ``step * config.dt``.
        particles: the SPH particles (fluid, walls, padding); None in a blocks-only scene.
        nbrs: the Verlet neighbour list; None in a blocks-only scene.
        status: ``Status`` bits (int32 scalar), OR-ed over the steps since the driver cleared it.
        blocks: block poses, velocities, geometry and contact history (``rockjax.blocks.BlockState``),
            or None.
        coupling: fluid loads on blocks (``CouplingState``) or None.
    """

    step: jax.Array
    particles: Optional[Particles]
    nbrs: Optional[NeighbourList]
    status: jax.Array
    blocks: Optional[Any] = None
    coupling: Optional[CouplingState] = None

    def time(self, config: Config) -> jax.Array:
        return self.step * config.dt
