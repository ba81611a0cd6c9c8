"""Particle shifting: a small displacement of each fluid particle, each step, down its neighbours'
concentration gradient, that keeps the particles evenly spread (``WCSPH(shifting=...)``,
``DFSPH(shifting=...)``).

Why: a wave drives particles through one another; without a correction their arrangement drifts
into clumps and voids, and the pair sums turn that disorder into particle noise that takes
energy out of the wave (``experiments/wave_box.py``'s energy budget). Shifting is the standard
remedy of incompressible and weakly compressible SPH for propagating waves (Lind et al. 2012,
Skillen et al. 2013, Sun et al. 2017).

The terms (one class each, a frozen dataclass with a ``name``; ``sph.by_name("shifting", NAME)``):

* ``NoShifting`` (``"none"``, the default): particles move with the flow only;
* ``Fickian`` (``"fickian"``): Fick's law with Skillen et al.'s (2013) diffusivity,
  ``dr_i = -A h |v_i| dt grad C_i``, ``grad C_i = sum_j V_j (1 + R (W_ij / W(dx))^4) grad_i W_ij``
  over all neighbours (walls and block particles fill the kernel as water would), ``V_j = m_j /
  rho_j`` (with the lattice's volume instead, the hydrostatic compression of a still column reads
  as a concentration gradient pushing up), ``R`` > 0 Sun et al.'s (2017) anti-clumping weight,
  which keeps particle pairs from collapsing onto each other; near the free surface (``div r_i`` below ``surface``) only the part
  of ``dr`` tangent to it, ``(I - n n) dr`` with the outward normal ``n = -grad C0 / |grad C0|``
  of the unweighted concentration ``C0`` (Lind et al. 2012: a free surface is not a void to
  fill); a particle with ``div r_i`` below ``splash`` (a drop) is not shifted. ``div r_i =
  -sum_j V_j (x_i - x_j) . grad_i W_ij`` is ~3 in a filled 3D lattice (``bulk_divergence``: the
  thresholds are fractions of it); under a flat free surface (Wendland C2, h = 1.5 dx) it is 2.03 /
  2.43 / 2.90 in the top three layers and 3.00 below. The surface's particles (``div r`` below
  ``surface``, 0.85 of the bulk's: the top two layers) and every particle with one of them within
  the kernel's support (Sun et al.'s near-surface band) get the tangential part only: a layer whose
  kernel the surface cuts sees a concentration gradient out of the water, and its full shift lifts
  the water steadily. In ``experiments/wave_box.py``'s box (kd 1, a/dx 0.67) the potential energy
  still rises with the band, 0.14 of the wave's energy per period (lattice volumes and a threshold
  at 0.985 of the bulk's instead of the band: 0.30; m/rho volumes and 0.985: 0.26; 0.999: 0.07),
  and the wave decays faster than without shifting (RESULTS, wave box).

The displacement is applied with the step's drift, ``x' = x + dt v + dr`` (``displacement``, on
the positions and velocities at the step's start; the densities and velocities are carried
unchanged to the shifted position, an error of ``dr . grad`` of each, second order in the
displacement for the smooth part). It is differentiable (a ``safe_norm`` for ``|v|`` and the
normal), but the surface and splash thresholds switch: a particle crossing them changes its
shift discontinuously (reverse mode then sees a kink, as for any SPH free-surface switch).

To add a shifting law: subclass ``Shifting`` here as a frozen dataclass with a ``name`` and a
``displacement``.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import ClassVar

import jax
import jax.numpy as jnp

from ..types import Config, Kind, NeighbourList, Params, Particles
from .neighbours import safe_norm
from .terms import Term

__all__ = ["Shifting", "NoShifting", "Fickian", "bulk_divergence"]


class Shifting(Term):
    """Base of the shifting laws. ``active``: the law moves anything (a scheme skips the pass
    otherwise, so its program is unchanged)."""

    family = "shifting"
    active: ClassVar[bool] = True

    def displacement(self, P: Particles, nbrs: NeighbourList, params: Params, config: Config):
        """The shift [N, 3] m of every particle for the step (zero off the fluid rows)."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class NoShifting(Shifting):
    """No shifting: particles move with the flow."""

    name = "none"
    active = False

    def displacement(self, P, nbrs, params, config):
        return jnp.zeros_like(P.x)


