"""Contact points and the per-step contact forces of the blocks.

Owns :func:`contact_forces` (broad phase -> history remap -> FCP -> contact points -> the contact
law ``BlockConfig.law`` (module ``laws``) -> forces and torques on each block) and the contact
points of a pair (:func:`pair_contacts`); the history it reads and returns is
``model.ContactHistory`` (``BlockState.history``). The per-pair part (FCP, points, law, joint water) runs over the pair buffer in segments of ``BlockConfig.pair_segment`` slots and
skips a segment holding no overlapping pair (``_segmented``); the pairs' loads are then summed
onto the blocks. With ``BlockConfig.skip_separated`` (default) a candidate pair whose stored
common plane still separates it by more than the contact tolerances can reach across
(:func:`separated_pairs`) is not evaluated (no contact, zero load, plane kept), and the evaluated
pairs are gathered to the front so that segments of separated ones are skipped whole.

Contact points of a pair (i, j) with common-plane normal n (from i to j) -- padded, masked, never
pruned; each point carries its contact *feature* (a vertex, a pair of edges, the fallback: an id,
``ContactHistory.contact_feature``) by which its history slot follows it from step to step:

* vertices of j inside block i (slot = vertex of j): depth = distance from the vertex along +n
  to the boundary of i (local: a tilted face gives each corner its own depth);
* vertices of i inside block j (slot = vertex of i): depth = distance along -n out of j;
* edge-edge crossings (feature = edge of i x edge of j): the two edges, projected on the common
  plane, cross strictly inside both; the crossing point of i's edge lies inside j and that of
  j's edge inside i; depth = n.(p_i - p_j) > 0. Sought among the edges of each block with a part
  inside the other only, the first ``BlockConfig.crossing_edges`` (8) of them (more set
  ``Status.CROSSING_EDGE_OVERFLOW``): 64 crossing slots instead of max_edges^2 (144 for boxes,
  ~900 for 12-vertex rocks);
* fallback (one slot): if the pair overlaps but none of the above exists (an edge passing
  through a face), one point at the centre of the edges clipped by the other block, depth = the
  common-plane overlap.

"Inside" is the face-plane test with a tolerance of ``inside_tolerance x radius`` (points on a
side face, as at the corners of a face-on-face contact, count).

The contact law (``BlockConfig.law``, default ``laws.PenaltyCoulomb``: penalty springs,
closing-only damping, Coulomb cap on a shear spring) runs over each pair's active points gathered
into ``BlockConfig.law_slots`` slots (a box pair has up to 16 of its 81 slots), and the law's
history is kept in those slots with each point's feature: a point takes the history of the last
step's slot with its feature (none: a new contact, zeros). A pair with more active points sets
``Status.CONTACT_POINT_OVERFLOW``. Forces are those on j; i gets the opposite; torques about
each centroid.

With ``BlockConfig.joint_water`` the pair's contact patch (the polygon of its active points) also
carries the hydrostatic pressure of a still water level, pushing the two blocks apart
(``joint_water``).  With a ``joint_aperture`` a > 0 the patch is that of the near contact (both
blocks grown by a/2) and its load fades out smoothly (smoothstep) as the common-plane gap opens
from 0 to a, so that a resting block's patch does not flicker with its micro-rocking.  It is
added to the blocks' forces, not to the springs: at rest the springs then carry the total normal
load minus the water's, so the Coulomb cap follows the effective normal force (Terzaghi's
effective stress).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..types import Status
from .broadphase import aabbs, candidate_pairs, pairs_are_static
from .fcp import _first_k, fcp_pair, gap_along, sat_start
from .joint_water import joint_water_load
from .laws import ContactLaw, ContactPoint, smoothstep
from .model import (BlockConfig, BlockParams, BlockShape, BlockState, ContactHistory, Motion, block_mass,
                    world_planes, world_vertices)
from .rotation import project, safe_norm, tied_max, tied_min

__all__ = ["contact_forces", "pair_contacts"]


def _inside(pts, N, D, fm, tol):
    """[...] bool: points [...,3] inside the planes N [F,3], D [F] (``N.x - D <= tol``)."""
    s = project(pts, N) - D
    return jnp.all(jnp.where(fm, s <= tol, True), -1)


def _exit_distance(X, N, D, fm, u):
    """[V] m: distance along the unit direction u from each point X [V,3] to the boundary of the
    polyhedron (N [F,3], D [F]), for points inside it (faces with N.u <= 1e-3 are never crossed)."""
    den = project(N, u)  # [F]
    ok = fm & (den > 1e-3)
    t = (D[None, :] - project(X, N)) / jnp.where(ok, den, 1.0)[None, :]
    return tied_min(jnp.where(ok[None, :], t, 1e30), -1)


def _tangent_basis(n):
    a = jnp.where(jnp.abs(n[0]) < 0.6, jnp.array([1.0, 0.0, 0.0], n.dtype), jnp.array([0.0, 1.0, 0.0], n.dtype))
    t1 = jnp.cross(n, a)
    t1 = t1 / safe_norm(t1)
    t2 = jnp.cross(n, t1)
    return t1, t2


class PairContacts(NamedTuple):
    """Contact points of one pair (:func:`pair_contacts`), S slots."""

    points: jax.Array  #: [S,3] m
    depth: jax.Array  #: [S] m (0 where inactive)
    active: jax.Array  #: [S] bool
    feature: jax.Array  #: [S] int32, each slot's contact feature (``ContactHistory.contact_feature``)
    edge_overflow: jax.Array  #: [] bool: a block has more edges inside the other than the crossing slots


def pair_contacts(Xi, mi, Ni, Di, fmi, ei, emi, ri, Xj, mj, Nj, Dj, fmj, ej, emj, rj, n, gap, *,
                  tol_rel: float, edge_contacts: bool, slack: float = 0.0, crossing_edges: int = 0):
    """Contact points of one pair for the common-plane normal n.

    ``slack`` (m) > 0 gives the points of the pair's *near* contact instead: both blocks grown by
    ``slack`` (points within that distance of the other block count; the joint-water patch).

    Edge-edge crossings are sought among the edges of each block with a part inside the other
    (the only ones whose crossing point can lie inside it), the first ``crossing_edges`` of them
    (``BlockConfig.crossing_edges``; 0 or >= nE: every edge, no selection); more set
    ``edge_overflow`` (unless the other block has none, when no crossing exists).

    Args:
      X*: [V,3] world vertices; m*: [V]; N*: [F,3] world normals; D*: [F] offsets; fm*: [F];
      e*: [nE,2] edges; em*: [nE]; r*: [] bounding radii (m).  n: [3] unit normal i -> j;
      gap: [] m, the common-plane gap (< 0: overlap).
    Returns:
      :class:`PairContacts` with S = 2 V (+ k^2 with edge contacts, k the crossing edges) + 1 slots.
    """
    V, nE = Xi.shape[0], ei.shape[0]
    tol_i, tol_j = tol_rel * ri, tol_rel * rj
    if slack:
        Di, Dj = Di + slack, Dj + slack
    # vertices of j inside i (depth: distance to leave i along +n), vertices of i inside j (along -n)
    dj = _exit_distance(Xj, Ni, Di, fmi, n)
    aj = mj & _inside(Xj, Ni, Di, fmi, tol_i) & (dj > 0)
    di = _exit_distance(Xi, Nj, Dj, fmj, -n)
    ai = mi & _inside(Xi, Nj, Dj, fmj, tol_j) & (di > 0)
    pts = [Xj, Xi]
    dep = [dj, di]
    act = [aj, ai]
    feat = [jnp.arange(2 * V, dtype=jnp.int32)]
    overflow = jnp.zeros((), bool)
    if edge_contacts:
        eps = 1e-3
        a0, dA3 = Xi[ei[:, 0]], Xi[ei[:, 1]] - Xi[ei[:, 0]]
        b0, dB3 = Xj[ej[:, 0]], Xj[ej[:, 1]] - Xj[ej[:, 0]]
        # the part of each edge inside the other block: a crossing point of i's edge a0 + s dA3
        # lies inside j iff s is within [lo_i, hi_i] (per edge, not per crossing), likewise for j
        lo_i, hi_i = _inside_interval(a0, dA3, Nj, Dj, fmj, tol_j)
        lo_j, hi_j = _inside_interval(b0, dB3, Ni, Di, fmi, tol_i)
        k = nE if crossing_edges <= 0 or crossing_edges >= nE else crossing_edges
        if k < nE:  # only edges with a part strictly inside (eps, 1 - eps) can cross
            ci = emi & (hi_i > eps) & (lo_i < 1 - eps) & (lo_i <= hi_i)
            cj = emj & (hi_j > eps) & (lo_j < 1 - eps) & (lo_j <= hi_j)
            idx_i, over_i = _first_k(ci, k)
            idx_j, over_j = _first_k(cj, k)
            # a crossing needs an edge of each: edges of one block do not count while the other
            # has none inside it (a rock's bottom edges within a floor slab's tolerance, say)
            overflow = (over_i & jnp.any(cj)) | (over_j & jnp.any(ci))

            def take(a, idx):
                return jnp.take(a, idx, axis=0, mode="fill", fill_value=0)

            a0, dA3, lo_i, hi_i = (take(a, idx_i) for a in (a0, dA3, lo_i, hi_i))
            b0, dB3, lo_j, hi_j = (take(a, idx_j) for a in (b0, dB3, lo_j, hi_j))
            em_a, em_b = idx_i < nE, idx_j < nE
        else:
            idx_i = idx_j = jnp.arange(nE, dtype=jnp.int32)
            em_a, em_b = emi, emj
        t1, t2 = _tangent_basis(n)

        def p2(x):
            return jnp.stack([project(x, t1), project(x, t2)], -1)

        A0, dA = p2(a0), p2(dA3)
        B0, dB = p2(b0), p2(dB3)

        def cross2(u, w):
            return u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]

        w = B0[None, :, :] - A0[:, None, :]  # [k, k, 2]
        den = cross2(dA[:, None, :], dB[None, :, :])
        la = safe_norm(dA)[:, None]
        lb = safe_norm(dB)[None, :]
        ok = (jnp.abs(den) > 1e-6 * la * lb) & em_a[:, None] & em_b[None, :]
        den_s = jnp.where(ok, den, 1.0)
        s = cross2(w, dB[None, :, :]) / den_s
        u = cross2(w, dA[:, None, :]) / den_s
        ok = ok & (s > eps) & (s < 1 - eps) & (u > eps) & (u < 1 - eps)
        ok = ok & (s >= lo_i[:, None]) & (s <= hi_i[:, None]) & (u >= lo_j[None, :]) & (u <= hi_j[None, :])
        # depth n.(p - q) from per-edge projections on n
        de = (project(a0, n)[:, None] + s * project(dA3, n)[:, None]
              - project(b0, n)[None, :] - u * project(dB3, n)[None, :])
        ok = ok & (de > -2.0 * slack)
        mid = 0.5 * (a0[:, None, :] + s[..., None] * dA3[:, None, :] + b0[None, :, :] + u[..., None] * dB3[None, :, :])
        pts.append(mid.reshape(-1, 3))
        dep.append(de.reshape(-1))
        act.append(ok.reshape(-1))
        feat.append((2 * V + idx_i[:, None] * nE + idx_j[None, :]).reshape(-1))
    # fallback slot: an overlap (gap < 0) with none of the points above -- an edge passing through
    # a face, where no vertex lies inside and no two edges cross -- gets one point at the centre of
    # the edge segments clipped by the other block, with the common-plane overlap as depth
    ci, ki = _clipped_centre(Xi, ei, emi, Nj, Dj, fmj)
    cj, kj = _clipped_centre(Xj, ej, emj, Ni, Di, fmi)
    none = ~jnp.any(jnp.concatenate(act, 0))
    k = ki + kj
    fb_ok = none & (gap < 0) & (k > 0)
    pts.append(((ci + cj) / jnp.maximum(k, 1.0))[None])
    dep.append(-gap[None])
    act.append(fb_ok[None])
    feat.append(jnp.full((1,), 2 * V + nE * nE, jnp.int32))
    points = jnp.concatenate(pts, 0)
    depth = jnp.concatenate(dep, 0)
    active = jnp.concatenate(act, 0)
    return PairContacts(points, jnp.where(active, depth, 0.0), active, jnp.concatenate(feat, 0), overflow)


def _inside_interval(x0, d, N, D, fm, tol):
    """The parameters t for which the points ``x0 + t d`` of each edge (x0, d [nE,3]) lie inside
    the planes N [F,3], D [F] within ``tol`` (``N.x - D <= tol``, as :func:`_inside`): ``(lo, hi)``
    [nE], empty (lo > hi) where none does. Faces parallel to the edge bound it only through its
    start point."""
    al = project(x0, N) - D - tol  # [nE, F]: inside while al + t be <= 0
    be = project(d, N)
    t = -al / jnp.where(be != 0, be, 1.0)
    hi = jnp.min(jnp.where(fm & (be > 0), t, jnp.inf), -1)
    lo = jnp.max(jnp.where(fm & (be < 0), t, -jnp.inf), -1)
    out = jnp.any(fm & (be == 0) & (al > 0), -1)
    return jnp.where(out, jnp.inf, lo), hi


def _clipped_centre(X, e, em, N, D, fm):
    """Sum of the end points of the edges (X [V,3], e [nE,2]) clipped to the polyhedron (N, D) and
    their count: ``(sum [3], count [])`` (Cyrus-Beck clipping)."""
    a0, a1 = X[e[:, 0]], X[e[:, 1]]
    s0 = project(a0, N) - D  # [nE, F]
    s1 = project(a1, N) - D
    out = fm & (s0 > 0) & (s1 > 0)
    den = jnp.where(jnp.abs(s0 - s1) > 0, s0 - s1, 1.0)
    t = s0 / den
    enter = fm & (s0 > 0) & (s1 <= 0)
    leave = fm & (s0 <= 0) & (s1 > 0)
    t0 = tied_max(jnp.where(enter, t, 0.0), -1)
    t1 = tied_min(jnp.where(leave, t, 1.0), -1)
    ok = em & ~jnp.any(out, -1) & (t0 < t1)
    p0 = a0 + t0[:, None] * (a1 - a0)
    p1 = a0 + t1[:, None] * (a1 - a0)
    w = ok.astype(X.dtype)[:, None]
    return jnp.sum(w * (p0 + p1), 0), 2.0 * jnp.sum(w)


def _take_slots(a, slot):
    """``a`` [S, n, ...] at the slots ``slot`` [S, k] (``_active_slots``): [S, k, ...], zeros (False)
    where the index is out of bounds; ``a`` itself when ``slot`` is None."""
    if slot is None:
        return a
    return jnp.take_along_axis(a, slot.reshape(slot.shape + (1,) * (a.ndim - 2)), 1, mode="fill", fill_value=0)


def _active_slots(active, k: int):
    """[S, k] int32: per pair, the indices of its active contact slots (in slot order), then the
    out-of-bounds index (gathers fill it, scatters drop it); None when ``k`` is 0 or covers every
    slot. A pair with more than ``k`` active slots loses some (``contact_forces`` flags it: the
    law's ``Status.CONTACT_POINT_OVERFLOW``, the joint patch's ``JOINT_PATCH_OVERFLOW``)."""
    S, n = active.shape
    if k <= 0 or k >= n:
        return None
    # scattered by their rank among the active slots (measured on CPU, 512 pairs x 161 slots:
    # 0.24 ms; lax.top_k 3.8 ms); positions past the pair's count hold n, out of bounds
    rank = jnp.where(active, jnp.cumsum(active.astype(jnp.int32), 1) - 1, k)
    slots = jnp.broadcast_to(jnp.arange(n, dtype=jnp.int32), (S, n))
    return jnp.full((S, k), n, jnp.int32).at[jnp.arange(S)[:, None], rank].set(slots, mode="drop")


def _segmented(fn, live, args, seg: int, fill=None):
    """``fn(*args)`` over the leading (pair) axis of ``args`` in segments of ``seg`` rows, skipping
    (``lax.cond``) a segment with no ``live`` row: its outputs are zeros, or ``fill[key]`` for the
    keys of ``fill`` (a dict) when ``fn`` returns a dict.

    ``fn`` maps arrays [S, ...] to a pytree of arrays [S, ...]; ``live`` [P] bool; ``args`` arrays
    [P, ...]. ``seg <= 0`` or ``>= P``: one call, nothing skipped. Under ``jax.vmap`` the ``cond``
    becomes a select (every segment evaluated, as with one call).

    The outputs are buffers [P, ...] carried through the loop (filled first), each evaluated
    segment written into them in place (``dynamic_update_slice``; the last segment's rows clamped
    into [0, P): rows it shares with the one before are evaluated again, to the same values): a
    skipped segment writes nothing. From ``SEGMENT_GROUPS_FROM`` segments on they are skipped in
    two levels, groups of ``ceil(sqrt(segments))`` segments, a group with no live row skipped
    whole: the evaluated pairs are gathered to the front, so few groups are live and a step runs
    about ``2 sqrt(segments)`` loop iterations instead of ``segments``."""
    P = live.shape[0]
    if seg <= 0 or seg >= P:
        return fn(*args)
    n_seg = -(-P // seg)
    group = 1 if n_seg < SEGMENT_GROUPS_FROM else int(np.ceil(np.sqrt(n_seg)))
    n_grp = -(-n_seg // group)
    pad = n_grp * group * seg - P
    lv = jnp.concatenate([live, jnp.zeros((pad,), bool)]) if pad else live
    live_seg = jnp.any(lv.reshape(n_grp * group, seg), -1)
    fill = fill or {}

    def empty(path, s):  # s: an output of one segment [seg, ...]
        key = getattr(path[0], "key", None) if path else None
        return jnp.full((P,) + s.shape[1:], fill.get(key, 0), s.dtype)

    bufs = jax.tree_util.tree_map_with_path(empty, jax.eval_shape(fn, *(a[:seg] for a in args)))

    def evaluate(k, bufs):  # segment k: rows [k seg, k seg + seg), the last one clamped into [0, P)
        start = jnp.minimum(k * seg, P - seg)
        out = fn(*(jax.lax.dynamic_slice_in_dim(a, start, seg) for a in args))
        return jax.tree_util.tree_map(lambda b, o: jax.lax.dynamic_update_slice_in_dim(b, o, start, 0), bufs, out)

    def segment(bufs, k):
        return jax.lax.cond(live_seg[k], evaluate, lambda k, b: b, k, bufs), None

    ks = jnp.arange(n_grp * group, dtype=jnp.int32)
    if group == 1:
        return jax.lax.scan(segment, bufs, ks)[0]

    def segment_group(bufs, kg):
        return jax.lax.cond(jnp.any(live_seg[kg]), lambda b: jax.lax.scan(segment, b, kg)[0], lambda b: b,
                            bufs), None

    return jax.lax.scan(segment_group, bufs, ks.reshape(n_grp, group))[0]


#: :func:`_segmented` skips in two levels (groups of segments) from this many segments on
SEGMENT_GROUPS_FROM = 12


def _to_front(keep):
    """``(rank [P], order [P])`` int32: the permutation that gathers the ``keep`` [P] rows to the
    front, each part in its order (``a[order]``; row p goes to ``rank[p]``, so ``b[rank]`` undoes
    it) -- a stable partition by two prefix sums, no sort."""
    k = keep.astype(jnp.int32)
    n = jnp.sum(k)
    rank = jnp.where(keep, jnp.cumsum(k) - 1, n + jnp.cumsum(1 - k) - 1)
    P = keep.shape[0]
    order = jnp.zeros(P, jnp.int32).at[rank].set(jnp.arange(P, dtype=jnp.int32), unique_indices=True)
    return rank, order


def separated_pairs(Xw, vertex_mask, shape, pairs, plane, plane_valid, *, tol_rel: float, slack: float = 0.0):
    """Which pairs are certainly contact-free: their stored common plane still separates them by
    more than the contact tests' tolerances can reach across.

    A point counts as inside block k when it is within ``t = tol_rel r_k (+ slack)`` of every
    face plane of k (``pair_contacts``). That grown block lies within k scaled about its
    centroid by ``1 + t / d_k`` (``d_k`` the centroid's distance to its nearest face plane), so
    its support along any direction exceeds k's by at most ``t r_k / d_k``. Along a plane with
    gap ``g`` greater than the two margins' sum, no vertex or edge crossing of one block lies
    within the grown other: no contact point, and the pair's forces are zero.

    Args:
      Xw: [B,V,3] m world vertices; vertex_mask [B,V]; shape: ``BlockShape`` (radius, face
        offsets about the centroid); pairs [P,2]; plane [P,3] the stored normals; plane_valid [P].
      tol_rel: ``BlockConfig.inside_tolerance``; slack: m, the joint-water patch's growth.
    Returns:
      ``(separated [P] bool, gap [P] m)``: the gap along the stored plane (a lower bound of the
      common plane's) and whether it exceeds the margins (only where ``plane_valid``).
    """
    r = shape.radius
    d = jnp.min(jnp.where(shape.face_mask, shape.face_offset, jnp.inf), 1)  # [B] centroid to nearest face
    margin = (tol_rel * r + slack) * r / jnp.maximum(d, 1e-12 * r)  # [B] m
    i, j = pairs[:, 0], pairs[:, 1]
    n = jax.lax.stop_gradient(plane)
    X = jax.lax.stop_gradient(Xw)
    gap = jax.vmap(lambda n, Xi, mi, Xj, mj: gap_along(n[None], Xi, mi, Xj, mj)[0][0])(
        n, X[i], vertex_mask[i], X[j], vertex_mask[j])
    return plane_valid & (gap > margin[i] + margin[j]), gap


def _remap(old: ContactHistory, pairs, mask, B):
    """Carry plane / shear history from the old pair buffer to the new one (matching (i, j))."""
    big = B * B + 1
    okey = jnp.where(old.pair_mask, old.pairs[:, 0] * B + old.pairs[:, 1], big)
    order = jnp.argsort(okey)
    sk = okey[order]
    nkey = pairs[:, 0] * B + pairs[:, 1]
    pos = jnp.clip(jnp.searchsorted(sk, nkey), 0, sk.shape[0] - 1)
    found = mask & (sk[pos] == nkey)
    src = order[pos]
    return ContactHistory(
        pairs=pairs,
        pair_mask=mask,
        plane=old.plane[src],
        plane_valid=found & old.plane_valid[src],
        shear=old.shear[src],
        contact_feature=jnp.where(found[:, None], old.contact_feature[src], -1),
        box_lo=old.box_lo,
        box_hi=old.box_hi,
    )


def _kept_or_rebuilt(config: BlockConfig, old: ContactHistory, Xw, vmask):
    """The candidate pairs of this step: the last step's list, or (``lax.cond``) a new one from
    ``candidate_pairs`` with the history carried over (``_remap``) when some block's box (no
    margin) has moved by more than half the AABB margin ``m`` (any face of it, m) since the
    list was built.

    Why it finds the same contacts: a pair whose boxes now overlap or lie within ``m`` of each
    other had, at the build, boxes within ``m + 2 (m / 2) = 2 m``, the margin the build used (each
    box grown by ``m``), so it is in the list; contact points (within ``inside_tolerance`` of a
    block) and the joint water (within the aperture, which the margin covers) need no pair
    farther apart. A kept pair that has moved apart is still evaluated or skipped
    (``separated_pairs``) with zero load, as a farther candidate would be.

    Returns ``(ContactHistory, status int32)``: the broad phase's overflow bits of a rebuild.
    """
    lo, hi = aabbs(Xw, vmask, 0.0)
    drift = jnp.max(jnp.maximum(jnp.abs(lo - old.box_lo), jnp.abs(hi - old.box_hi)))
    stale = ~(drift <= 0.5 * config.aabb_margin)  # also NaN / inf: the first step builds

    def rebuild(old):
        pairs, mask, status = candidate_pairs(config, Xw, vmask)
        return _remap(old, pairs, mask, config.n_blocks).replace(box_lo=lo, box_hi=hi), status

    return jax.lax.cond(stale, rebuild, lambda old: (old, jnp.int32(0)), old)


class _Bodies(NamedTuple):
    """The blocks at the current poses as the per-pair passes read them (row b: block b)."""

    X: jax.Array  #: [B,V,3] m world vertices
    N: jax.Array  #: [B,F,3] world face normals
    D: jax.Array  #: [B,F] m face offsets (``N.x <= D`` inside)
    shape: BlockShape
    x: jax.Array  #: [B,3] m centroids
    v: jax.Array  #: [B,3] m/s
    omega: jax.Array  #: [B,3] rad/s
    inv_m: jax.Array  #: [B] 1/kg (0 for FIXED / PRESCRIBED blocks)


def _common_planes(b: _Bodies, i, j, plane, plane_valid, *, iterations: int, support_edges: int, crosses: int):
    """The Fast Common Plane of the pairs (i, j) [S], warm-started from ``plane`` [S,3] where
    ``plane_valid`` [S]: ``fcp.fcp_pair``'s dict (normal [S,3], gap [S] m, ...)."""
    sh = b.shape
    return jax.vmap(lambda *a: fcp_pair(*a, iterations=iterations, support_edges=support_edges, crosses=crosses))(
        b.X[i], sh.vertex_mask[i], b.N[i], sh.face_mask[i], sh.edges[i], sh.edge_mask[i],
        b.X[j], sh.vertex_mask[j], b.N[j], sh.face_mask[j], sh.edges[j], sh.edge_mask[j],
        b.x[i], b.x[j], plane, plane_valid,
        (sh.edge_direction[i], sh.direction_edge[i], sh.direction_mask[i], sh.vertex_direction[i]),
        (sh.edge_direction[j], sh.direction_edge[j], sh.direction_mask[j], sh.vertex_direction[j]),
    )


def _pair_points(b: _Bodies, config: BlockConfig, i, j, n, gap, slack: float = 0.0) -> PairContacts:
    """:func:`pair_contacts` of the pairs (i, j) [S] for their normals n [S,3] and gaps [S] (m)."""
    sh = b.shape
    return jax.vmap(lambda *a: pair_contacts(*a, tol_rel=config.inside_tolerance, edge_contacts=config.edge_contacts,
                                             slack=slack, crossing_edges=config.crossing_slots))(
        b.X[i], sh.vertex_mask[i], b.N[i], b.D[i], sh.face_mask[i], sh.edges[i], sh.edge_mask[i], sh.radius[i],
        b.X[j], sh.vertex_mask[j], b.N[j], b.D[j], sh.face_mask[j], sh.edges[j], sh.edge_mask[j], sh.radius[j],
        n, gap)


def _law_loads(law: ContactLaw, params: BlockParams, dt, b: _Bodies, i, j, n, pts, depth, active, n_points, history):
    """The contact law at the points of the pairs (i, j) [S] and the pairs' loads.

    Args:
      law: ``BlockConfig.law``.  dt: s.  n: [S,3] unit normals i -> j.  pts: [S,L,3] m world
        points; depth: [S,L] m; active: [S,L] bool; n_points: [S] int32, each pair's active points
        (the law shares the pair's damping among them); history: [S,L,3] the law's slots.
    Returns:
      ``(f_n [S,L] N, f_t [S,L,3] N, history [S,L,3], F_j [S,3] N, T_j [S,3] N m, T_i [S,3] N m)``:
      per point the forces on j and the new history slot (zeros at inactive points); per pair the
      force on j and the torques on j and i about their centroids (i gets ``-F_j``).
    """
    m_red = 1.0 / jnp.maximum(b.inv_m[i] + b.inv_m[j], 1e-30)  # [S] kg
    n_act = law.pair_points(n_points, depth, active)  # [S] the pair's damping shares (>= 1)
    ri = pts - b.x[i][:, None, :]
    rj = pts - b.x[j][:, None, :]
    vi = b.v[i][:, None, :] + jnp.cross(b.omega[i][:, None, :], ri)
    vj = b.v[j][:, None, :] + jnp.cross(b.omega[j][:, None, :], rj)
    nn = n[:, None, :]
    res = law(ContactPoint(depth=depth, normal=nn, velocity=vj - vi, reduced_mass=m_red[:, None],
                           pair_points=n_act[:, None]), history, params, dt)
    fn = jnp.where(active, res.normal_force, 0.0)
    ft = jnp.where(active[..., None], res.tangential_force, 0.0)
    history = jnp.where(active[..., None], res.history, 0.0)
    F = fn[..., None] * nn + ft  # on j, [S,L,3]
    return fn, ft, history, jnp.sum(F, 1), jnp.sum(jnp.cross(rj, F), 1), -jnp.sum(jnp.cross(ri, F), 1)


def _joint_water_loads(b: _Bodies, params: BlockParams, config: BlockConfig, gravity, i, j, mask, n, gap,
                       pts, active):
    """The hydrostatic load of the pairs' (i, j) [S] contact patches (``BlockConfig.joint_water``).

    Args:
      gravity: [3] m/s^2.  mask: [S] bool.  n: [S,3] unit normals i -> j; gap: [S] m.
      pts, active: [S,C,3] m, [S,C] the pairs' contact points (the patch without an aperture).
    Returns:
      dict: ``Fj``, ``Tj``, ``Ti`` [S,3] (N, N m: the load on j, the torques on j and i about their
      centroids), ``near_overflow`` [S] (the near patch's crossing-edge overflow), and the
      diagnostics ``joint_water_force`` [S,3], ``joint_points``, ``joint_active``, ``joint_count``.
    """
    t1, t2 = jax.vmap(_tangent_basis)(n)
    ap = config.joint_aperture
    if ap > 0:  # the patch of the near contact, faded out over the aperture
        near = _pair_points(b, config, i, j, n, gap, slack=0.5 * ap)
        wpts, wact = near.points, near.active & mask[:, None]
        near_overflow = near.edge_overflow & mask
        s_gap = jnp.clip(gap / ap, 0.0, 1.0)
        fade = 1.0 - s_gap * s_gap * (3.0 - 2.0 * s_gap)
    else:
        wpts, wact, fade = pts, active, jnp.ones_like(gap)
        near_overflow = jnp.zeros_like(mask)
    n_wact = jnp.sum(wact.astype(jnp.int32), 1)
    patch = _active_slots(wact, config.joint_patch_points)  # overflow flagged by contact_forces
    if ap > 0 and config.joint_fade_points:
        # closeness of each near point: a vertex's exit distance from the other block grown by
        # ap/2 runs from 0 (leaving the joint, ap/2 away) to ap/2 (touching); an edge crossing's
        # overlap from -ap (leaving) to 0 (touching), mapped onto the same scale. Weight 0 -> 1
        # between closeness 0 and ap/4; the point moves in from the weighted centre, so the hull's
        # area is continuous as points come and go
        vertex = near.feature < 2 * b.X.shape[1]
        close = jnp.where(vertex, near.depth, 0.5 * (near.depth + ap))
        wdep = _take_slots(jnp.where(wact, close, 0.0), patch)
        wpts, wact = _take_slots(wpts, patch), _take_slots(wact, patch)
        wgt = jnp.where(wact, smoothstep(wdep / (0.25 * ap)), 0.0)  # [S, C]
        tot = jnp.sum(wgt, 1, keepdims=True)
        ctr = jnp.sum(wgt[..., None] * wpts, 1) / jnp.where(tot > 0, tot, 1.0)  # [S, 3]
        wpts = ctr[:, None, :] + wgt[..., None] * (wpts - ctr[:, None, :])
    else:
        wpts, wact = _take_slots(wpts, patch), _take_slots(wact, patch)
    Fw, fw, mw = jax.vmap(lambda *a: joint_water_load(
        *a, level=params.joint_water_level, density=params.joint_water_density, gravity=gravity))(
            wpts, wact, n, t1, t2)
    Fw, fw, mw = Fw * fade[:, None], fw * fade, mw * fade[:, None]
    return dict(Fj=Fw, Tj=jnp.cross(mw - fw[:, None] * b.x[j], n), Ti=-jnp.cross(mw - fw[:, None] * b.x[i], n),
                near_overflow=near_overflow, joint_water_force=Fw, joint_points=wpts, joint_active=wact,
                joint_count=n_wact)


def contact_forces(state: BlockState, params: BlockParams, config: BlockConfig, *, dt, gravity=None,
                   return_info: bool = False):
    """Contact forces and torques on every block at the current poses.

    Args:
      state, params, config: the blocks.  dt: s, the step the law's history advances over.
      gravity: [3] m/s^2, needed when ``config.joint_water`` (the joints' hydrostatic pressure,
        ``joint_water``); ignored otherwise.
      return_info: also return a dict of per-pair/per-slot diagnostics.
    Returns:
      ``(force [B,3] N, torque [B,3] N m, history ContactHistory, status int32)`` -- forces ON each
      block, torques about its centroid, world frame; the history for ``state.history`` of the
      next step; plus ``info`` when asked.
    """
    B = config.n_blocks
    sh = state.shape
    f = state.x.dtype
    old = state.history
    if old.shear.shape[1] != config.history_slots:  # trace time: the shapes are static
        raise ValueError(f"contact_forces: the state's shear history has {old.shear.shape[1]} slots per pair, "
                         f"config.history_slots is {config.history_slots} (law_slots / crossing_edges changed): "
                         "refit it with rockjax.blocks.fit_history(config, state)")
    Xw = world_vertices(state)
    Nw, Dw = world_planes(state)
    if pairs_are_static(config):
        pairs, mask, status = candidate_pairs(config, Xw, sh.vertex_mask)
        hist = ContactHistory(pairs, mask, old.plane, old.plane_valid & mask, old.shear,
                              jnp.where(mask[:, None], old.contact_feature, -1), old.box_lo, old.box_hi)
    else:
        hist, status = _kept_or_rebuilt(config, old, Xw, sh.vertex_mask)
        pairs, mask = hist.pairs, hist.pair_mask
    dyn = jnp.asarray([m == Motion.DYNAMIC for m in config.motion])
    m = block_mass(state, params)
    if config.joint_water:
        if gravity is None:
            raise ValueError("contact_forces: config.joint_water needs gravity=")
        gvec = jnp.asarray(gravity, f)

    # blocks with few edge directions (boxes, prisms) start the FCP from every separating axis: an
    # overlapping pair's plane is then exact without iterations, and only the joint water's fade
    # reads a separated pair's gap (which the iterations may still raise)
    n_dir = sh.direction_edge.shape[1]
    complete = sat_start(n_dir) and not config.joint_water
    iterations = 0 if complete else config.fcp_iterations
    warm_iterations = 0 if complete else min(config.fcp_warm_iterations, iterations)
    support_edges = config.support_edges if 0 < config.support_edges < n_dir else 0
    crosses = config.fcp_crosses if support_edges and 0 < config.fcp_crosses < support_edges ** 2 else 0
    bodies = _Bodies(Xw, Nw, Dw, sh, state.x, state.v, state.omega, jnp.where(dyn, 1.0 / m, 0.0))

    # the law's history (``law_slots`` per pair, most of the buffer's bytes) is read by row (``src``)
    # inside the evaluated segments only: a skipped segment and the reordering below never touch it
    old_shear, old_feature = hist.shear, hist.contact_feature

    def pair_forces(i, j, mask, plane, plane_valid, src):
        """Common plane, contact points and contact law of the pairs (i, j) [S] (a segment of the
        buffer; their law history at rows ``src`` [S] of the step's history): per-pair forces on j
        and torques on i and j, the new history, diagnostics."""
        shear = jnp.take(old_shear, src, axis=0, mode="clip")
        feature_old = jnp.take(old_feature, src, axis=0, mode="clip")
        def planes(its):
            return lambda: _common_planes(bodies, i, j, plane, plane_valid, iterations=its,
                                          support_edges=support_edges, crosses=crosses)

        if warm_iterations == iterations:
            fcp = planes(iterations)()
        else:  # a segment whose pairs all carry last step's plane: its last round is exact from there
            fcp = jax.lax.cond(jnp.all(plane_valid | ~mask), planes(warm_iterations), planes(iterations))
        n = fcp["normal"]
        pc = _pair_points(bodies, config, i, j, n, fcp["gap"])
        active_all = pc.active & mask[:, None]
        depth_all = jnp.where(active_all, pc.depth, 0.0)
        n_points = jnp.sum(active_all.astype(jnp.int32), 1)
        # the law runs over the pair's active slots only (gathered to the front, in slot order)
        slot = _active_slots(active_all, config.law_slots)
        pts, depth, active, feature = (_take_slots(a, slot) for a in (pc.points, depth_all, active_all, pc.feature))
        feature = jnp.where(active, feature, -1)
        # each point's history slot from the last step's slot holding the same feature (one-hot:
        # features are unique within a pair; none: a new contact, zeros)
        same = (feature[:, :, None] == feature_old[:, None, :]) & (feature[:, :, None] >= 0)
        shear = jnp.einsum("skm,smc->skc", same.astype(f), shear)
        fn, ft, shear, Fj, Tj, Ti = _law_loads(config.law, params, dt, bodies, i, j, n, pts, depth, active,
                                               n_points, shear)

        def per_slot(a):  # [S, law slots, ...] -> [S, contact slots, ...] (zeros at inactive slots)
            if slot is None:
                return a
            rows = jnp.arange(a.shape[0])[:, None]
            return jnp.zeros(active_all.shape + a.shape[2:], a.dtype).at[rows, slot].set(a, mode="drop")

        rmin = jnp.minimum(sh.radius[i], sh.radius[j])
        out = dict(normal=n, gap=fcp["gap"],
                   support_overflow=fcp["support_overflow"] & mask, cross_overflow=fcp["cross_overflow"] & mask,
                   n_points=n_points, edge_overflow=pc.edge_overflow & mask, shear=shear, contact_feature=feature,
                   Fj=Fj, Tj=Tj, Ti=Ti, deep=jnp.any(depth_all > config.penetration_limit * rmin[:, None], 1))
        if return_info:  # the per-slot arrays (~80 slots a pair): only for the diagnostics
            out.update(fcp_changes=fcp["changes"], points=pc.points, depth=depth_all, active=active_all,
                       feature=pc.feature, normal_force=per_slot(fn), tangential_force=per_slot(ft))
        if config.joint_water:
            w = _joint_water_loads(bodies, params, config, gvec, i, j, mask, n, fcp["gap"], pc.points, active_all)
            out["edge_overflow"] = out["edge_overflow"] | w.pop("near_overflow")
            for k in ("Fj", "Tj", "Ti"):
                out[k] = out[k] + w.pop(k)
            out["joint_count"] = w.pop("joint_count")
            if return_info:
                out.update(w)
        return out

    i, j = pairs[:, 0], pairs[:, 1]
    rows = jnp.arange(mask.shape[0], dtype=jnp.int32)
    args = (i, j, mask, hist.plane, hist.plane_valid, rows)
    fill = {"feature": -1, "contact_feature": -1}
    if config.skip_separated:
        # pairs their stored plane still separates beyond the contact tolerances are not evaluated
        # (no contact points, zero forces, plane kept); the rest are gathered to the front so that
        # whole segments of separated pairs are skipped
        slack = 0.5 * config.joint_aperture if config.joint_water else 0.0
        clear, warm_gap = separated_pairs(Xw, sh.vertex_mask, sh, pairs, hist.plane, hist.plane_valid,
                                          tol_rel=config.inside_tolerance, slack=slack)
        if config.joint_water:  # the joint load fades out by gap = aperture
            clear = clear & (warm_gap >= config.joint_aperture)
        keep = mask & ~clear
        P = mask.shape[0]
        if 0 < config.pair_segment < P:
            rank, order = _to_front(keep)
            if pairs_are_static(config):  # the static list keeps its order: the results go back
                per = _segmented(pair_forces, keep[order], tuple(a[order] for a in args), config.pair_segment, fill)
                per = {k: v[rank] for k, v in per.items()}
            else:  # the list itself is reordered (any order serves; the next step reads it as it is)
                hist = hist.replace(pairs=hist.pairs[order], pair_mask=hist.pair_mask[order], plane=hist.plane[order],
                                    plane_valid=hist.plane_valid[order], shear=None, contact_feature=None)
                pairs, mask, keep, warm_gap = hist.pairs, hist.pair_mask, keep[order], warm_gap[order]
                i, j = pairs[:, 0], pairs[:, 1]
                args = (i, j, mask, hist.plane, hist.plane_valid, order)
                per = _segmented(pair_forces, keep, args, config.pair_segment, fill)
        else:
            per = pair_forces(*args)
        alt = {"normal": hist.plane, "gap": warm_gap}

        def kept(k, v):
            other = alt[k] if k in alt else jnp.full_like(v, fill.get(k, 0))
            return jnp.where(keep.reshape(keep.shape + (1,) * (v.ndim - 1)), v, other)

        # a pair not kept has no active point: its law slots are already empty (zeros, -1)
        per = {k: v if k in ("shear", "contact_feature") else kept(k, v) for k, v in per.items()}
    else:
        keep = mask
        per = _segmented(pair_forces, mask, args, config.pair_segment, fill=fill)
    n = per["normal"]
    Fj, Tj, Ti = per["Fj"], per["Tj"], per["Ti"]
    if 0 < config.law_slots < config.contact_slots:
        over = jnp.any(per["n_points"] > config.law_slots)
        status = status | jnp.where(over, Status.CONTACT_POINT_OVERFLOW.value, 0).astype(jnp.int32)
    if config.crossing_slots < config.max_edges:
        over = jnp.any(per["edge_overflow"])
        status = status | jnp.where(over, Status.CROSSING_EDGE_OVERFLOW.value, 0).astype(jnp.int32)
    if support_edges:
        over = jnp.any(per["support_overflow"])
        status = status | jnp.where(over, Status.SUPPORT_EDGE_OVERFLOW.value, 0).astype(jnp.int32)
    if crosses:
        over = jnp.any(per["cross_overflow"])
        status = status | jnp.where(over, Status.FCP_CROSS_OVERFLOW.value, 0).astype(jnp.int32)
    if config.joint_water and config.joint_patch_points < config.contact_slots:
        over = jnp.any(per["joint_count"] > config.joint_patch_points)
        status = status | jnp.where(over, Status.JOINT_PATCH_OVERFLOW.value, 0).astype(jnp.int32)
    force = jnp.zeros((B, 3), f).at[j].add(Fj).at[i].add(-Fj)
    torque = jnp.zeros((B, 3), f).at[j].add(Tj).at[i].add(Ti)

    hist = ContactHistory(pairs=pairs, pair_mask=mask, plane=jax.lax.stop_gradient(n), plane_valid=mask,
                          shear=per["shear"], contact_feature=per["contact_feature"], box_lo=hist.box_lo,
                          box_hi=hist.box_hi)
    deep = jnp.any(per["deep"])
    status = status | jnp.where(deep, Status.BLOCK_PENETRATION.value, 0).astype(jnp.int32)
    if return_info:
        info = dict(pairs=pairs, pair_mask=mask, evaluated=keep, n_contacts=jnp.sum(per["active"].astype(jnp.int32)),
                    **{k: per[k] for k in ("normal", "gap", "fcp_changes", "points", "depth", "active", "feature",
                                           "normal_force", "tangential_force")})
        if config.joint_water:
            info.update({k: per[k] for k in ("joint_water_force", "joint_points", "joint_active")})
        return force, torque, hist, status, info
    return force, torque, hist, status
