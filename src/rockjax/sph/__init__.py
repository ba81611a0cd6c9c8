"""The fluid: SPH kernels, neighbour search, equations of state, wall particles, and the fluid
schemes with their terms as static objects (``schemes``: ``WCSPH``, ``DFSPH``, ``SeedScheme``; ``kernels``,
``viscosity``, ``diffusion``, ``walls``, ``shifting``: one class per choice), and absorbing zones
(``absorbers``: ``Sponge``, listed in ``Config.absorbers``). Re-exported here: the scheme and
term classes a user composes."""

from .absorbers import Absorber, Sponge
from .diffusion import Antuono, DensityDiffusion, Fourtakas, FourtakasSurface, Molteni, NoDiffusion
from .kernels import CubicSpline, Kernel, Poly6Gradient, SeedGradientKernel, SpikyGradient, WendlandC2
from .shifting import Fickian, NoShifting, Shifting
from .schemes import DFSPH, WCSPH, FluidScheme, SeedScheme, from_names
from .terms import Term, by_name, names
from .viscosity import Artificial, Laminar, LaminarSPS, Viscosity
from .walls import Adami, DynamicWalls, WallModel

__all__ = [
    "FluidScheme", "WCSPH", "DFSPH", "SeedScheme", "from_names",
    "Kernel", "WendlandC2", "CubicSpline", "SeedGradientKernel", "SpikyGradient", "Poly6Gradient",
    "Viscosity", "Artificial", "Laminar", "LaminarSPS",
    "DensityDiffusion", "NoDiffusion", "Molteni", "Fourtakas", "FourtakasSurface", "Antuono",
    "WallModel", "Adami", "DynamicWalls",
    "Shifting", "NoShifting", "Fickian",
    "Term", "by_name", "names",
    "Absorber", "Sponge",
]
