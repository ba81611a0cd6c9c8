"""Broad phase: axis-aligned bounding boxes and candidate block pairs in a fixed-capacity buffer.

Owns ``aabbs`` and ``candidate_pairs`` (seed section 2):

* ALL_PAIRS: every pair (i < j) with at least one DYNAMIC block (a static list) is tested box
  against box.  Pairs of two non-dynamic blocks are never candidates.
* GRID: blocks that fit in a cell are binned by the cell of their box centre in a uniform grid
  (cell ~ 1.5 x median block size; Nezami et al. 2004), sorted by cell id; each block looks at
  its own cell and half of the 26 around it (the other half sees it; binary search in the sorted
  ids, ``grid_cell_capacity`` entries per cell).  Blocks larger than a cell (floors, slopes) are
  tested against every block.
* The overlapping pairs are compacted into ``pair_capacity`` slots; more set
  ``Status.CONTACT_OVERFLOW`` (never silently dropped); a grid cell holding more than its capacity
  sets ``Status.BLOCK_CELL_OVERFLOW``.  The driver cures either by doubling that buffer.  When the
  static list fits in the buffer (ALL_PAIRS default) the pair order is fixed and no compaction is
  needed.
"""

from __future__ import annotations

import itertools

import jax.numpy as jnp
import numpy as np

from ..types import Status
from .model import BlockConfig, Broadphase, Motion

__all__ = ["aabbs", "candidate_pairs", "pairs_are_static"]


#: the own cell first, then the 13 cell offsets that come after (0, 0, 0) in (z, y, x) order
_HALF_SHELL = [(0, 0, 0)] + [o for o in itertools.product((-1, 0, 1), repeat=3) if o[::-1] > (0, 0, 0)]


def aabbs(Xw, vmask, margin):
    """Boxes of the world vertices [B,V,3] (m): ``(lo [B,3], hi [B,3])`` grown by ``margin`` (m)."""
    big = jnp.asarray(1e30, Xw.dtype)
    lo = jnp.min(jnp.where(vmask[..., None], Xw, big), 1) - margin
    hi = jnp.max(jnp.where(vmask[..., None], Xw, -big), 1) + margin
    return lo, hi


def _overlap(lo, hi, i, j):
    return jnp.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), -1)


def pairs_are_static(config: BlockConfig) -> bool:
    """True when the buffer holds the full static ALL_PAIRS list (fixed order, no compaction)."""
    return config.broadphase == Broadphase.ALL_PAIRS and len(config.static_pairs) <= config.pair_capacity


def _compact(cand_i, cand_j, ok, P):
    """First P candidates with ``ok`` into [P,2] pairs; returns (pairs, mask, overflow)."""
    n = jnp.sum(ok.astype(jnp.int32))
    (sel,) = jnp.nonzero(ok, size=P, fill_value=0)
    mask = jnp.arange(P) < n
    pairs = jnp.stack([cand_i[sel], cand_j[sel]], -1).astype(jnp.int32)
    pairs = jnp.where(mask[:, None], pairs, 0)
    return pairs, mask, n > P


