"""rockjax: a differentiable 3D simulator of rock slides into water, in JAX.

The public API, re-exported explicitly:

* the three pytrees: ``Config`` (static), ``Params`` (calibratable), ``State`` (dynamic), plus
  the fluid schemes (``WCSPH``, ``DFSPH``, ``SeedScheme``; their terms in ``rockjax.sph``), the remaining
  enums and ``Status`` bits;
* ``make_step(config) -> step(state, params)``; ``prime``; ``make_rollout`` / ``rollout``;
* ``simulate(scene, t_end=...)`` (the host driver; checkpoint and resume), ``SimulationError``, ``Interrupted``;
* ``scenes`` (built-in scene builders returning a ``Scene``), ``observables``, ``io``;
* the physics packages: ``blocks`` (3D-DDA rock blocks), ``coupling`` (fluid-block exchange);
* ``calibrate`` (differentiable losses, optax calibration), ``gradcheck`` (is a gradient good at
  the scale a calibration moves?) and ``ensembles`` (vmap / sharded runs);
* ``decomposition``: one scene over many devices (slabs along x, halo exchange, ``shard_map``).
"""

__version__ = "0.1.0"

from . import blocks, calibrate, coupling, decomposition, ensembles, io, observables, scenes, sph
from .gradcheck import gradcheck
from .driver import Interrupted, Result, SimulationError, simulate
from .rollout import make_rollout, rollout
from .scenes import Scene
from .sph.absorbers import Sponge
from .sph.schemes import DFSPH, WCSPH, SeedScheme
from .step import make_step, prime
from .tuning import Tuning
from .types import (
    Adjoint, Capacities, Config, Coupling, GatherForm, WallSums, CouplingParams, CouplingState, FluidParams, GridSpec, Kind,
    NeighbourList, Params, Particles, State, Status,
)

__all__ = [
    "__version__",
    "Config", "Capacities", "Params", "FluidParams", "State", "Particles", "NeighbourList", "GridSpec",
    "CouplingParams", "CouplingState",
    "WCSPH", "DFSPH", "SeedScheme", "Sponge", "Tuning", "Adjoint", "GatherForm", "WallSums", "Coupling", "Kind", "Status",
    "make_step", "prime", "make_rollout", "rollout",
    "simulate", "Result", "SimulationError", "Interrupted",
    "Scene", "scenes", "observables", "io", "sph", "blocks", "coupling", "calibrate", "ensembles", "gradcheck",
    "decomposition",
]
