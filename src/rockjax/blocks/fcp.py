"""Fast Common Plane (FCP) narrow phase for one pair of convex polyhedra (seed section 3).

Owns the search for the common plane (CP) of two blocks i and j, after Nezami et al. (2004):

* The gap of a unit normal n (pointing from i to j) is ``g(n) = min_j n.x - max_i n.x``: positive
  when the plane separates the blocks, ``-g`` is the overlap along n.  The CP maximises g; for
  overlapping blocks its normal is the minimum-penetration axis.
* Start (step i): the best of the plane stored for this pair last step (warm start), the
  perpendicular bisector of the centroids, and -- a cheap addition to the paper -- every face
  normal of both blocks (robust cold start).
* Iterate a FIXED number of times (``lax.fori_loop``; steps ii-iv): take the support ("closest")
  vertices A of i and B of j for the current plane, score the candidate normals built from the
  features at A and B (seed types a-d: the bisector of AB; face normals; cross products of an
  edge at A and an edge at B; the component of AB normal to an edge at A or B) plus the current
  plane, and keep the one with the largest gap (each candidate in its better orientation).
  Keeping the current plane makes the gap non-decreasing.  Parallel edges give the same
  candidates, so types c and d are built once per edge *direction* (``BlockShape.direction_edge``).
  "At A" means at every vertex of the support set of i (ties within round-off: a whole face when
  n is a face normal), not one arbitrary vertex -- see ``_local_candidates``.
* The search runs on stopped gradients; one last candidate round on the live geometry makes the
  chosen normal differentiable with respect to the block poses.

All functions are per pair; ``jax.vmap`` them over the candidate-pair buffer.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax import lax

from .rotation import project, tied_max, tied_min

__all__ = ["fcp_pair", "gap_along", "sat_start", "SAT_START_LIMIT"]

_BIG = 1e30


# Candidate normals are held component-major, [3, C]: the narrow phase's arrays then have the
# candidates as their minor axis, which XLA:CPU vectorises (as [C, 3] every operation ran over a
# minor axis of 3: building a rock pair's ~440 candidates cost twice their scoring).


def _normalise(c, valid, rel_eps):
    """Unit vectors of the columns of ``c`` [3,C]; columns shorter than ``rel_eps`` (squared) are invalid."""
    s = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
    ok = valid & (s > rel_eps)
    inv = lax.rsqrt(jnp.where(ok, s, 1.0))
    return c * inv[None, :], ok


def _project_t(X, Nt):
    """[V,3] points X, [3,C] directions Nt -> [V,C] (``X @ Nt`` as three multiply-adds)."""
    return X[:, 0, None] * Nt[0] + X[:, 1, None] * Nt[1] + X[:, 2, None] * Nt[2]


def gap_along(normals, Xi, mi, Xj, mj):
    """Gaps of candidate normals in both orientations.

    Args:
      normals: [C,3] unit normals.  Xi, Xj: [V,3] world vertices (m).  mi, mj: [V] masks.
    Returns:
      ``(g_plus, g_minus)`` [C] m: ``min_j n.x - max_i n.x`` for n and for -n.
    """
    return _gaps(normals.T, Xi, mi, Xj, mj)


def _gaps(normals_t, Xi, mi, Xj, mj):
    """:func:`gap_along` of component-major normals [3,C]."""
    pi = _project_t(Xi, normals_t)  # [V, C]
    pj = _project_t(Xj, normals_t)
    max_i = tied_max(jnp.where(mi[:, None], pi, -_BIG), 0)
    min_i = tied_min(jnp.where(mi[:, None], pi, _BIG), 0)
    max_j = tied_max(jnp.where(mj[:, None], pj, -_BIG), 0)
    min_j = tied_min(jnp.where(mj[:, None], pj, _BIG), 0)
    return min_j - max_i, min_i - max_j


def _best(cands, valid, Xi, mi, Xj, mj, tie):
    """The candidate [3,C] (in its better orientation) with the largest gap: ``(normal [3], gap [])``.

    Candidates within ``tie`` [m] of the largest gap tie, and the FIRST of them in candidate order
    wins. A plain argmax would let round-off pick among them (a box resting flat on a slope: its
    face normal, the slope's and the carried plane give the same gap), and the programs of a
    forward run and of its gradient round differently: the gradient then followed another normal
    than the run it differentiates (measured: a -O0 compile's gradient 30x off the finite
    difference). ``tie`` is 16 ulps of the coordinates (:func:`_tie_tolerance`)."""
    gp, gm = _gaps(cands, Xi, mi, Xj, mj)
    g = jnp.maximum(gp, gm)
    sign = jnp.where(gp >= gm, 1.0, -1.0).astype(cands.dtype)
    g = jnp.where(valid, g, -_BIG)
    k = jnp.argmax(g >= jnp.max(g) - tie)
    return cands[:, k] * sign[k], g[k]


def _tie_tolerance(Xi, mi, Xj, mj):
    """[] m: gaps closer than this tie in :func:`_best` -- 16 ulps of the largest vertex
    coordinate of the pair (what a projection's round-off scales with), from stopped values."""
    big = jnp.maximum(jnp.max(jnp.abs(Xi) * mi[:, None]), jnp.max(jnp.abs(Xj) * mj[:, None]))
    return lax.stop_gradient(16 * jnp.finfo(Xi.dtype).eps * big)


def vertex_directions(edges, edge_mask, n_vertices: int, edge_direction=None, n_directions: int | None = None):
    """Which edge directions touch each vertex: [V, nD] bool, True where vertex v is an end of an
    edge in ``edge_mask`` [nE] whose direction group (``edge_direction`` [nE]) is d.  Without
    ``edge_direction`` every edge is its own direction ([V, nE]).  It depends on the shape only, so
    it is built once per block, outside the FCP rounds (one small matrix product, no scatter)."""
    onehot_v = (edges[:, :, None] == jnp.arange(n_vertices, dtype=edges.dtype)).any(1)  # [nE, V]
    inc = (onehot_v & edge_mask[:, None]).astype(jnp.float32)
    if edge_direction is None:
        return inc.T > 0
    member = (edge_direction[:, None] == jnp.arange(n_directions, dtype=edge_direction.dtype)).astype(jnp.float32)
    return (inc.T @ member) > 0  # [V, nD]


def _direction_vectors(X, e, dirs):
    """[3,nD] m (component-major): each edge direction's vector (its representative edge's, from
    the vertices X [V,3]); ``dirs`` None: every edge's [3,nE]."""
    rep = jnp.arange(e.shape[0]) if dirs is None else dirs[1]
    return (X[e[rep, 1]] - X[e[rep, 0]]).T


def _directions(X, e, em, dirs):
    """A block's edge directions for the FCP rounds: ``(vectors [3,nD] m, mask [nD],
    vertex_direction [V,nD])``.  ``dirs`` is ``(edge_direction [nE], direction_edge [nD],
    direction_mask [nD])``, optionally followed by the precomputed :func:`vertex_directions` table,
    or None (every edge its own direction)."""
    if dirs is None:
        return _direction_vectors(X, e, None), em, vertex_directions(e, em, X.shape[0])
    group, rep, dm = dirs[:3]
    vd = dirs[3] if len(dirs) > 3 else vertex_directions(e, em, X.shape[0], group, rep.shape[0])
    return _direction_vectors(X, e, dirs), dm, vd


def _first_k(cand, k: int):
    """The indices of the first ``k`` True entries of ``cand`` [n] (in order; ``n`` past the
    count) and whether there were more than ``k``: ``(idx [k] int32, overflow [])``."""
    n = cand.shape[0]
    rank = jnp.cumsum(cand.astype(jnp.int32)) - 1
    hit = cand[None, :] & (rank[None, :] == jnp.arange(k, dtype=jnp.int32)[:, None])  # [k, n], one-hot rows
    # the True column of each row, as a sum (an argmax is a slow variadic reduction on XLA:CPU)
    idx = jnp.sum(jnp.where(hit, jnp.arange(n, dtype=jnp.int32), 0), -1)
    return jnp.where(jnp.arange(k) <= rank[-1], idx, n).astype(jnp.int32), rank[-1] >= k


def _support_edges(e, m, k: int):
    """The first ``k`` columns of the edge vectors ``e`` [3,n] in the mask ``m`` [n] (in order),
    their mask, and whether ``m`` held more: ``(e [3,k], m [k], overflow [])``. ``k`` 0 or >= n:
    unchanged."""
    n = e.shape[1]
    if k <= 0 or k >= n:
        return e, m, jnp.zeros((), bool)
    idx, over = _first_k(m, k)
    return jnp.take(e, idx, axis=1, mode="fill", fill_value=0), idx < n, over


def _cross(a, b):
    """Cross products of the edge vectors ``a`` and ``b`` (each three broadcastable component
    arrays) and whether each is valid, i.e. the edges are not parallel: ``(cross [3,...], ok [...])``."""
    (a0, a1, a2), (b0, b1, b2) = a, b
    cr = jnp.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    ref = (a0 * a0 + a1 * a1 + a2 * a2) * (b0 * b0 + b1 * b1 + b2 * b2)
    return cr, cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2] > 1e-10 * ref


def _crosses(ea, ma, eb, mb):
    """Every cross product of an edge vector of ``ea`` [3,Ka] and one of ``eb`` [3,Kb], flattened
    [3, Ka Kb] (a-major), and which are valid: both edges in their masks and not parallel."""
    cr, ok = _cross(tuple(c[:, None] for c in ea), tuple(c[None, :] for c in eb))
    return cr.reshape(3, -1), (ma[:, None] & mb[None, :] & ok).reshape(-1)


def _crosses_first(ea, na, eb, nb, cap: int):
    """The cross products of the first ``na`` columns of ``ea`` [3,Ka] with the first ``nb`` of
    ``eb`` [3,Kb], a-major (the order of :func:`_crosses`' valid ones when its masks are those
    prefixes), enumerated into ``cap`` slots (slot t: a = t // nb, b = t % nb).

    Returns ``(crosses [3,cap], valid [cap], overflow [])``: valid as :func:`_crosses` (in the
    rectangle, not parallel); overflow when ``na nb > cap`` (the crosses past ``cap`` are missing)."""
    t = jnp.arange(cap, dtype=jnp.int32)
    nb_ = jnp.maximum(nb, 1).astype(jnp.int32)
    inside = t < na * nb
    a, b = jnp.where(inside, t // nb_, 0), jnp.where(inside, t % nb_, 0)
    cr, ok = _cross(jnp.take(ea, a, axis=1), jnp.take(eb, b, axis=1))
    return cr, inside & ok, na * nb > cap


def _local_candidates(n, Xi, mi, Nti, fmi, di, Xj, mj, Ntj, fmj, dj, scale, support_edges: int = 0,
                      crosses: int = 0):
    """Seed candidate types a-d at the support features of the plane n, plus n itself (last).

    The "closest vertices" of the paper are generalised to the support SETS (all vertices
    within round-off of the extreme value): when n is a face normal, every vertex of that face
    ties, and the paper's "any of them" can miss the edge that defines the plane (measured: ~10 %
    of random overlaps stall).  Candidates: every face normal of both blocks (cheap), the
    crosses of the edges touching the support set of i with those touching the support set of j
    (type c), the bisector of AB (type a) and AB minus its part along each such edge (type d).
    Parallel edges give the same candidates, so types c and d are built once per edge direction
    (``di`` / ``dj`` from :func:`_directions`, built once per pair outside the rounds): a box pair
    scores 29 candidates instead of 182.
    With ``support_edges`` = k (0: all), the edges (directions) touching each support set are first
    gathered into k columns (in order, so the candidates and their ties are those of the full set):
    a 12-vertex rock pair scores ~k^2 + 2k + 42 candidates instead of 1000. With ``crosses`` = c
    as well (0 < c < k^2), the ka x kb crosses of the gathered directions (ka, kb of them touching
    the two support sets) are enumerated into c slots instead of k^2 (:func:`_crosses_first`; the
    same valid crosses in the same order, so the same plane while ka kb <= c).

    Args: as :func:`fcp_pair`, but the face normals ``Nti``, ``Ntj`` [3,F] component-major.
    Returns:
      ``(candidates [3,C] unit, valid [C], support_overflow [], cross_overflow [])``: a support set
      touched more than ``support_edges`` directions, or ka kb exceeded ``crosses`` (some
      candidates were not scored).
    """
    pi = project(Xi, n)
    pj = project(Xj, n)
    sup_i = jnp.max(jnp.where(mi, pi, -_BIG))
    sup_j = jnp.min(jnp.where(mj, pj, _BIG))
    tau = 64 * jnp.finfo(Xi.dtype).eps * scale
    set_i = mi & (pi >= sup_i - tau)
    set_j = mj & (pj <= sup_j + tau)
    A = jnp.argmax(jnp.where(mi, pi, -_BIG))
    B = jnp.argmin(jnp.where(mj, pj, _BIG))
    d = Xj[B] - Xi[A]
    ea, ma = di[0], di[1] & jnp.any(set_i[:, None] & di[2], 0)  # the directions touching the support sets
    eb, mb = dj[0], dj[1] & jnp.any(set_j[:, None] & dj[2], 0)
    ea, ma, over_a = _support_edges(ea, ma, support_edges)
    eb, mb, over_b = _support_edges(eb, mb, support_edges)
    if support_edges > 0 and 0 < crosses < ea.shape[1] * eb.shape[1] and ea.shape[1] < di[0].shape[1]:
        # gathered: the masks are prefixes, so the valid crosses are the top-left ka x kb block
        cr, cr_ok, over_c = _crosses_first(ea, jnp.sum(ma.astype(jnp.int32)), eb, jnp.sum(mb.astype(jnp.int32)),
                                           crosses)
    else:
        cr, cr_ok = _crosses(ea, ma, eb, mb)  # type c; parallel edges invalid
        over_c = jnp.zeros((), bool)
    e_all = jnp.concatenate([ea, eb], 1)  # [3, 2k]
    l_all = e_all[0] * e_all[0] + e_all[1] * e_all[1] + e_all[2] * e_all[2]
    m_all = jnp.concatenate([ma, mb], 0)
    proj = (e_all[0] * d[0] + e_all[1] * d[1] + e_all[2] * d[2]) / jnp.where(m_all, l_all, 1.0)
    perp = d[:, None] - proj[None, :] * e_all  # type d
    eps_abs = (1e-6 * scale) ** 2
    perp_ok = m_all & (perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2] > eps_abs)
    d_ok = jnp.sum(d * d) > eps_abs
    cands = jnp.concatenate([Nti, -Ntj, cr, perp, d[:, None], n[:, None]], 1)
    valid = jnp.concatenate([fmi, fmj, cr_ok, perp_ok, d_ok[None], jnp.ones(1, bool)], 0)
    return (*_normalise(cands, valid, 0.0), over_a | over_b, over_c)


#: the start holds every cross product of two edge directions (with the face normals: every
#: separating axis) when the padded direction counts multiply to at most this (boxes: 3 x 3)
SAT_START_LIMIT = 64


def sat_start(n_directions: int) -> bool:
    """Whether blocks padded to ``n_directions`` edge directions get the complete start."""
    return n_directions * n_directions <= SAT_START_LIMIT


def fcp_pair(Xi, mi, Ni, fmi, ei, emi, Xj, mj, Nj, fmj, ej, emj, ci, cj, n_prev, prev_valid, dirs_i=None, dirs_j=None,
             *, iterations: int, support_edges: int = 0, crosses: int = 0):
    """Common plane of blocks i and j.

    Args:
      Xi, Xj: [V,3] world vertices (m); mi, mj: [V] vertex masks.
      Ni, Nj: [F,3] world outward face normals; fmi, fmj: [F] face masks.
      ei, ej: [nE,2] edges (vertex pairs); emi, emj: [nE] edge masks.
      ci, cj: [3] centroids (m).  n_prev: [3] last plane normal (i -> j); prev_valid: [] bool.
      dirs_i, dirs_j: the blocks' edge directions ``(edge_direction [nE], direction_edge [nD],
        direction_mask [nD])`` (``BlockShape``), optionally followed by their
        ``vertex_directions`` table [V,nD] (built here, once per pair, when absent), or None to
        treat every edge as its own direction (the same plane, found with more candidates). With
        directions and ``sat_start`` of their count, the start also holds every cross product of
        a direction of i and one of j: with the face normals, every separating axis, so for an
        overlapping pair the start is already the minimum-penetration plane and the iterations
        keep it (a separated pair's gap may still grow with them: the largest gap is not always
        along a separating axis).
      iterations: fixed FCP iteration count (static).
      support_edges: the candidates of a round are built from at most this many edge directions
        touching each support set (``BlockConfig.support_edges``; 0: every direction).
      crosses: with ``support_edges``, the crosses of a round's gathered directions are enumerated
        into this many slots (``BlockConfig.fcp_crosses``; 0: support_edges^2, every slot).
    Returns:
      dict with ``normal`` [3] (unit, i -> j), ``gap`` [] m (min_j n.x - max_i n.x; < 0 overlap),
      ``support_i`` [] = max_i n.x, ``support_j`` [] = min_j n.x, ``changes`` [] int32 (iterations
      that improved the plane by more than 1e-7 of the block size), ``support_overflow`` [] bool (a
      support set touched more than ``support_edges`` directions in some round), ``cross_overflow``
      [] bool (a round had more crosses than ``crosses``).
    """
    scale = jnp.maximum(jnp.max(jnp.abs(Xi - ci) * mi[:, None]), jnp.max(jnp.abs(Xj - cj) * mj[:, None]))
    sg = lax.stop_gradient
    sXi, sXj, sNi, sNj, sscale = sg(Xi), sg(Xj), sg(Ni), sg(Nj), sg(scale)
    cdir = sg(cj - ci)
    sNti, sNtj = sNi.T, sNj.T  # component-major (see _normalise)
    init = [sNti, -sNtj, cdir[:, None], sg(n_prev)[:, None]]
    init_ok = [fmi, fmj, jnp.ones(1, bool), jnp.reshape(prev_valid, (1,))]
    di, dj = _directions(sXi, ei, emi, dirs_i), _directions(sXj, ej, emj, dirs_j)  # the rounds' (no gradient)
    if dirs_i is not None and dirs_j is not None and sat_start(max(dirs_i[1].shape[0], dirs_j[1].shape[0])):
        cr, cr_ok = _crosses(di[0], di[1], dj[0], dj[1])
        init.append(cr)
        init_ok.append(cr_ok)
    init, init_ok = _normalise(jnp.concatenate(init, 1), jnp.concatenate(init_ok, 0), 1e-30)
    tie = _tie_tolerance(sXi, mi, sXj, mj)
    n0, g0 = _best(init, init_ok, sXi, mi, sXj, mj, tie)

    def body(_, carry):
        n, g, changes, over, over_c = carry
        c, ok, o, oc = _local_candidates(n, sXi, mi, sNti, fmi, di, sXj, mj, sNtj, fmj, dj, sscale, support_edges,
                                         crosses)
        n1, g1 = _best(c, ok, sXi, mi, sXj, mj, tie)
        changes = changes + (g1 > g + 1e-7 * sscale).astype(jnp.int32)
        return n1, g1, changes, over | o, over_c | oc

    no = jnp.zeros((), bool)
    n_s, _, changes, over, over_c = lax.fori_loop(0, iterations, body, (n0, g0, jnp.int32(0), no, no))
    # differentiable last round on the live geometry (ties pick a geometric candidate, not n_s: it
    # comes last)
    live_i = (_direction_vectors(Xi, ei, dirs_i), *di[1:])
    live_j = (_direction_vectors(Xj, ej, dirs_j), *dj[1:])
    c, ok, o, oc = _local_candidates(n_s, Xi, mi, Ni.T, fmi, live_i, Xj, mj, Nj.T, fmj, live_j, sscale,
                                     support_edges, crosses)
    n, _ = _best(c, ok, Xi, mi, Xj, mj, tie)
    pi = project(Xi, n)
    pj = project(Xj, n)
    sup_i = tied_max(jnp.where(mi, pi, -_BIG))
    sup_j = tied_min(jnp.where(mj, pj, _BIG))
    return dict(normal=n, gap=sup_j - sup_i, support_i=sup_i, support_j=sup_j, changes=changes,
                support_overflow=over | o, cross_overflow=over_c | oc)
