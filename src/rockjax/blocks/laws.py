"""The contact laws of the blocks: the force a contact point carries, given how deep and how fast.

Owns :class:`ContactLaw` (what every law is given and returns), its input :class:`ContactPoint`
and output :class:`LawResult`, and the laws themselves: :class:`PenaltyCoulomb` (the default).

A law chooses the maths only: it is a frozen (hashable) dataclass held by the static
``BlockConfig.law`` (``make_blocks(law=...)``; another law recompiles). The numbers it reads --
stiffnesses, friction angle, cohesion, damping ratio -- are the differentiable leaves of
``BlockParams``. ``contact.contact_forces`` finds the contact points (geometry), gathers each
point's history slot, calls the law once on the points of a segment of pairs (arrays [S, L, ...]:
S pairs, L law slots), masks the inactive slots and sums the forces onto the blocks.

:class:`SmoothPenaltyCoulomb` is the same law with its four switches (contact onset, the
closing-only dashpot, the stick/slip cap, the count of a pair's points) spread over stated widths,
so that the forces and the history are continuous -- and a loss over a whole event is smooth at
the scale a calibration moves (issue: gradients over the full event; ``rockjax.gradcheck``).

Each contact point carries one history slot from step to step: a 3-vector (world frame;
``ContactHistory.shear``) that follows the point's contact feature (a vertex, a pair of crossing
edges); a new contact starts from zeros. ``PenaltyCoulomb`` keeps its shear spring's displacement
(m) in it.

A new law is one frozen dataclass subclassing :class:`ContactLaw` in this module plus its test
(``tests/blocks/test_laws.py``).
"""

from __future__ import annotations

import abc
import dataclasses
from typing import TYPE_CHECKING, NamedTuple

import jax
import jax.numpy as jnp

from .rotation import safe_norm

if TYPE_CHECKING:  # model imports this module (BlockConfig.law)
    from .model import BlockParams

__all__ = ["ContactLaw", "ContactPoint", "LawResult", "PenaltyCoulomb", "SmoothPenaltyCoulomb", "smooth_ramp",
           "smoothstep", "smoothstep_integral"]


class ContactPoint(NamedTuple):
    """What a contact law is told of its contact points (any leading shape ``[...]``; the
    per-pair fields broadcast against the per-point ones, e.g. [S, 1] against [S, L]).

    The pair is (i, j), its common-plane normal points from i to j; forces are those on j
    (i gets the opposite).
    """

    depth: jax.Array  #: [...] m, penetration of the point (> 0 at every point the law is given)
    normal: jax.Array  #: [..., 3] unit common-plane normal, from i to j
    velocity: jax.Array  #: [..., 3] m/s, velocity of j's material point minus i's, at the point
    reduced_mass: jax.Array  #: [...] kg, the pair's ``1 / (1/m_i + 1/m_j)`` (FIXED blocks: infinite mass)
    pair_points: jax.Array  #: [...] the number of active points of the pair (>= 1, float)


class LawResult(NamedTuple):
    """What a contact law returns per point (forces on j)."""

    normal_force: jax.Array  #: [...] N, along ``ContactPoint.normal``
    tangential_force: jax.Array  #: [..., 3] N, in the contact plane
    history: jax.Array  #: [..., 3], the point's history slot for the next step


class ContactLaw(abc.ABC):
    """A contact law: per contact point, the force from the point's depth, relative velocity and
    history slot. Subclasses are frozen dataclasses (hashable: ``BlockConfig`` is a static
    argument of ``jax.jit``) whose fields, if any, are static choices; physical constants are
    read from ``params``."""

    @abc.abstractmethod
    def __call__(self, point: ContactPoint, history: jax.Array, params: "BlockParams", dt) -> LawResult:
        """Forces on j at the contact points.

        Args:
          point: :class:`ContactPoint`, leading shape [...].
          history: [..., 3] the points' history slots from the last step (zeros for a new contact).
          params: ``BlockParams`` (scalar leaves broadcast over the points).
          dt: s, the step over which the history advances.
        Returns:
          :class:`LawResult` with leading shape [...]. Values at slots the caller masks out
          (inactive points) are discarded, but must be finite.
        """

    def pair_points(self, count, depth, active):
        """The number of points a pair's damping is shared among, [S] float >= 1.

        Args: count [S] int, the pair's active points; depth [S, L] m and active [S, L] bool, its
        points (the law's slots). The default is ``max(count, 1)``; a law that ramps points in
        (:class:`SmoothPenaltyCoulomb`) counts them by weight, so the count does not jump.
        """
        return jnp.maximum(count.astype(depth.dtype), 1.0)


