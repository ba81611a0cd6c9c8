"""The coupling protocol: what a fluid-block coupling method does in a step, and the table of
methods by ``Coupling`` name.

A method is a frozen dataclass (static, hashable) with the few operations ``step`` composes::

    blocks advance (loads of the previous step)  ->  place  ->  fluid_step  (fluid + exchange)

* ``place(state, params, config)``: put what the blocks carry for the fluid at their new poses
  (boundary particles); default: nothing;
* ``fluid_step(state, params, config)``: advance the fluid one step and exchange momentum with the
  blocks: the new fluid loads on the blocks in ``state.coupling`` (applied in the blocks' next
  step) and any kick of the fluid; default: the scheme's step, then ``exchange(kick=True)``;
* ``prime(state, params, config)``: the fluid's initial accelerations and the blocks' initial
  loads (no kick); default: the scheme's prime, then ``exchange(kick=False)``;
* ``exchange(state, params, config, *, kick)``: the loads for the current particles (and with
  ``kick`` the fluid's kick by dt times the coupling's acceleration).

Every exchange is equal and opposite (momentum to round-off: ``tests/coupling``). ``Config.coupling``
names a method (``types.Coupling``) or is a method object itself; ``Config.coupling_method`` is the
object (``method``). To add a method: a class with these operations (in its own module of this
package), passed as ``Config.coupling``; for scene files also a name in ``types.Coupling`` and ``method``.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

__all__ = ["CouplingMethod", "NoCoupling", "method"]


class CouplingMethod:
    """Base of the coupling methods (module docstring). ``wall_term``: the penalty exchange adds the
    semi-analytical wall term (``coupling.penalty.wall_terms``); ``needs_continuity``: the method is
    written for a scheme with the continuity equation (``FluidScheme.continuity``); ``body_pairs``:
    the neighbour list keeps the (fluid, block particle) pairs apart (``NeighbourList.body_row``)."""

    name: ClassVar[str] = ""
    wall_term: ClassVar[bool] = False
    needs_continuity: ClassVar[bool] = False
    body_pairs: ClassVar[bool] = False  # list builds fill the (fluid, block particle) sub-list

    def place(self, state, params, config):
        return state

    def exchange(self, state, params, config, *, kick: bool):
        return state

    def fluid_step(self, state, params, config):
        P = config.scheme.advance(state.particles, state.nbrs, params, config)
        return self.exchange(state.replace(particles=P), params, config, kick=True)

    def prime(self, state, params, config):
        P = config.scheme.prime(state.particles, state.nbrs, params, config)
        return self.exchange(state.replace(particles=P), params, config, kick=False)


@dataclasses.dataclass(frozen=True)
class NoCoupling(CouplingMethod):
    """No exchange (no blocks, no water, or only fixed blocks met as wall particles)."""

    name = "none"


def method(config) -> CouplingMethod:
    """The coupling method object of ``config`` (``Config.coupling`` as given if it is one, else the
    method its name stands for, with ``Config.coupling_guard`` / ``guard_fixed``)."""
    from ..types import Coupling

    c = config.coupling
    if isinstance(c, CouplingMethod):
        return c
    if c == Coupling.NONE:
        return NoCoupling()
    if c == Coupling.PENALTY:
        from .penalty import Penalty

        return Penalty()
    if c == Coupling.BOUNDARY_INTEGRAL:
        from .penalty import BoundaryIntegral

        return BoundaryIntegral()
    if c == Coupling.BOUNDARY_PARTICLES:
        from .boundary_particles import BoundaryParticles

        return BoundaryParticles(guard=config.coupling_guard, guard_fixed=config.guard_fixed)
    raise ValueError(f"Config.coupling: unknown coupling {c!r}")
