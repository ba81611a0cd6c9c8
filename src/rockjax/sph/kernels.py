"""SPH smoothing kernels in 3D, all with compact support radius ``R = 2h``.

Each kernel is a pair of functions of the distance ``r`` [m] and smoothing length ``h`` [m]:

* ``w(r, h)``: the kernel value W [1/m^3];
* ``f(r, h)``: ``(dW/dr) / r`` [1/m^5], so that ``grad_i W(x_i - x_j) = f(r, h) * (x_i - x_j)``.
  Writing the gradient this way keeps it finite at ``r = 0`` for smooth kernels.

Kernels: Wendland C2 (default), cubic spline (M4), and the Mueller et al. (2003) set of the seed
paper: poly6 for density (seed Eq 13), spiky for the pressure gradient (seed Eq 15), and the
viscosity kernel whose Laplacian is seed Eq 19. The seed's "h" is the support radius, here ``2h``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar

import jax.numpy as jnp

from .terms import Term

__all__ = [
    "SUPPORT_FACTOR",
    "wendland_c2",
    "wendland_c2_f",
    "cubic_spline",
    "cubic_spline_f",
    "poly6",
    "poly6_f",
    "spiky",
    "spiky_f",
    "viscosity_kernel",
    "viscosity_laplacian",
    "kernel_pair",
    "plane_integrals",
    "Kernel",
    "WendlandC2",
    "CubicSpline",
    "SeedGradientKernel",
    "SpikyGradient",
    "Poly6Gradient",
]

#: support radius / smoothing length for every kernel here
SUPPORT_FACTOR = 2.0


def wendland_c2(r, h):
    """Wendland C2 in 3D: ``21/(16 pi h^3) (1 - q/2)^4 (2q + 1)``, q = r/h < 2."""
    q = r / h
    t = jnp.clip(1.0 - 0.5 * q, 0.0, None)
    return jnp.where(r < SUPPORT_FACTOR * h, (21.0 / (16.0 * math.pi)) / h**3 * t**4 * (2.0 * q + 1.0), 0.0)


def wendland_c2_f(r, h):
    """(dW/dr)/r of Wendland C2: ``-5 sigma (1 - q/2)^3 / h^2`` (finite at r = 0)."""
    q = r / h
    t = jnp.clip(1.0 - 0.5 * q, 0.0, None)
    return jnp.where(r < SUPPORT_FACTOR * h, -5.0 * (21.0 / (16.0 * math.pi)) / h**5 * t**3, 0.0)


def cubic_spline(r, h):
    """Cubic spline (Monaghan & Lattanzio 1985) in 3D, sigma = 1/(pi h^3)."""
    q = r / h
    s = 1.0 / (math.pi * h**3)
    inner = 1.0 - 1.5 * q**2 + 0.75 * q**3
    outer = 0.25 * jnp.clip(2.0 - q, 0.0, None) ** 3
    return s * jnp.where(q < 1.0, inner, jnp.where(r < SUPPORT_FACTOR * h, outer, 0.0))


def cubic_spline_f(r, h):
    """(dW/dr)/r of the cubic spline."""
    q = r / h
    s = 1.0 / (math.pi * h**5)
    inner = -3.0 + 2.25 * q
    q_safe = jnp.where(q < 1.0, 1.0, q)
    outer = -0.75 * jnp.clip(2.0 - q_safe, 0.0, None) ** 2 / q_safe
    return s * jnp.where(q < 1.0, inner, jnp.where(r < SUPPORT_FACTOR * h, outer, 0.0))


def poly6(r, h):
    """Mueller poly6 (seed Eq 13) with support R = 2h: ``315/(64 pi R^9) (R^2 - r^2)^3``."""
    R = SUPPORT_FACTOR * h
    t = jnp.clip(R * R - r * r, 0.0, None)
    return 315.0 / (64.0 * math.pi) / R**9 * t**3


def poly6_f(r, h):
    """(dW/dr)/r of poly6: ``-6 * 315/(64 pi R^9) (R^2 - r^2)^2``."""
    R = SUPPORT_FACTOR * h
    t = jnp.clip(R * R - r * r, 0.0, None)
    return -6.0 * 315.0 / (64.0 * math.pi) / R**9 * t**2


def spiky(r, h):
    """Desbrun's spiky kernel with support R = 2h: ``15/(pi R^6) (R - r)^3``."""
    R = SUPPORT_FACTOR * h
    t = jnp.clip(R - r, 0.0, None)
    return 15.0 / math.pi / R**6 * t**3


def spiky_f(r, h):
    """(dW/dr)/r of spiky, i.e. seed Eq 15 divided by r: ``-45/(pi R^6) (R - r)^2 / r``.

    Singular as 1/r at r = 0; callers pass a safe, positive r and mask coincident pairs.
    """
    R = SUPPORT_FACTOR * h
    t = jnp.clip(R - r, 0.0, None)
    return -45.0 / math.pi / R**6 * t**2 / r


def viscosity_kernel(r, h):
    """Mueller's viscosity kernel (support R = 2h), for tests of its Laplacian."""
    R = SUPPORT_FACTOR * h
    val = -(r**3) / (2 * R**3) + r**2 / R**2 + R / (2 * r) - 1.0
    return jnp.where(r < R, 15.0 / (2 * math.pi * R**3) * val, 0.0)


