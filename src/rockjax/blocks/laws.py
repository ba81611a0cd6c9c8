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

__all__ = ["ContactLaw", "ContactPoint", "LawResult", "PenaltyCoulomb", "SmoothPenaltyCoulomb", "onset_factor",
           "smooth_ramp", "smoothstep", "smoothstep_integral"]


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

    ``resolve_step`` (default True) makes the normal force the mean force over the step the
    integrator applies it to (``advance_blocks``: the force at t_n kicks the velocity from
    t_n - dt/2 to t_n + dt/2), not the force at the step's start:

    * the dashpot sees the closing speed at t_n, not the state's mid-step speed w = -v_n (half a
      step old): ``w_n = max(w - dt n f_s / (2 m_red), 0.9 w) / (1 + zeta omega dt)``, with
      f_s the point's spring force, ``n f_s / m_red`` the pair's deceleration by its springs and
      ``zeta omega dt = c_n n dt / (2 m_red)``: the trapezoidal (centred) dashpot of the pair's
      normal mode, ``c_n (w_{n-1/2} + w_{n+1/2}) / 2``. The law does not know the static load (a
      resting block's weight offsets its springs' deceleration), so the estimate is kept at
      ``CLOSING_FLOOR w = 0.9 w`` or more: a resting contact keeps 90 % of its damping on small
      closing speeds (a floor of 0.5 would halve it, for drops within 0.25 % instead of 0.5 %);
    * a point's first step in contact (``delta < w dt``: it was apart at t_{n-1}) carries the
      impulse from the onset inside the step, ``t_n - delta / w``, to ``t_n + dt/2`` (the
      contact closing at w): the spring ``k_n (delta + w dt/2)^2 / (2 w dt)`` and the dashpot
      ``c_n w_n (1/2 + delta / (w dt))``, instead of ``k_n delta`` and ``c_n w_n`` whatever the
      onset's phase.

    Why: at the blocks' default step (``stable_dt``, seed Eq 8 with safety 0.5) a box landing
    flat is in contact for only 15-20 steps (omega dt = 0.13-0.18 for its 4 corners), and the
    plain force made the restitution of a drop depend on where in the step the contact began
    (for zeta = 0.5, -11 % to +2 % of the closed form ``exp(-zeta arccos(zeta) /
    sqrt(1 - zeta^2))``) and its damping lag by half a step (the bias of that range). Resolved,
    it is within 0.5 % at every phase (``tests/blocks/test_restitution_phase.py``,
    ``experiments/restitution_phase.py``); a point at rest or opening is unchanged (the spring
    alone, the dashpot off), so is a static load. False: the plain force ``k_n delta + c_n w``.
    """

    resolve_step: bool = True  #: the normal force averaged over the step (onset phase, centred dashpot)

    def _floor(self, x):
        """``max(x, CLOSING_FLOOR)`` for ``x = 1 - decel / w`` (the smooth law rounds it)."""
        return jnp.maximum(x, CLOSING_FLOOR)

    def _centred_closing(self, closing, spring, cn, point: ContactPoint, dt):
        """The closing speed the dashpot sees at the step's time [m/s] (``resolve_step``): from the
        state's mid-step one ``closing`` [m/s, >= 0], the point's spring force ``spring`` [N] and its
        dashpot ``cn`` [N s/m] (see the class doc)."""
        m, n = point.reduced_mass, point.pair_points
        decel = 0.5 * dt * n * spring / m  # m/s: half a step of the pair's deceleration by its springs
        zwdt = 0.5 * dt * n * cn / m  # zeta omega dt of the pair's normal mode
        fast = closing > decel  # else the floor holds (the ratio bounded for the gradients)
        ratio = jnp.where(fast, decel / jnp.where(fast, closing, 1.0), 1.0)
        return closing * self._floor(1.0 - ratio) / (1.0 + zwdt)

    def __call__(self, point: ContactPoint, history: jax.Array, params: "BlockParams", dt) -> LawResult:
        kn, ks = params.normal_stiffness, params.shear_stiffness
        zeta = params.damping_ratio
        # per-point dashpots share the pair's critical damping: n points of stiffness k and
        # c = 2 zeta sqrt(k m_red / n) give the pair's translational mode the ratio zeta
        cn = 2.0 * zeta * jnp.sqrt(kn * point.reduced_mass / point.pair_points)
        ct = 2.0 * zeta * jnp.sqrt(ks * point.reduced_mass / point.pair_points)
        nn, vrel = point.normal, point.velocity
        vn = jnp.sum(vrel * nn, -1)
        closing = jnp.maximum(-vn, 0.0)
        spring = kn * point.depth
        if self.resolve_step:
            w_n = self._centred_closing(closing, spring, cn, point, dt)
            step = closing * dt  # m, the depth the contact closes in one step
            first = (point.depth > 0) & (point.depth < step)  # apart at the last step: the onset is in this one
            step_s = jnp.where(first, step, 1.0)
            onset = point.depth + 0.5 * step  # m, closed from the onset to the step's end
            fn = jnp.where(first, kn * onset * onset / (2.0 * step_s) + cn * w_n * (onset / step_s),
                           spring + cn * w_n)
        else:
            fn = spring + cn * closing
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


#: the least fraction of the mid-step closing speed the resolved dashpot sees (``PenaltyCoulomb.resolve_step``)
CLOSING_FLOOR = 0.9


def onset_factor(x):
    """The dashpot's factor over a contact's first two steps, ``x`` = depth / (closing speed dt)
    (the steps closed since the onset): ``3.5 x^2 - 2 x^3`` on [0, 1], ``1 + 2 u^3 - 3.5 u^2 + u +
    1/2`` (u = x - 1) on [1, 2], 1 beyond; C1, 0 at the onset.

    Why: the step's force at t_n stands for the impulse over [t_n - dt/2, t_n + dt/2], and a
    contact that began at a phase s in (0, 1] of the last step (depth ``s w dt`` now) has had the
    dashpot's force ``c w`` for ``(s + 1/2) dt`` by ``t_n + dt/2``, not dt: its first two steps
    must carry ``s - 1/2`` steps of it more than the plain force. This factor does so for every s
    (``f(s) + f(s + 1) = s + 3/2``) at a constant closing speed, and is continuous in the depth
    and the speed.
    """
    x = jnp.clip(x, 0.0, 2.0)
    u = x - 1.0
    return jnp.where(x <= 1.0, x * x * (3.5 - 2.0 * x), 1.5 + u * (1.0 + u * (-3.5 + 2.0 * u)))


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
      Coulomb above the slip speed ``slip_band cap / (k_s dt + c_t)``;
    * ``resolve_step``: the dashpot sees the same centred closing speed as the sharp law's, its
      floor rounded: ``w max(1 - r, 0.9)`` with ``r = dt n f_s / (2 m_red w)`` becomes
      ``w (0.9 + smooth_ramp(0.1 - r, 0.05))`` (the sharp law's for r outside [0.05, 0.15], and 0
      where w is, unlike a rounded ``max(w - ..., 0.9 w)``); the onset's phase is
      resolved continuously: instead of the sharp law's first-step impulse (a jump), the
      dashpot's factor :func:`onset_factor` of the depth in steps closed (``delta / (w dt)``)
      spreads the same impulse over the first two steps, faded out as the onset band spans a
      step (by ``1 - smoothstep(d_s / (w dt))``: a band of a step or more resolves the onset by
      itself).

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

    def _floor(self, x):
        return CLOSING_FLOOR + smooth_ramp(x - CLOSING_FLOOR, 0.5 * (1.0 - CLOSING_FLOOR))

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
        spring = kn * self.onset_depth * smoothstep_integral(point.depth / self.onset_depth)
        closing = smooth_ramp(-vn, self.closing_speed)
        if self.resolve_step:
            step = jnp.maximum(-vn, 0.0) * dt  # m, the depth the contact closes in one step
            # depth in steps closed (capped at 2: the factor is 1 from there) and the onset band in
            # steps (capped at 1: the factor is off from there), both bounded for the gradients
            near = step > 0.5 * point.depth
            x = jnp.where(near, point.depth / jnp.where(near, step, 1.0), 2.0)
            wide = step > self.onset_depth
            band = jnp.where(wide, self.onset_depth / jnp.where(wide, step, 1.0), 1.0)
            factor = 1.0 + (1.0 - smoothstep(band)) * (onset_factor(x) - 1.0)
            closing = self._centred_closing(closing, spring, cn, point, dt) * factor
        fn = spring + cn * closing
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