def candidate_pairs(config: BlockConfig, Xw, vmask):
    """Candidate pairs whose boxes overlap.

    Args:
      config: static block config.  Xw: [B,V,3] world vertices (m).  vmask: [B,V].
    Returns:
      ``(pairs [P,2] int32 with i < j, mask [P] bool, status int32)``.
    """
    B = config.n_blocks
    P = config.pair_capacity
    lo, hi = aabbs(Xw, vmask, config.aabb_margin)
    status = jnp.int32(0)
    if config.broadphase == Broadphase.ALL_PAIRS:
        st = np.asarray(config.static_pairs, np.int32).reshape(-1, 2)
        if len(st) == 0:
            return jnp.zeros((P, 2), jnp.int32), jnp.zeros(P, bool), status
        i, j = jnp.asarray(st[:, 0]), jnp.asarray(st[:, 1])
        ok = _overlap(lo, hi, i, j)
        if len(st) <= P:
            pad = P - len(st)
            pairs = jnp.concatenate([jnp.asarray(st), jnp.zeros((pad, 2), jnp.int32)], 0)
            mask = jnp.concatenate([ok, jnp.zeros(pad, bool)], 0)
            return pairs, mask, status
        pairs, mask, over = _compact(i, j, ok, P)
        return pairs, mask, jnp.where(over, Status.CONTACT_OVERFLOW.value, 0).astype(jnp.int32)

    # ---------------- GRID ----------------
    dyn_np = np.asarray([m == Motion.DYNAMIC for m in config.motion])
    dyn = jnp.asarray(dyn_np)
    large = set(config.large_blocks)
    small = np.asarray([b for b in range(B) if b not in large], np.int32)
    cand_i, cand_j, cand_ok = [], [], []
    # large blocks against every other block (static list)
    lp = [(min(l, b), max(l, b)) for l in sorted(large) for b in range(B)
          if b != l and (b not in large or b > l) and (dyn_np[l] or dyn_np[b])]
    lp = sorted(set(lp))
    if lp:
        a = np.asarray(lp, np.int32)
        li, lj = jnp.asarray(a[:, 0]), jnp.asarray(a[:, 1])
        cand_i.append(li)
        cand_j.append(lj)
        cand_ok.append(_overlap(lo, hi, li, lj))
    ns = len(small)
    if ns > 1:
        sm = jnp.asarray(small)
        cs = config.grid_cell_size
        centre = 0.5 * (lo[sm] + hi[sm])
        cell = jnp.floor(centre / cs).astype(jnp.int32)  # [ns,3]
        cmin = jnp.min(cell, 0) - 1
        ext = jnp.max(cell, 0) - cmin + 2  # room for the +-1 neighbours
        rel = cell - cmin

        def cid(r):
            return r[..., 0] + ext[0] * (r[..., 1] + ext[1] * r[..., 2])

        key = cid(rel)
        order = jnp.argsort(key)
        skey = key[order]
        cap = config.grid_cell_capacity
        # half shell: the own cell and the 13 neighbours whose offset is positive (lexicographically,
        # z first), so each pair of blocks in different cells is met once, from the lower cell
        offs = jnp.asarray(_HALF_SHELL, jnp.int32)  # [14,3]
        nkey = cid(rel[:, None, :] + offs[None, :, :])  # [ns,14]
        start = jnp.searchsorted(skey, nkey, side="left")
        stop = jnp.searchsorted(skey, nkey, side="right")
        over = jnp.any(stop - start > cap)
        slot = start[..., None] + jnp.arange(cap)  # [ns,14,cap]
        in_run = slot < stop[..., None]
        other = sm[order[jnp.clip(slot, 0, ns - 1)]]  # global index
        me = jnp.broadcast_to(sm[:, None, None], other.shape)
        own = (jnp.arange(offs.shape[0]) == 0)[None, :, None]  # offset (0, 0, 0) first
        ok = in_run & ((other > me) | (~own & (other != me))) & (dyn[me] | dyn[other])
        gi, gj = jnp.minimum(me, other).reshape(-1), jnp.maximum(me, other).reshape(-1)
        ok = ok.reshape(-1) & _overlap(lo, hi, gi, gj)
        cand_i.append(gi)
        cand_j.append(gj)
        cand_ok.append(ok)
        status = status | jnp.where(over, Status.BLOCK_CELL_OVERFLOW.value, 0).astype(jnp.int32)
    if not cand_i:
        return jnp.zeros((P, 2), jnp.int32), jnp.zeros(P, bool), status
    ci, cj, ok = (jnp.concatenate(c, 0) for c in (cand_i, cand_j, cand_ok))
    pairs, mask, over = _compact(ci, cj, ok, P)
    return pairs, mask, status | jnp.where(over, Status.CONTACT_OVERFLOW.value, 0).astype(jnp.int32)
