"""Speed settings, apart from the physics: ``Tuning`` (how the pair sums are blocked and gathered,
how reverse mode goes through them) with its backend-dependent defaults decided here, in one place.

None of these changes a result beyond float rounding; they change time and memory. A ``Tuning`` is
static (hashable) and travels in ``Config.tuning``; ``make_step``, ``make_rollout`` and ``simulate``
take ``tuning=`` to override it. The measurements behind each default are in
``experiments/RESULTS.md`` ("row tiles", "gather form", "adjoint") and ``docs/notes.md``.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Optional

import jax

__all__ = ["Adjoint", "GatherForm", "Tuning", "WallSums", "on_accelerator"]


class Adjoint(enum.Enum):
    """How reverse mode (``jax.grad``, ``jax.vjp``) goes through the WCSPH step's neighbour sums."""

    #: JAX transposes every neighbour gather (a scatter-add) and keeps the per-pair intermediates;
    #: forward mode (``jax.jvp``) works too
    AUTODIFF = "autodiff"
    #: a custom VJP of each pair sum by gathers over the symmetric list (``sph.pair_sum``): the
    #: same forward, a faster reverse mode; ``jax.jvp`` through the step raises
    PAIR_SUMS = "pair_sums"


class GatherForm(enum.Enum):
    """How the WCSPH pair sums read the neighbours' values (``Tuning.gather``)."""

    #: one 1-D gather per value (position components, velocity components, rho, p, ...): the
    #: fastest forward on the CPU (DESIGN.md: 2x a packed [n, 8] gather)
    COMPONENTS = "components"
    #: the values stacked into one [N, C] array and gathered by rows ([R, K, C]): its reverse mode
    #: scatters rows, which DESIGN.md measured 8x faster on a GPU than the component scatters
    ROWS = "rows"


class WallSums(enum.Enum):
    """How the sums onto the wall particles over the flat (fluid, wall) list run (``Tuning.wall_sums``):
    the Adami extrapolation each step, dynamic walls' continuity, the no-slip velocity."""

    #: ``segment_sum`` over the list in row order: one scatter-add, the fastest on the CPU (serial
    #: there); on a GPU its atomics contend on each wall (51 % of a 1M-particle WCSPH step)
    SCATTER = "scatter"
    #: the list rebuilt in wall order (a sort per list build) with each wall's first slot
    #: (``NeighbourList.wall_start``); each step sums each wall's run of consecutive slots by a
    #: segmented scan and reads the sums at the runs' ends: no scatter, no atomics
    RANGES = "ranges"


def on_accelerator() -> bool:
    """Whether JAX's default backend is not the CPU (a GPU or TPU): the defaults below differ."""
    return jax.default_backend() != "cpu"


#: on the CPU, pair sums over lists of more than this many slots (n_fluid * K) run in row blocks
ROW_TILE_SLOTS = 2**19
#: rows per block then (the per-pair intermediates of a block stay in cache)
CPU_ROW_TILE = 512
#: rows per block of the custom reverse pass when the forward runs in one block
BACKWARD_TILE = 512


@dataclasses.dataclass(frozen=True)
class Tuning:
    """Speed settings of a simulation (static). None means: the default for this backend and size.

    Attributes:
        row_tile: the WCSPH pair sums run over blocks of this many fluid rows (0: all rows at once).
            Default: blocks of 512 rows on the CPU when the list has more than 2**19 slots (faster
            there at 5.5k-21k rows, slower at <= 2.7k), one block on accelerators (where the blocks
            are a sequential scan).
        gather: ``GatherForm``; default ``COMPONENTS`` on the CPU (the faster forward), ``ROWS`` on
            accelerators (the same forward, a 2.6x faster reverse mode).
        adjoint: ``Adjoint``; default ``PAIR_SUMS`` where the pair sums run in row blocks, else
            ``AUTODIFF`` (so that ``jax.jvp`` works on small scenes). Forward mode needs ``AUTODIFF``.
        backward_tile: rows per block of ``Adjoint.PAIR_SUMS``'s reverse pass when the forward runs
            in one block (default 512; 0: one block).
        hand_pullbacks: ``Adjoint.PAIR_SUMS`` uses the hand-derived pullbacks of the default pair
            functions (``sph.pullbacks``; False: JAX's VJP of the pair function from each end).
        save_pair_sums: under ``Adjoint.PAIR_SUMS`` a checkpointed rollout saves the pair sums'
            outputs instead of recomputing them (``rollout``).
        wall_sums: ``WallSums``; default ``SCATTER`` on the CPU, ``RANGES`` on accelerators.
    """

    row_tile: Optional[int] = None
    gather: Optional[GatherForm] = None
    adjoint: Optional[Adjoint] = None
    backward_tile: Optional[int] = None
    hand_pullbacks: bool = True
    save_pair_sums: bool = True
    wall_sums: Optional[WallSums] = None

    def __post_init__(self):
        for name in ("row_tile", "backward_tile"):
            v = getattr(self, name)
            if v is not None and (not isinstance(v, int) or v < 0):
                raise ValueError(f"Tuning.{name} must be an int >= 0 or None (0 = one block; got {v!r})")
        if self.gather is not None and not isinstance(self.gather, GatherForm):
            raise ValueError(f"Tuning.gather must be a GatherForm or None (got {self.gather!r})")
        if self.adjoint is not None and not isinstance(self.adjoint, Adjoint):
            raise ValueError(f"Tuning.adjoint must be an Adjoint or None (got {self.adjoint!r})")
        if self.wall_sums is not None and not isinstance(self.wall_sums, WallSums):
            raise ValueError(f"Tuning.wall_sums must be a WallSums or None (got {self.wall_sums!r})")

    def replace(self, **changes) -> "Tuning":
        return dataclasses.replace(self, **changes)

    def row_tile_for(self, n_rows: int, neighbours: int) -> int:
        """Rows per block of the pair sums over ``n_rows`` rows of ``neighbours`` slots (0: one block)."""
        if self.row_tile is not None:
            return self.row_tile
        if on_accelerator():
            return 0
        return CPU_ROW_TILE if n_rows * neighbours > ROW_TILE_SLOTS else 0

    def gather_form(self) -> GatherForm:
        if self.gather is not None:
            return self.gather
        return GatherForm.ROWS if on_accelerator() else GatherForm.COMPONENTS

    def adjoint_for(self, row_tile: int) -> Adjoint:
        if self.adjoint is not None:
            return self.adjoint
        return Adjoint.PAIR_SUMS if row_tile > 0 else Adjoint.AUTODIFF

    def wall_sums_form(self) -> WallSums:
        if self.wall_sums is not None:
            return self.wall_sums
        return WallSums.RANGES if on_accelerator() else WallSums.SCATTER

    def backward_rows(self) -> int:
        return BACKWARD_TILE if self.backward_tile is None else self.backward_tile
