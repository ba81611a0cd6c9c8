"""The contact laws of the blocks: the force a contact point carries, given how deep and how fast.

Owns :class:`ContactLaw` (what every law is given and returns), its input :class:`ContactPoint`
and output :class:`LawResult`, and the laws themselves: :class:`PenaltyCoulomb` (the default).

A law chooses the maths only: it is a frozen (hashable) dataclass held by the static
``BlockConfig.law`` (``make_blocks(law=...)``; another law recompiles). The numbers it reads --
stiffnesses, friction angle, cohesion, damping ratio -- are the differentiable leaves of
``BlockParams``. ``contact.contact_forces`` finds the contact points (geometry), gathers each
point's history slot, calls the law once on the points of a segment of pairs (arrays [S, L, ...]:
S pairs, L law slots), masks the inactive slots and sums the forces onto the blocks.

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

__all__ = ["ContactLaw", "ContactPoint", "LawResult", "PenaltyCoulomb"]


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
