"""Fluid schemes as static objects composed of their terms (``Config.scheme``).

``WCSPH(kernel=WendlandC2(), viscosity=Artificial(), walls=Adami(), diffusion=Fourtakas())`` is
the default, accurate scheme; ``SeedScheme(gradient=SpikyGradient(), walls=Adami())`` the seed
paper's. A scheme is a frozen dataclass (hashable, part of the static ``Config``; changing it
recompiles); it chooses the maths, ``Params.fluid`` holds the numbers. Each scheme owns what a
step needs of it: ``prime`` and ``advance`` (``sph.wcsph`` / ``sph.seed``), its time-step limits
(``stable_dt`` on the host, ``unstable_dt`` in jit), the checks of params it cannot run safely,
the initial densities of a still water column and its elastic energy. Terms are checked when the
scheme is built: a wrong type, or a combination that cannot work, is a ``ValueError`` there.

Where to add things: a viscosity in ``sph.viscosity``, a density diffusion in ``sph.diffusion``,
a kernel in ``sph.kernels``, a wall model in ``sph.walls``, a particle-shifting law in
``sph.shifting``, a scheme here (one class each).
Scene files and the command line find them by name (``from_names``; ``sph.terms``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from .diffusion import DensityDiffusion, Fourtakas
from .kernels import CubicSpline, Kernel, SeedGradientKernel, SpikyGradient, WendlandC2
from .shifting import NoShifting, Shifting
from .terms import Term, by_name, names
from .viscosity import Artificial, Viscosity
from .walls import Adami, WallModel

__all__ = ["FluidScheme", "WCSPH", "DFSPH", "SeedScheme", "from_names"]


def _check_type(owner: str, field: str, value, cls):
    if not isinstance(value, cls):
        raise ValueError(f"{owner}: {field} must be a {cls.__name__} object, one of "
                         f"{', '.join(names(cls.family))} (e.g. {owner}({field}=...)); got {value!r}")


class FluidScheme(Term):
    """Base of the fluid schemes (see the module docstring for what a scheme owns).

    ``kernel``: the kernel of the scheme's sums (and of interpolations, ``observables``);
    ``continuity``: the density follows the continuity equation (so the semi-analytical wall term
    ``Coupling.BOUNDARY_INTEGRAL``, written for it, applies); ``uses_nu``: the viscous time-step
    limit applies.
    """

    family = "scheme"
    continuity: ClassVar[bool] = False
    #: The step's pair sums all use the positions at its start (DFSPH), not the drifted ones
    #: (WCSPH's kick-drift-kick): the list must be valid there only (``rollout.needs_rebuild``,
    #: ``step.check``), however far a particle then moves in the step.
    sums_at_start: ClassVar[bool] = False
    #: The CFL number the scene builders use with this scheme when given none (``stable_dt``).
    default_cfl: ClassVar[float] = 0.25
    #: The Verlet skin / dx the water-only scene builders use when given none.
    default_skin_factor: ClassVar[float] = 0.3

    @property
    def uses_wall_pairs(self) -> bool:
        """Whether the step sums over the flat (fluid, wall) pair list (``NeighbourList.wall_row``);
        when False, list builds leave it empty (``Config.needs_wall_pairs``)."""
        return True

    @property
    def default_h_factor(self) -> float:
        """h / dx the scene builders use with this scheme when given none (WCSPH and the seed
        scheme: 1.3, whatever the kernel)."""
        return 1.3

    @property
    def uses_nu(self) -> bool:
        return False

    # ---- host side --------------------------------------------------------------------------
    def stable_dt(self, params, *, cfl: float) -> float:
        """Largest stable time step [s] for these params (concrete values):
        ``min(cfl h / c0, 0.125 h^2 / nu [if uses_nu], 0.25 sqrt(h / |g|))``."""
        f = params.fluid
        h, c0, nu = float(f.h), float(f.c0), float(f.nu)
        g = float(np.linalg.norm(np.asarray(params.gravity)))
        limits = [cfl * h / c0]
        if self.uses_nu and nu > 0:
            limits.append(0.125 * h * h / nu)
        if g > 0:
            limits.append(0.25 * math.sqrt(h / g))
        return min(limits)

    def check_params(self, params) -> None:
        """Refuse or warn about params this scheme cannot run well (host side). Default: none."""

    def check_resolution(self, h_factor: float) -> None:
        """Refuse an ``h / dx`` this scheme cannot run (host side, at the scene's build; ValueError
        naming the setting). Default: none."""

    def initial_density(self, pressure, *, rho0: float, c0: float):
        """Densities [n] kg/m^3 of a water column at rest under ``pressure`` [n] Pa (host, numpy),
        or None where the scheme sums its densities (they start at rho0)."""
        return None

    # ---- in jit -----------------------------------------------------------------------------
    def unstable_dt(self, dt: float, params, vmax):
        """True where ``dt`` exceeds the scheme's limits for the fastest particle ``vmax`` [m/s]
        (the in-jit check: acoustic ``0.5 h / (c0 + vmax)``, viscous ``0.25 h^2 / nu``)."""
        f = params.fluid
        unstable = dt > 0.5 * f.h / (f.c0 + vmax)
        if self.uses_nu:
            unstable |= dt * f.nu > 0.25 * f.h**2
        return unstable

    def initial_solver(self, n: int, dtype):
        """The ``Particles.solver`` record of a new state with ``n`` particles (None: no solves), so a
        scene's state has the same arrays before and after its first step (checkpoints, resume)."""
        return None

    def solver_status(self, P):
        """``Status`` bits [int32] of the scheme's own solves for particles ``P`` just advanced (in
        jit), or None for a scheme without solves (nothing is traced)."""
        return None

    def prime(self, P, nbrs, params, config):
        raise NotImplementedError

    def advance(self, P, nbrs, params, config, *, bodies: tuple = ()):
        raise NotImplementedError

    def pressure(self, P, params):
        """Pressure [N] Pa of the particles (output and probes)."""
        return P.p

    def elastic_energy(self, rho, params):
        """Elastic energy per unit mass ``e(rho) = int_rho0^rho p / rho^2`` [J/kg] of the equation of state."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class WCSPH(FluidScheme):
    """Weakly compressible SPH (``sph.wcsph``): continuity with density diffusion, Tait equation of
    state with exponent ``gamma``, momentum-conserving pressure gradient, a viscous term,
    kick-drift-kick."""

    name = "wcsph"
    continuity = True
    kernel: Kernel = WendlandC2()
    viscosity: Viscosity = Artificial()
    walls: WallModel = Adami()
    diffusion: DensityDiffusion = Fourtakas()
    gamma: float = 7.0
    shifting: Shifting = NoShifting()

    def __post_init__(self):
        for field, cls in (("kernel", Kernel), ("viscosity", Viscosity), ("walls", WallModel),
                           ("diffusion", DensityDiffusion), ("shifting", Shifting)):
            _check_type("WCSPH", field, getattr(self, field), cls)
        if not (self.gamma > 1 and math.isfinite(self.gamma)):
            raise ValueError(f"WCSPH: gamma (the Tait exponent) must be a finite number > 1 (got {self.gamma})")

    @property
    def uses_nu(self) -> bool:
        return self.viscosity.uses_nu

    def check_params(self, params) -> None:
        """Warn (``RuntimeWarning``) when neither artificial viscosity nor density diffusion damps the
        pressure noise: from a settled dam break, alpha = delta = 0 gained 0.2 m g 2a of energy in
        6 s (RESULTS.md, "energy creep"). Allowed (a user may study it), never silent."""
        import warnings

        if not isinstance(self.viscosity, Artificial):
            return
        f = params.fluid
        no_visc = not np.any(np.asarray(f.alpha) > 0)
        no_diff = not self.diffusion.active or not np.any(np.asarray(f.delta) > 0)
        if no_visc and no_diff:
            warnings.warn("WCSPH with Params.fluid.alpha = 0 and no density diffusion (delta = 0 or "
                          "NoDiffusion()) leaves the pressure noise undamped (unstable after a dam-break impact). "
                          "Set alpha > 0 (e.g. 0.02) or delta > 0 (e.g. 0.1).", RuntimeWarning, stacklevel=4)

    def initial_density(self, pressure, *, rho0: float, c0: float):
        from .eos import tait_density

        return np.asarray(tait_density(pressure, rho0, c0, self.gamma))

    def prime(self, P, nbrs, params, config):
        from . import wcsph

        return wcsph.prime(P, nbrs, params, config)

    def advance(self, P, nbrs, params, config, *, bodies: tuple = ()):
        from . import wcsph

        return wcsph.advance(P, nbrs, params, config, bodies=bodies)

    def pressure(self, P, params):
        from .eos import tait_pressure

        return tait_pressure(P.rho, params.fluid.rho0, params.fluid.c0, self.gamma)

    def elastic_energy(self, rho, params):
        f = params.fluid
        g = self.gamma
        B = f.rho0 * f.c0**2 / g
        # e(rho) = B/(g-1) [ (rho/rho0)^(g-1) - 1 ] / rho0 ... integral of p/rho^2 from rho0
        return B / rho * (jnp.power(rho / f.rho0, g) / (g - 1.0) + 1.0) - B / f.rho0 * (g / (g - 1.0))


@dataclasses.dataclass(frozen=True)
class DFSPH(FluidScheme):
    """Divergence-free SPH (``sph.dfsph``; Bender & Koschier 2015, 2017): summed densities, a
    divergence solve and a density solve per step (projected Jacobi on the pressure), walls and
    block particles as volumes (Akinci et al. 2012), a viscous term, symplectic Euler.

    ``wall_pressure``: the pressure a wall or block particle carries in the density solve's pair
    terms: "extrapolated" (default) the fluid row's own continued hydrostatically to it, so water at
    rest carries rho0 g d; "akinci" none of its own (the peer's form: a tank's pressures come out
    4-16 % high; ``sph.dfsph`` module docstring).

    ``kernel``: the cubic spline by default, at the h / dx of ``Kernel.h_factor`` (1.0: support 2 dx,
    as SPlisHSPlasH's) where a scene builder is given no ``h_factor``; the scene builders' CFL
    default is ``default_cfl`` = 0.4 (the velocity CFL ``0.4 dx / v``, as the peer's scenes), their
    Verlet skin 0.05 dx (``default_skin_factor``). ``viscosity``: Monaghan's artificial viscosity by
    default, with ``Params.fluid.alpha`` and the scene's speed scale ``c0`` (the dissipation WCSPH
    scenes carry, an effective nu ~ alpha c0 h / 10, 3e-3 m^2/s in the 3D dam break; the peer's
    scenes run nu = 0.01): with water's nu alone (``Laminar()``) the 3D dam break's impact on the
    far wall throws particles faster than h per step at dt = 0.4 dx / v.
    Against Wendland C2 at h = 1.3 dx it sums over 2.2x fewer neighbours, for the same surge front
    (``experiments/sph_time_vs_error.py``).

    ``tolerance``: the density solve's mean residual ``|rho/rho0 - 1|`` at which it stops (0.1 %);
    ``divergence_tolerance``: the divergence solve's mean ``dt |D|``; ``min_iterations`` /
    ``max_iterations``: the sweeps of each solve (a solve still above its tolerance at the cap sets
    ``Status.SOLVER_NOT_CONVERGED``), the divergence solve's least ``min_divergence_iterations``
    (1, as SPlisHSPlasH's; the density solve's 2 as its); ``iterations``: None runs each solve until it converges (a
    ``while_loop``), an int runs exactly that many sweeps, all of them; ``gradient``: the reverse
    mode of a solve, "unrolled" (through the fixed sweeps: needs ``iterations``; with ``None`` the
    run has no derivatives, and ``jax.grad`` says so) or "implicit" (the
    implicit function theorem at the solve's result, the adjoint solved by ``adjoint_iterations``
    Jacobi sweeps: any ``iterations``, exact for a converged solve; ``sph.dfsph`` "Gradients");
    ``divergence_solve``: run the divergence solve; ``min_neighbours``: rows
    with fewer neighbours get no divergence correction (free surface); ``warm_start``: the share of
    the previous step's pressures each solve starts from; ``relaxation``: the Jacobi step, below
    2 / lambda_max of the solves' operator (0.4: lambda_max 4.2 for Wendland C2 at h = 1.3 dx);
    ``mach``: ``Params.fluid.c0`` is read as the scene's speed scale over ``mach`` (the scenes set
    ``c0 = 10 v_max``), so the time step is the velocity CFL ``cfl h / (mach c0)``, 1/``mach``
    times WCSPH's acoustic one.
    """

    name = "dfsph"
    sums_at_start = True
    default_cfl = 0.4
    #: At its time step the fastest particles move ~0.4 dx a step, so the list is rebuilt every step
    #: whatever the skin (its sums use the step's start only): a thin skin keeps the list short.
    default_skin_factor = 0.05
    kernel: Kernel = CubicSpline()
    viscosity: Viscosity = Artificial()
    tolerance: float = 1e-3
    divergence_tolerance: float = 1e-3
    min_iterations: int = 2
    min_divergence_iterations: int = 1
    max_iterations: int = 100
    iterations: int | None = None
    divergence_solve: bool = True
    min_neighbours: int = 20
    warm_start: float = 1.0
    relaxation: float = 0.4
    mach: float = 0.1
    wall_pressure: str = "extrapolated"
    gradient: str = "unrolled"
    adjoint_iterations: int = 100
    shifting: Shifting = NoShifting()

    def __post_init__(self):
        _check_type("DFSPH", "kernel", self.kernel, Kernel)
        _check_type("DFSPH", "shifting", self.shifting, Shifting)
        if self.gradient not in ("unrolled", "implicit"):
            raise ValueError(f"DFSPH: gradient must be 'unrolled' (reverse mode through the sweeps) or 'implicit' "
                             f"(the implicit function theorem at the solve's result); got {self.gradient!r}")
        if not (isinstance(self.adjoint_iterations, int) and self.adjoint_iterations >= 1):
            raise ValueError(f"DFSPH: adjoint_iterations must be an int >= 1 (got {self.adjoint_iterations!r})")
        if self.wall_pressure not in ("extrapolated", "akinci"):
            raise ValueError(f"DFSPH: wall_pressure must be 'extrapolated' or 'akinci' (got "
                             f"{self.wall_pressure!r})")
        _check_type("DFSPH", "viscosity", self.viscosity, Viscosity)
        for field in ("tolerance", "divergence_tolerance", "mach"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"DFSPH: {field} must be a positive finite number (got {value!r})")
        if not (isinstance(self.min_iterations, int) and isinstance(self.max_iterations, int)
                and 1 <= self.min_iterations <= self.max_iterations):
            raise ValueError(f"DFSPH: need integers 1 <= min_iterations <= max_iterations (got "
                             f"{self.min_iterations!r}, {self.max_iterations!r})")
        if not (isinstance(self.min_divergence_iterations, int)
                and 1 <= self.min_divergence_iterations <= self.max_iterations):
            raise ValueError(f"DFSPH: need an integer 1 <= min_divergence_iterations <= max_iterations (got "
                             f"{self.min_divergence_iterations!r})")
        if self.iterations is not None and not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ValueError(f"DFSPH: iterations must be None (solve until converged) or an int >= 1 "
                             f"(a fixed, differentiable sweep count); got {self.iterations!r}")
        if not (0.0 <= self.warm_start <= 1.0):
            raise ValueError(f"DFSPH: warm_start must be in [0, 1] (got {self.warm_start!r})")
        if not (0.0 < self.relaxation < 1.0):
            raise ValueError(f"DFSPH: relaxation must be in (0, 1) (got {self.relaxation!r}); the Jacobi sweeps "
                             "diverge above 2 / lambda_max of the solves' operator (0.48 for Wendland C2 at h = 1.3 dx)")

    @property
    def uses_nu(self) -> bool:
        return self.viscosity.uses_nu

    def check_resolution(self, h_factor: float) -> None:
        """Refuse a ``relaxation`` at or above the Jacobi sweeps' stability bound ``2 / lambda_max``
        of this kernel at ``h = h_factor dx`` (``dfsph.jacobi_lambda_max``, the bulk lattice): a
        tank at rest with the cubic spline at h = 1.5 dx (bound 0.27) blew up in its first step
        at the default 0.4."""
        from .dfsph import jacobi_lambda_max

        lam = jacobi_lambda_max(self.kernel, float(h_factor))
        if self.relaxation >= 2.0 / lam:
            raise ValueError(
                f"DFSPH: relaxation = {self.relaxation} is at or above the Jacobi sweeps' stability bound "
                f"2 / lambda_max = {2.0 / lam:.3f} of the {self.kernel.name} kernel at h = {h_factor:g} dx "
                f"(lambda_max = {lam:.3g}); use DFSPH(relaxation={0.9 * 2.0 / lam:.2f}) or a smaller h_factor "
                f"(the kernel's own: {self.kernel.h_factor:g})")

    @property
    def default_h_factor(self) -> float:
        """The kernel's own h / dx (``Kernel.h_factor``)."""
        return self.kernel.h_factor

    @property
    def uses_wall_pairs(self) -> bool:
        """Only through the viscous term (``Viscosity.uses_wall_pairs``): the solves sum over the rows."""
        return self.viscosity.uses_wall_pairs

    def stable_dt(self, params, *, cfl: float) -> float:
        """Largest stable time step [s]: ``min(cfl h / (mach c0), 0.125 h^2 / nu [if uses_nu],
        0.25 sqrt(h / |g|))`` (the velocity CFL for the scene's speed scale ``mach c0``)."""
        f = params.fluid
        h, c0, nu = float(f.h), float(f.c0), float(f.nu)
        g = float(np.linalg.norm(np.asarray(params.gravity)))
        limits = [cfl * h / (self.mach * c0)]
        if self.uses_nu and nu > 0:
            limits.append(0.125 * h * h / nu)
        if g > 0:
            limits.append(0.25 * math.sqrt(h / g))
        return min(limits)

    def unstable_dt(self, dt: float, params, vmax):
        """True where the fastest particle moves more than ``h`` in a step (or the viscous limit)."""
        f = params.fluid
        unstable = dt * vmax > f.h
        if self.uses_nu:
            unstable |= dt * f.nu > 0.25 * f.h**2
        return unstable

    def initial_solver(self, n: int, dtype):
        from .dfsph import SOLVER_COLUMNS

        return jnp.zeros((n, len(SOLVER_COLUMNS)), dtype)

    def solver_status(self, P):
        from ..types import Kind, Status
        from .dfsph import SOLVER_COLUMNS

        if P.solver is None:
            return jnp.zeros((), jnp.int32)
        col = {c: k for k, c in enumerate(SOLVER_COLUMNS)}
        n = jnp.maximum(jnp.sum(P.kind == Kind.FLUID), 1)
        dens = jnp.sum(P.solver[:, col["density_error"]]) / n
        div = jnp.sum(P.solver[:, col["divergence_error"]]) / n
        it_d = jnp.max(P.solver[:, col["iterations_density"]])
        it_v = jnp.max(P.solver[:, col["iterations_divergence"]])
        bad = ((it_d >= self.max_iterations) & (dens > self.tolerance)) | (
            (it_v >= self.max_iterations) & (div > self.divergence_tolerance))
        return jnp.where(bad, jnp.int32(Status.SOLVER_NOT_CONVERGED), jnp.int32(0))

    def prime(self, P, nbrs, params, config):
        from . import dfsph

        return dfsph.prime(P, nbrs, params, config)

    def advance(self, P, nbrs, params, config, *, bodies: tuple = ()):
        from . import dfsph

        return dfsph.advance(P, nbrs, params, config, bodies=bodies)

    def elastic_energy(self, rho, params):
        """Zero: the incompressible scheme stores no elastic energy."""
        return jnp.zeros_like(rho)