@dataclasses.dataclass(frozen=True)
class PenaltyCoulomb(ContactLaw):
    """Penalty springs with closing-only damping and a Coulomb cap on a shear spring (the default
    law).

    * normal: ``f_n = k_n delta + c_n max(-v_n, 0)`` with ``c_n = 2 zeta sqrt(k_n m_red / n)``, n the
      number of active points of the pair (n points in parallel give the pair's normal mode the
      damping ratio zeta); the dashpot acts only while the gap closes (``v_n < 0``), so with
      ``delta > 0`` the point never pulls;
    * tangential: a spring on the accumulated tangential displacement u (the history slot, first
      projected on the current contact plane, then advanced by ``v_t dt``),
      ``f_t = -k_s u - c_t v_t`` with ``c_t = 2 zeta sqrt(k_s m_red / n)``; where
      ``|f_t| > f_n tan(phi) + cohesion`` the point slips: ``f_t`` is scaled onto that cap and u
      set to ``-f_t / k_s`` (no dashpot while slipping). The norm is gradient-safe.

    Constants from ``BlockParams``: ``normal_stiffness`` k_n (N/m), ``shear_stiffness`` k_s (N/m),
    ``damping_ratio`` zeta, ``friction_angle`` phi (rad), ``cohesion`` (N per point).
    """

    def __call__(self, point: ContactPoint, history: jax.Array, params: "BlockParams", dt) -> LawResult:
        kn, ks = params.normal_stiffness, params.shear_stiffness
        zeta = params.damping_ratio
        # per-point dashpots share the pair's critical damping: n points of stiffness k and
        # c = 2 zeta sqrt(k m_red / n) give the pair's translational mode the ratio zeta
        cn = 2.0 * zeta * jnp.sqrt(kn * point.reduced_mass / point.pair_points)
        ct = 2.0 * zeta * jnp.sqrt(ks * point.reduced_mass / point.pair_points)
        nn, vrel = point.normal, point.velocity
        vn = jnp.sum(vrel * nn, -1)
        fn = kn * point.depth + cn * jnp.maximum(-vn, 0.0)
        vt = vrel - vn[..., None] * nn
        u = history
        u = u - jnp.sum(u * nn, -1, keepdims=True) * nn
        u = u + vt * dt
        ft = -ks * u - ct[..., None] * vt
        cap = fn * jnp.tan(params.friction_angle) + params.cohesion
        fmag = safe_norm(ft)
        slip = fmag > cap
        scale = jnp.where(slip, cap / jnp.where(slip, fmag, 1.0), 1.0)
        ft = ft * scale[..., None]
        u = jnp.where(slip[..., None], -ft / jnp.where(ks > 0, ks, 1.0), u)
        return LawResult(fn, ft, u)


def smooth_ramp(x, width):
    """``max(x, 0)`` with its corner rounded over ``|x| < width`` (C1): 0 for ``x <= -width``,
    ``(x + width)^2 / (4 width)`` between, ``x`` for ``x >= width``; exactly ``max(x, 0)``
    outside the band. ``width`` >= 0 (0: ``max(x, 0)``); gradient-safe at ``width = 0``."""
    w = jnp.asarray(width)
    ws = jnp.where(w > 0, w, 1.0)
    band = (x + ws) ** 2 / (4.0 * ws)
    return jnp.where(x >= w, x, jnp.where(x <= -w, 0.0, band))


def smoothstep(t):
    """``3 t^2 - 2 t^3`` on [0, 1], 0 below and 1 above: a C1 switch (its integral
    :func:`smoothstep_integral` is C2)."""
    t = jnp.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def smoothstep_integral(t):
    """The integral of :func:`smoothstep` from 0 to ``t >= 0``: ``t^3 - t^4 / 2`` on [0, 1], then
    ``t - 1/2``."""
    tc = jnp.clip(t, 0.0, 1.0)
    return jnp.where(t >= 1.0, t - 0.5, tc ** 3 - 0.5 * tc ** 4)