@dataclasses.dataclass(frozen=True)
class Fickian(Shifting):
    """Fick's-law shifting with Skillen et al.'s diffusivity ``A h |v| dt`` (module docstring).

    ``A``: the diffusivity's coefficient (Skillen et al. 2013 and DualSPHysics use 2);
    ``R``: Sun et al.'s anti-clumping weight of ``(W_ij / W(dx))^4`` (0.2; 0 for Lind's plain
    concentration gradient); ``surface`` / ``splash``: ``div r`` over the bulk lattice's below which
    a particle is at the free surface / a drop (no shift); the surface's particles and those with
    one of them within the kernel's support get the tangential shift only.
    """

    name = "fickian"
    A: float = 2.0
    R: float = 0.2
    surface: float = 0.85
    splash: float = 0.5

    def __post_init__(self):
        for field in ("A", "R", "surface", "splash"):
            value = getattr(self, field)
            if not (isinstance(value, (int, float)) and value >= 0 and value == value):
                raise ValueError(f"Fickian: {field} must be a number >= 0 (got {value!r})")
        if not self.splash <= self.surface <= 1.0:
            raise ValueError(f"Fickian: need splash <= surface <= 1 (fractions of the bulk's div r); got splash = "
                             f"{self.splash}, surface = {self.surface}")

    def displacement(self, P, nbrs, params, config):
        from .pair_sum import pair_sum

        nf = config.n_fluid
        V = params.fluid.rho0 * P.vol / P.rho  # m / rho: a compressed column is not a concentration gradient
        sums = pair_sum(_concentration_pair(float(self.R)), P.x, {"vol": V}, {"vol": V}, params, nbrs, P.kind,
                        config)
        g, g0, divr = jnp.stack(sums[0:3], axis=1), jnp.stack(sums[3:6], axis=1), sums[6]
        divr = divr / _lattice_divergence(jax.lax.stop_gradient(P.vol[0]), jax.lax.stop_gradient(params.fluid.h),
                                          config.scheme.kernel)
        h = params.fluid.h
        speed = safe_norm(jnp.sum(P.v[:nf] ** 2, axis=1))
        dr = -(self.A * h * config.dt) * speed[:, None] * g
        g0n = safe_norm(jnp.sum(g0 ** 2, axis=1))
        n = -g0 / jnp.where(g0n > 0, g0n, 1.0)[:, None]
        tangent = dr - jnp.sum(dr * n, axis=1, keepdims=True) * n
        fluid = P.kind[:nf] == Kind.FLUID
        at_surface = (divr < self.surface) & fluid
        flag = jnp.concatenate([at_surface, jnp.zeros((P.x.shape[0] - nf,), bool)]).astype(P.x.dtype)
        (near,) = pair_sum(_near_pair, P.x, {}, {"flag": flag}, params, nbrs, P.kind, config)
        dr = jnp.where((at_surface | (near > 0))[:, None], tangent, dr)
        dr = jnp.where((fluid & (divr >= self.splash))[:, None], dr, 0.0)
        return jnp.concatenate([dr, jnp.zeros((P.x.shape[0] - nf, 3), dr.dtype)])


def _near_pair(ri, cj, d, params, mask, fluid_j, config):
    """The pair function of the near-surface band: ``flag_j`` over the pairs within the kernel's
    support ``2h``."""
    r2 = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
    h = params.fluid.h
    return (jnp.where(mask & (r2 < 4.0 * h * h), cj["flag"], 0.0),)


@functools.lru_cache(maxsize=None)
def _concentration_pair(R: float):
    """The pair function (``sph.pair_sum``) of the concentration sums: ``V_j (1 + R (W/W(dx))^4) F d``
    (3), ``V_j F d`` (3) and ``-V_j F r^2`` (``div r``), ``F = (dW/dr) / r``, ``d = x_i - x_j``,
    ``V = m / rho``; ``dx`` the row's ``V^(1/3)``."""
    def fn(ri, cj, d, params, mask, fluid_j, config):
        kernel = config.scheme.kernel
        h = params.fluid.h
        r2 = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
        r = safe_norm(r2)
        V = jnp.where(mask, cj["vol"], 0.0)
        F = jnp.where(mask, kernel.f(r, h), 0.0)
        w_dx = kernel.w(jnp.cbrt(ri["vol"]), h)
        weight = 1.0 + R * (kernel.w(r, h) / w_dx) ** 4
        plain = tuple(V * F * d[a] for a in range(3))
        return tuple(weight * p for p in plain) + plain + (-V * F * r2,)

    fn.__name__ = f"concentration_R{R:g}"
    return fn


def _lattice_divergence(vol, h, kernel):
    """``bulk_divergence`` in jit: ``-sum_n dx^3 F(|n| dx) |n dx|^2`` over the lattice offsets of
    spacing ``dx = vol^(1/3)`` (kernels with support 2h, h/dx up to 3, as ``dfsph.lattice_sum``)."""
    from .dfsph import _LATTICE_REACH

    dx = jnp.cbrt(vol)
    n = jnp.arange(-_LATTICE_REACH, _LATTICE_REACH + 1, dtype=jnp.asarray(vol).dtype)
    r2 = dx * dx * (n[:, None, None] ** 2 + n[None, :, None] ** 2 + n[None, None, :] ** 2)
    r = safe_norm(r2)
    return -vol * jnp.sum(jnp.where(r2 > 0, kernel.f(r, h) * r2, 0.0))


def bulk_divergence(kernel, h_over_dx: float) -> float:
    """``div r`` of a particle inside a filled cubic lattice (host): ``-sum_j dx^3 F r^2`` over the
    lattice offsets (3 for a kernel whose discrete moment is exact); ``_lattice_divergence`` at
    unit spacing."""
    return float(_lattice_divergence(1.0, h_over_dx, kernel))