@dataclasses.dataclass(frozen=True)
class SeedScheme(FluidScheme):
    """The seed paper's scheme (``sph.seed``; Mikola & Sitar 2013): summation density with poly6,
    linear equation of state (clamped at zero), symmetrised pressure force with the ``gradient``
    kernel (the paper's spiky, or poly6, which comes to rest), the viscosity kernel's Laplacian
    with ``Params.fluid.nu``, symplectic Euler."""

    name = "seed"
    gradient: SeedGradientKernel = SpikyGradient()
    walls: WallModel = Adami()

    def __post_init__(self):
        _check_type("SeedScheme", "gradient", self.gradient, SeedGradientKernel)
        _check_type("SeedScheme", "walls", self.walls, WallModel)
        if self.walls.mirrors_velocity:
            raise ValueError(f"SeedScheme: walls={self.walls!r} mirror the wall velocity for WCSPH's viscous terms; "
                             "the seed scheme's viscosity does not use it: use walls=Adami()")

    @property
    def uses_nu(self) -> bool:
        return True

    @property
    def kernel(self) -> Kernel:
        """The kernel of interpolations (probes; the scheme's own sums use the Mueller set)."""
        return WendlandC2()

    def prime(self, P, nbrs, params, config):
        from . import seed

        return seed.prime(P, nbrs, params, config)

    def advance(self, P, nbrs, params, config, *, bodies: tuple = ()):
        from . import seed

        return seed.advance(P, nbrs, params, config, bodies=bodies)

    def elastic_energy(self, rho, params):
        f = params.fluid
        ratio = jnp.maximum(rho, f.rho0) / f.rho0  # the clamped law: p >= 0 (sph.seed, deviation 2)
        return f.c0**2 * (jnp.log(ratio) + 1.0 / ratio - 1.0)


def from_names(scheme: str = "wcsph", *, kernel: str | None = None, viscosity: str | None = None,
               walls: str | None = None, diffusion: str | None = None, gradient: str | None = None,
               shifting: str | None = None) -> FluidScheme:
    """The scheme named ``scheme`` with terms by name (None: the scheme's default term), as scene
    files and the command line give them; a ``ValueError`` naming the unknown or inapplicable one."""
    cls = type(by_name("scheme", scheme))
    fields = {f.name for f in dataclasses.fields(cls)}
    chosen = {"kernel": kernel, "viscosity": viscosity, "walls": walls, "diffusion": diffusion, "gradient": gradient,
              "shifting": shifting}
    family = {"kernel": "kernel", "viscosity": "viscosity", "walls": "walls", "diffusion": "diffusion",
              "gradient": "seed_gradient", "shifting": "shifting"}
    kwargs = {}
    for key, value in chosen.items():
        if value is None:
            continue
        if key not in fields:
            raise ValueError(f"{key} = {value!r} does not apply to scheme {scheme!r} (its terms: {', '.join(sorted(fields))})")
        kwargs[key] = by_name(family[key], value)
    return cls(**kwargs)