@dataclasses.dataclass(frozen=True)
class SmoothPenaltyCoulomb(PenaltyCoulomb):
    """:class:`PenaltyCoulomb` with its switches spread over stated widths: continuous forces and
    history, so a whole event's outcome is a smooth function of the parameters.

    The same law as :class:`PenaltyCoulomb` outside the bands below (the tests check it):

    * **onset** over a depth ``onset_depth`` d_s [m]: a point's weight ``w = smoothstep(delta /
      d_s)`` rises from 0 to 1; the spring force is ``k_n d_s S(delta / d_s)`` with ``S' = w`` (C2;
      ``k_n (delta - d_s/2)`` beyond d_s: the spring sits d_s/2 deeper than the sharp law's), and
      the dashpots and the cohesion are scaled by w, so a new contact starts from zero force;
    * **the pair's point count** for the damping shares: ``sum w + prod (1 - w)`` (>= 1, the
      integer count when every weight is 0 or 1), instead of a count that jumps;
    * **closing-only dashpot**: ``c_n smooth_ramp(-v_n, closing_speed)`` [m/s] instead of
      ``c_n max(-v_n, 0)``;
    * **stick/slip**: the trial force's magnitude a is replaced by ``cap + smooth_ramp(a - cap,
      slip_band cap)`` (the cap is reached exactly beyond ``(1 + slip_band) cap``; below
      ``(1 - slip_band) cap`` the spring sticks exactly), and the history blends continuously
      from the stick update (u) to the slip update (``-f_t / k_s``) across the band. In steady
      sliding the trial force exceeds the cap by ``k_s v_t dt + c_t v_t``, so sliding is exactly
      Coulomb above the slip speed ``slip_band cap / (k_s dt + c_t)``.

    Choose ``onset_depth`` about the depth a contact closes in one step at the impact speed
    (``v dt``) or more, and well below the static penetration's scale of interest; the default
    10 um suits blocks of 0.1-1 m at the default stiffness. Fields are static (a new width
    recompiles).
    """

    onset_depth: float = 1e-5  #: m, depth over which a point's forces ramp in
    closing_speed: float = 1e-3  #: m/s, width of the closing-only dashpot's switch
    slip_band: float = 0.05  #: relative half-width of the stick/slip band around the Coulomb cap

    def __post_init__(self):
        for name in ("onset_depth", "closing_speed", "slip_band"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v > 0 and v == v and v != float("inf")):
                raise ValueError(f"SmoothPenaltyCoulomb: {name} must be a positive finite number (got {v!r})")
        if self.slip_band >= 1.0:
            raise ValueError(f"SmoothPenaltyCoulomb: slip_band must be < 1 (got {self.slip_band})")

    def weight(self, depth):
        """The ramp-in weight of points at ``depth`` [m] (0 at contact, 1 beyond ``onset_depth``)."""
        return smoothstep(depth / self.onset_depth)

    def pair_points(self, count, depth, active):
        w = jnp.where(active, self.weight(depth), 0.0)
        return jnp.sum(w, -1) + jnp.prod(1.0 - w, -1)

    def __call__(self, point: ContactPoint, history: jax.Array, params: "BlockParams", dt) -> LawResult:
        kn, ks = params.normal_stiffness, params.shear_stiffness
        zeta = params.damping_ratio
        w = self.weight(point.depth)
        cn = 2.0 * zeta * jnp.sqrt(kn * point.reduced_mass / point.pair_points) * w
        ct = 2.0 * zeta * jnp.sqrt(ks * point.reduced_mass / point.pair_points) * w
        nn, vrel = point.normal, point.velocity
        vn = jnp.sum(vrel * nn, -1)
        fn = kn * self.onset_depth * smoothstep_integral(point.depth / self.onset_depth) \
            + cn * smooth_ramp(-vn, self.closing_speed)
        vt = vrel - vn[..., None] * nn
        u = history
        u = u - jnp.sum(u * nn, -1, keepdims=True) * nn
        u = u + vt * dt
        ft = -ks * u - ct[..., None] * vt
        cap = fn * jnp.tan(params.friction_angle) + params.cohesion * w
        a = safe_norm(ft)
        band = self.slip_band * cap
        excess = a - cap
        # the magnitude after the cap: a below the band, cap above it, a C1 blend between
        capped = a - smooth_ramp(excess, band)
        scale = jnp.where(a > 0, capped / jnp.where(a > 0, a, 1.0), 1.0)
        ft_out = ft * scale[..., None]
        # stick fraction: 1 below the band, 0 above it (the ramp's slope), continuous across
        bs = jnp.where(band > 0, band, 1.0)
        stick = jnp.where(excess <= -band, 1.0, jnp.where(excess >= band, 0.0, 0.5 - 0.5 * excess / bs))
        ks_safe = jnp.where(ks > 0, ks, 1.0)
        # stick: u (= -(f_t + c_t v_t) / k_s); slip: -f_t / k_s (the spring carries the capped force)
        u_new = -(ft_out + (stick * ct)[..., None] * vt) / ks_safe
        u_new = jnp.where(ks > 0, u_new, u)
        return LawResult(fn, ft_out, u_new)