def viscosity_laplacian(r, h):
    """Laplacian of the viscosity kernel (seed Eq 19): ``45/(pi R^6) (R - r)``."""
    R = SUPPORT_FACTOR * h
    return 45.0 / math.pi / R**6 * jnp.clip(R - r, 0.0, None)


def _wendland_c2_plane(s, h):
    u = jnp.clip(s / h, 0.0, SUPPORT_FACTOR)
    t = SUPPORT_FACTOR - u
    area = 3.0 / 256.0 * t**5 * (4.0 * u**2 + 5.0 * u + 2.0) / h
    beyond = t**6 * (3.0 * u**2 + 6.0 * u + 4.0) / 512.0
    return area, beyond


def _cubic_spline_plane(s, h):
    u = jnp.clip(s / h, 0.0, SUPPORT_FACTOR)
    t = SUPPORT_FACTOR - u
    area = jnp.where(u < 1.0, 0.7 - u**2 + 0.75 * u**4 - 0.3 * u**5, t**4 * (2.0 * u + 1.0) / 20.0) / h
    beyond = jnp.where(u < 1.0, 0.5 - 0.7 * u + u**3 / 3.0 - 0.15 * u**5 + u**6 / 20.0, t**5 * (u + 1.0) / 60.0)
    return area, beyond


class Kernel(Term):
    """A smoothing kernel of the WCSPH scheme (a static choice; ``h`` comes from ``Params``).

    ``w(r, h)`` [1/m^3] and ``f(r, h) = (dW/dr) / r`` [1/m^5] for distances ``r`` [m] (any shape);
    ``plane(s, h)`` the closed-form plane integrals ``(A, G)`` that the semi-analytical wall term
    needs (``plane_integrals``). Support radius ``SUPPORT_FACTOR * h`` for every kernel here.
    ``h_factor``: the h / dx the kernel is meant for (what ``DFSPH`` scenes use when given none).
    """

    family = "kernel"
    h_factor: ClassVar[float] = 1.3

    def w(self, r, h):
        raise NotImplementedError

    def f(self, r, h):
        raise NotImplementedError

    def plane(self, s, h):
        raise ValueError(f"no plane integrals for kernel {self.name!r}")


@dataclasses.dataclass(frozen=True)
class WendlandC2(Kernel):
    """Wendland C2 (the default): smooth, positive Fourier transform (no pairing instability)."""

    name = "wendland_c2"

    def w(self, r, h):
        return wendland_c2(r, h)

    def f(self, r, h):
        return wendland_c2_f(r, h)

    def plane(self, s, h):
        return _wendland_c2_plane(s, h)


@dataclasses.dataclass(frozen=True)
class CubicSpline(Kernel):
    """The M4 cubic spline (Monaghan & Lattanzio 1985); meant for h = dx (support 2 dx, ~33
    neighbours in 3D, as SPlisHSPlasH's cubic kernel of support 4 particle radii)."""

    name = "cubic_spline"
    h_factor = 1.0

    def w(self, r, h):
        return cubic_spline(r, h)

    def f(self, r, h):
        return cubic_spline_f(r, h)

    def plane(self, s, h):
        return _cubic_spline_plane(s, h)


def kernel_pair(kernel: Kernel):
    """The ``(w, f)`` functions of a kernel object."""
    return kernel.w, kernel.f


def plane_integrals(kernel: Kernel):
    """``(A, G)`` of a plane at distance ``s`` [m] >= 0 from a kernel's centre (clamped to [0, 2h]):

    * ``A(s, h) = int_plane W dA`` [1/m], the kernel's marginal across the plane; the gradient of
      the kernel volume beyond the plane, ``int_beyond grad_x W(x - y) dy = -A n`` (``n`` the plane's
      normal towards the centre), is what a particle misses of a pressure-gradient sum there;
    * ``G(s, h) = int_beyond W dy`` [-], the kernel's volume fraction beyond the plane (1/2 at s = 0,
      0 from s = 2h); ``int_0^inf G ds = int_0^inf s A ds`` (both ``5 h / 24`` for Wendland C2).

    Closed forms (integrals of the 3D kernels above over the plane and the half space).
    """
    return kernel.plane


class SeedGradientKernel(Term):
    """The kernel whose gradient the seed scheme's pressure force uses (``SeedScheme.gradient``):
    ``f(r, h)`` [1/m^5] for pairs at a safe, positive ``r``, and ``normalised``: whether the force
    divides it by the discrete lattice sum, as the density sum is (``seed.lattice_sum``)."""

    family = "seed_gradient"
    normalised = False

    def f(self, r, h):
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class SpikyGradient(SeedGradientKernel):
    """The spiky kernel's gradient (seed Eq 15, after Mueller et al. 2003), as the paper. It is not
    the gradient of the poly6 summation density, so the force is not that of the scheme's elastic
    energy and the water never comes to rest (RESULTS.md, "seed scheme at rest")."""

    name = "spiky"

    def f(self, r, h):
        return spiky_f(r, h)


@dataclasses.dataclass(frozen=True)
class Poly6Gradient(SeedGradientKernel):
    """The poly6 kernel's gradient, the density sum's own kernel normalised alike: the water comes
    to rest (RESULTS.md, "seed scheme at rest")."""

    name = "poly6"
    normalised = True

    def f(self, r, h):
        return poly6_f(r, h)
