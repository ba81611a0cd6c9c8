"""Fluid-block coupling methods, one class each behind one protocol (``base.CouplingMethod``:
``place``, ``fluid_step``, ``prime``, ``exchange``): the seed's penalty force (``penalty.Penalty``,
seed Eq 22), boundary particles carried by the blocks (``boundary_particles.BoundaryParticles``) and
the semi-analytical wall term (``penalty.BoundaryIntegral``). Only this package and ``step`` see
both the fluid (``sph``) and the blocks (``blocks``)."""

from .base import CouplingMethod, NoCoupling, method
from .boundary_particles import BoundaryParticles
from .penalty import BoundaryIntegral, Penalty

__all__ = ["CouplingMethod", "NoCoupling", "Penalty", "BoundaryParticles", "BoundaryIntegral", "method"]
