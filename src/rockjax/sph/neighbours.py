"""Neighbour search: cell lists by sorting, Verlet lists with a skin, overflow reporting.

Particles live in two static segments of the arrays: fluid ``[0, n_fluid)`` and walls
``[n_fluid, n_particles)``. Only fluid-segment particles get a row ``idx [n_fluid, K]`` (fluid and
wall neighbours); what wall particles need is summed over the transpose of these rows.

The search uses the *sub-cell grid* ``search_grid(config.grid)``: the config's cells halved along
every axis (sub-cells at least ``list_radius / 2`` wide), numbered x-fastest. At each rebuild every
segment is sorted by sub-cell (``sort_by_cell``; the wall segment only when it is not sorted
already, which after the first build is the case unless walls move), and the two sorted segments
are merged (two binary searches, no sort) into one order of all particles. In that order the
particles of a run of 5 consecutive x-sub-cells are one contiguous range, so a row's candidates are
25 ranges (one per (dy, dz) in -2..2; 125 single sub-cells when x is periodic), each read into a
fixed ``range_capacity(config)`` slots. Candidates closer than ``cutoff + skin`` are compacted
without a scatter and without a long cumulative sum (both are serial and slow on XLA:CPU): the
row's hit mask is packed into 32-bit words, and the k-th neighbour is found from word popcounts
(prefix sums by small triangular matmuls) and a 5-step select within its word. Unused slots hold
the row's own index.

Sub-cells halve the candidate volume of the classic 27-cell search (125 (r/2)^3 vs 27 r^3 around
a row), and merging the segments halves the slot count again; together with the compaction this
is several times faster than per-segment 3-cell runs with a cumulative sum and a scatter.

Nothing is dropped silently: a range holding more than its capacity sets ``CELL_OVERFLOW`` (the
reported ``max_run`` is scaled to ``Config.cell_capacity`` units, so the driver's regrow rule
works unchanged), a row with more than ``neighbour_capacity`` neighbours sets
``NEIGHBOUR_OVERFLOW``. Indices are integers, outside any gradient.

Pair geometry is gathered component by component (1-D gathers): on the CPU, gathering a
``[N, 3]`` array by rows was measured 5x slower than three 1-D gathers. ``GatherForm.ROWS``
(``Tuning.gather``) gathers rows instead, the default on accelerators, where the reverse mode of
row gathers was measured 2.6x faster and the forward as fast (``Config.effective_gather``).
"""

from __future__ import annotations

import itertools
import math
from typing import Any, NamedTuple, Optional

import jax
import jax.numpy as jnp
import numpy as np

from ..types import Config, GatherForm, GridSpec, Kind, NeighbourList, Particles, Status

__all__ = ["cell_coords", "cell_order", "search_grid", "range_capacity", "sort_by_cell", "build", "rebuild", "pair_geometry", "safe_norm", "wrap_positions",
           "min_image", "transpose_sum", "take", "Pairs", "pairs", "Rows", "scan_rows", "wall_pairs",
           "order_by_wall", "wall_sum"]


def cell_coords(x, grid: GridSpec):
    """Integer cell coordinates [N, 3] and an ``inside`` flag [N] (False off a non-periodic axis)."""
    origin = jnp.asarray(grid.origin, x.dtype)
    cell = jnp.asarray(grid.cell_size, x.dtype)
    shape = jnp.asarray(grid.shape, jnp.int32)
    c = jnp.floor((x - origin) / cell).astype(jnp.int32)
    periodic = jnp.asarray(grid.periodic)
    inside = jnp.all(((c >= 0) & (c < shape)) | periodic, axis=-1)
    c = jnp.where(periodic, jnp.mod(c, shape), jnp.clip(c, 0, shape - 1))
    return c, inside


def _flat(c, shape):
    return c[..., 0] + shape[0] * (c[..., 1] + shape[1] * c[..., 2])


def _ids(x, kind, grid: GridSpec):
    c, inside = cell_coords(x, grid)
    return jnp.where(kind == Kind.PAD, grid.n_cells, _flat(c, grid.shape)), c, inside


def segments(config: Config) -> list[tuple[int, int]]:
    """The sorted segments ``[(start, end), ...]`` of the particle arrays, in tie order: fluid,
    fixed walls, and (``Config.n_block_particles``) the block particles at the end of the walls."""
    nf, n = config.n_fluid, config.n_particles
    nb = config.n_block_particles
    return [(a, b) for a, b in ((0, nf), (nf, n - nb), (n - nb, n)) if b > a]


def cell_order(x, kind, grid: GridSpec):
    """The stable order [N] int32 that sorts particles at ``x`` [N, 3] by search sub-cell, padding
    last: the key of ``sort_by_cell`` (an array sorted by it is left in place by a rebuild)."""
    ids, _, _ = _ids(jax.lax.stop_gradient(x), kind, search_grid(grid))
    return jnp.argsort(ids, stable=True).astype(jnp.int32)


def sort_by_cell(particles: Particles, config: Config) -> Particles:
    """Reorder each segment (fluid, fixed walls, block particles) by search sub-cell id (stable);
    padding goes to its segment's end.

    The fixed walls are re-sorted only when out of order (walls that do not move stay sorted after
    the first build, and an argsort of them would cost as much as the fluid's); the block
    particles (``Config.n_block_particles``), which move, are sorted apart at every build.
    """
    sg = search_grid(config.grid)
    ids, _, _ = _ids(jax.lax.stop_gradient(particles.x), particles.kind, sg)
    nf, fixed_end = config.n_fluid, config.n_particles - config.n_block_particles
    perms = []
    for a, b in segments(config):
        seg = ids[a:b]
        if (a, b) == (nf, fixed_end):  # the fixed walls
            is_sorted = jnp.all(seg[1:] >= seg[:-1])  # then the stable argsort is the identity
            p = _uniform_cond(is_sorted, lambda s: jnp.arange(s.shape[0], dtype=jnp.int32),
                              lambda s: jnp.argsort(s, stable=True).astype(jnp.int32), seg)
        else:
            p = jnp.argsort(seg, stable=True).astype(jnp.int32)
        perms.append(a + p)
    perm = jnp.concatenate(perms)
    return jax.tree_util.tree_map(lambda a: a[perm], particles)


def wrap_positions(x, grid: GridSpec):
    """Map positions into the period along periodic axes (no-op without periodic axes)."""
    if not any(grid.periodic):
        return x
    origin = jnp.asarray(grid.origin, x.dtype)
    L = jnp.asarray(grid.lengths, x.dtype)
    return jnp.where(jnp.asarray(grid.periodic), origin + jnp.mod(x - origin, L), x)


def min_image(d, axis: int, grid: GridSpec):
    """Minimum-image component ``d`` along ``axis`` (identity on a non-periodic axis)."""
    if not grid.periodic[axis]:
        return d
    L = grid.lengths[axis]
    return d - L * jnp.round(d / L)


def safe_norm(r2):
    """sqrt(r2) with a zero (not NaN) gradient at r2 = 0."""
    nz = r2 > 0
    return jnp.where(nz, jnp.sqrt(jnp.where(nz, r2, 1.0)), 0.0)


def take(a, i):
    """``a[i]`` for indices known to be in bounds and non-negative (no index normalisation or clamping)."""
    return a.at[i].get(mode="promise_in_bounds", wrap_negative_indices=False)


def pair_geometry(x_rows, x_all, idx, grid: GridSpec, *, rows: bool = False):
    """Separation components of every listed pair.

    Args:
        x_rows: [R, 3] positions of the rows; x_all: [N, 3] all positions; idx: [R, K];
        rows: gather ``x_all`` by rows ([R, K, 3]) instead of one component at a time
            (``GatherForm.ROWS``; the same numbers).
    Returns:
        ``(d, r, r2)``: ``d`` a tuple of three [R, K] arrays ``x_i - x_j`` (minimum image),
        ``r`` and ``r2`` [R, K].
    """
    if rows:
        xj = take(x_all, idx)
        d = tuple(min_image(x_rows[:, a, None] - xj[..., a], a, grid) for a in range(3))
    else:
        d = tuple(min_image(x_rows[:, a, None] - take(x_all[:, a], idx), a, grid) for a in range(3))
    r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    return d, safe_norm(r2), r2


class Rows(NamedTuple):
    """A block of consecutive fluid rows ``[start, start + size)`` (``start`` may be traced)."""

    start: Any
    size: int

    def of(self, a):
        """The block's entries of ``a`` (leading axis)."""
        if isinstance(self.start, int):
            return a[self.start:self.start + self.size]
        return jax.lax.dynamic_slice_in_dim(a, self.start, self.size)

    def ids(self):
        """Row indices [size] int32."""
        return self.start + jnp.arange(self.size, dtype=jnp.int32)


class Pairs(NamedTuple):
    """Geometry of the listed pairs of a block of fluid rows, shared by every sum of a pass.

    ``d``: three [R, K] arrays ``x_i - x_j`` (minimum image); ``r``, ``r2``: [R, K];
    ``idx``: the rows' list [R, K]; ``mask``: [R, K] True for a real pair (not the row itself, not
    padding); ``rows``: which rows (all fluid rows ``Rows(0, n_fluid)`` unless a pass is tiled).
    """

    d: tuple
    r: jax.Array
    r2: jax.Array
    idx: jax.Array
    mask: jax.Array
    rows: Rows


def pairs(x, kind, idx, config: Config, *, rows: Optional[Rows] = None) -> Pairs:
    """``Pairs`` of fluid rows ``rows`` (default all) for positions ``x`` [N, 3] and the list ``idx`` [n_fluid, K]."""
    rows = Rows(0, config.n_fluid) if rows is None else rows
    idx = rows.of(idx)
    d, r, r2 = pair_geometry(rows.of(x), x, idx, config.grid, rows=config.effective_gather == GatherForm.ROWS)
    # listed neighbours are never padding (``build`` sorts padding past every searched cell), so
    # the mask needs no gather of the neighbours' kinds
    mask = (idx != rows.ids()[:, None]) & (rows.of(kind)[:, None] != Kind.PAD)
    return Pairs(d=d, r=r, r2=r2, idx=idx, mask=mask, rows=rows)


def neighbour_kind(idx, config: Config):
    """``Kind`` of listed neighbours ``idx`` (any shape) without a gather: a listed neighbour is
    never padding, so it is fluid in the fluid segment ``[0, n_fluid)`` and wall after it."""
    return jnp.where(idx < config.n_fluid, jnp.int32(Kind.FLUID), jnp.int32(Kind.WALL))


def block_plan(n_rows: int, tile: int) -> tuple[int, int]:
    """``(size, count)`` of the row blocks for at most ``tile`` rows each: ``count = ceil(n_rows /
    tile)`` blocks of balanced size ``ceil(n_rows / count)`` (so 686 rows in blocks of <= 512 are
    two blocks of 343, not 512 + an overlapping 512)."""
    nt = -(-n_rows // tile)
    size = -(-n_rows // nt)
    if (nt - 1) * size >= n_rows:  # cannot happen while (nt - 1)^2 < n_rows; keep the plain plan
        size = tile
    return size, nt


def scan_rows(fn, n_rows: int, tile: int, carry):
    """Run a pass over the fluid rows in blocks of ``tile`` rows.

    ``fn(rows: Rows, own, carry) -> (carry, out)``: ``out`` a pytree of [rows.size, ...] arrays;
    ``own`` [rows.size] bool marks the rows this block contributes (None: all), for sums that
    ``fn`` scatters into ``carry`` (blocks have the balanced size of ``block_plan``; if that does
    not divide ``n_rows`` the last block is shifted back to end at ``n_rows`` and overlaps its
    predecessor). Returns ``(carry, out)`` with ``out`` [n_rows, ...].

    A pass over all rows at once materialises every [n, K] pair intermediate in memory; in blocks
    they stay in cache (about 2x faster for the momentum sum on the CPU at 21k rows). With
    ``tile <= 0`` or ``n_rows <= tile`` the pass is one block (no loop).
    """
    if tile <= 0 or n_rows <= tile:
        return fn(Rows(0, n_rows), None, carry)
    tile, nt = block_plan(n_rows, tile)
    tail = n_rows - (nt - 1) * tile

    def body(carry, i):
        start = jnp.minimum(i * tile, n_rows - tile).astype(jnp.int32)
        rows = Rows(start, tile)
        return fn(rows, rows.ids() >= i * tile, carry)

    carry, out = jax.lax.scan(body, carry, jnp.arange(nt, dtype=jnp.int32))
    out = jax.tree_util.tree_map(lambda o: jnp.concatenate([o[:-1].reshape((-1,) + o.shape[2:]), o[-1, tile - tail:]]),
                                 out)
    return carry, out


def search_grid(grid: GridSpec) -> GridSpec:
    """The sub-cell grid of the search: ``grid`` with every cell halved (same domain and periods)."""
    return GridSpec(grid.origin, tuple(c / 2 for c in grid.cell_size), tuple(2 * n for n in grid.shape),
                    grid.periodic)


def _run_mode(sg: GridSpec) -> bool:
    """Whether x-sub-cells are searched as runs of 5 (x not periodic and at least 5 sub-cells)."""
    return (not sg.periodic[0]) and sg.shape[0] >= 5


def _offsets(sg: GridSpec) -> np.ndarray:
    """Static (dx, dy, dz) sub-cell offsets searched; in run mode dx = 0 stands for -2..+2."""
    per_axis = []
    for ax in range(3):
        n, periodic = sg.shape[ax], sg.periodic[ax]
        if ax == 0 and _run_mode(sg):
            per_axis.append([0])
        elif periodic and n < 5:
            per_axis.append(list(range(n)))  # distinct images only
        else:
            per_axis.append([-2, -1, 0, 1, 2])
    return np.array(list(itertools.product(*per_axis)), dtype=np.int32)


def range_ratio(sg: GridSpec) -> float:
    """Volume of one search range of sub-grid ``sg`` over a ``Config.cell_capacity`` run of cells."""
    return (5.0 / 24.0) if _run_mode(sg) else 1.0 / 8.0


def range_capacity(config: Config) -> tuple[int, float]:
    """Slots per candidate range and its volume ratio to a ``Config.cell_capacity`` run.

    ``cell_capacity`` counts particles in ``run_length`` consecutive config cells; a search range is
    5 (run mode) or 1 sub-cell of 1/8 the volume. Returns ``(L, ratio)`` with
    ``L = ceil8(ratio * cell_capacity)``.
    """
    ratio = range_ratio(search_grid(config.grid))
    return max(8, int(math.ceil(ratio * config.cell_capacity / 8.0) * 8)), ratio


def _ranges(c_rows, starts, sg: GridSpec):
    """Candidate ranges [R_rows, n_off] (start, end) in the merged order for rows in sub-cells ``c_rows``."""
    offs = _offsets(sg)
    comp, valid = [], None
    for a in range(3):  # per axis [R_rows, n_off]: no [R_rows, n_off, 3] array (a slow scatter on XLA:CPU)
        n = sg.shape[a]
        ca = c_rows[:, a, None] + jnp.asarray(offs[:, a])[None, :]
        if sg.periodic[a]:
            ca = jnp.mod(ca, n)
        else:
            ok = (ca >= 0) & (ca < n)
            valid = ok if valid is None else valid & ok
            ca = jnp.clip(ca, 0, n - 1)
        comp.append(ca)
    if _run_mode(sg):
        lo_x = jnp.maximum(c_rows[:, 0, None] - 2, 0)
        hi_x = jnp.minimum(c_rows[:, 0, None] + 2, sg.shape[0] - 1)
    else:
        lo_x = hi_x = comp[0]
    yz = sg.shape[0] * (comp[1] + sg.shape[1] * comp[2])
    start = take(starts, lo_x + yz)
    end = take(starts, hi_x + yz + 1)
    if valid is not None:
        end = jnp.where(valid, end, start)
    return start, end


def _prefix_sum(a, block: int = 16):
    """Inclusive prefix sum along axis 1 of a float32 array [R, M] by two small triangular matmuls.

    Exact for integer-valued entries with sums below 2^24. ``jnp.cumsum`` over a long axis was
    measured ~20x slower per element on XLA:CPU.
    """
    n, m = a.shape
    mp = -(-m // block) * block
    nb = mp // block
    a = jnp.pad(a, ((0, 0), (0, mp - m))).reshape(n, nb, block)
    inner = jnp.dot(a, jnp.triu(jnp.ones((block, block), a.dtype)), precision=jax.lax.Precision.HIGHEST)
    offs = jnp.dot(inner[:, :, -1], jnp.triu(jnp.ones((nb, nb), a.dtype), 1), precision=jax.lax.Precision.HIGHEST)
    return (inner + offs[:, :, None]).reshape(n, mp)[:, :m]


def _cumsum_1d(a, block: int = 256):
    """Inclusive prefix sum of a float32 vector [M] (``_prefix_sum`` on blocks, then on block totals)."""
    n = a.shape[0]
    m = -(-n // block) * block
    inner = _prefix_sum(jnp.pad(a, (0, m - n)).reshape(m // block, block))
    tot = inner[:, -1]
    offs = _prefix_sum(tot[None, :])[0] - tot
    return (inner + offs[:, None]).reshape(-1)[:n]


def _cell_starts(ids, n_cells: int):
    """``starts [n_cells + 1]``: number of particles with a smaller cell id (counts + prefix sum;
    a binary search per cell was 10x slower and scales with the grid, not the particles)."""
    counts = jnp.zeros((n_cells + 1,), jnp.float32).at[ids].add(1.0)
    incl = _cumsum_1d(counts).astype(jnp.int32)
    return jnp.concatenate([jnp.zeros((1,), jnp.int32), incl[:n_cells]])


def _candidate_words(x_rows, xm, start, end, pos_rows, L: int, grid: GridSpec, radius2: float):
    """Packed hit mask of the candidate slots: [R_rows, W] uint32.

    Candidate slot ``t = r L + l`` of a row is position ``start[:, r] + l`` of the merged order
    (``l < end - start``); it is a hit if that particle is within ``sqrt(radius2)`` and is not the
    row itself (``pos_rows``). Bit b of word w is slot ``32 w + b`` (W = ceil(R L / 32)), as
    ``_pack_bits`` of the [R_rows, R L] mask would give.

    The words are produced directly, 32 bit planes fused into one loop over [R_rows, W]: computing
    the [R_rows, R, L] mask and then padding and packing it is ~3x slower, since XLA:CPU does the
    reshape + pad + small-axis reduction
    in separate passes over the big mask. Needs ``L % 8 == 0`` (a byte never straddles two ranges).
    """
    if L % 8:
        raise ValueError(f"_candidate_words: range capacity L must be a multiple of 8 (got {L})")
    n_rows, R = start.shape
    L8 = L // 8
    n_bytes = R * L8
    W = -(-n_bytes // 4)
    length = end - start
    xi = [x_rows[:, a, None] for a in range(3)]
    words = jnp.zeros((n_rows, W), jnp.uint32)
    for q in range(4):  # byte q of every word: slots 32 w + 8 q + j, j < 8, all in range (4 w + q) // L8
        byte = 4 * np.arange(W) + q
        off = (byte % L8) * 8
        first = _byte_columns(start, byte // L8) + off
        left = jnp.where(byte < n_bytes, _byte_columns(length, byte // L8) - off, 0)  # slots left from this byte on
        for j in range(8):
            slot = first + j
            d = [min_image(xi[a] - take(xm[a], slot), a, grid) for a in range(3)]
            hit = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < radius2) & (j < left) & (slot != pos_rows[:, None])
            words = words | (hit.astype(jnp.uint32) << (8 * q + j))
    return words


def _byte_columns(a, r):
    """``a[:, r]`` for the static column indices ``r`` [W] (past ``a``'s last column: that column),
    as a strided slice when ``r`` is an arithmetic progression (columns past the end read as zeros:
    only bytes past the last range read them, and those are masked). A gather with constant indices
    stays a gather in XLA:CPU; fused into ``_candidate_words``' loop it made every slot slower."""
    step = int(r[1] - r[0]) if len(r) > 1 else 1
    if step >= 1 and np.all(np.diff(r) == step):
        need = int(r[-1]) + 1
        if need > a.shape[1]:
            a = jnp.pad(a, ((0, 0), (0, need - a.shape[1])))
        return a[:, int(r[0]):need:step]
    return a[:, np.minimum(r, a.shape[1] - 1)]


def _uniform_cond(pred, fast, full, operand):
    """``lax.cond(pred, fast, full, operand)`` that stays a conditional under ``jax.vmap``.

    Under ``vmap`` a ``cond`` on a batched predicate becomes a select that runs both branches for
    every member. Here the batched call runs ``fast`` on the whole batch when ``pred`` holds for
    every member, else ``full`` on the whole batch: so ``full`` must give ``fast``'s result where
    ``pred`` holds (or ``pred`` must be the same for all members). For integer work off the
    gradient only (list builds): ``custom_vmap`` has no reverse mode, so no operand may carry a
    tangent. A vmapped list build then costs little more than the plain build, where the selects
    cost about twice as much (and ``_materialise`` loses its fusion boundary).
    """

    @jax.custom_batching.custom_vmap
    def call(pred, operand):
        return jax.lax.cond(pred, fast, full, operand)

    @call.def_vmap
    def rule(axis_size, in_batched, pred, operand):
        pred_batched, op_batched = in_batched
        every = jnp.all(pred) if pred_batched else pred
        operand = jax.tree_util.tree_map(
            lambda a, b: a if b else jnp.broadcast_to(a, (axis_size,) + jnp.shape(a)), operand, op_batched)
        out = jax.lax.cond(every, jax.vmap(fast), jax.vmap(full), operand)
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return call(pred, operand)


def _materialise(tree, pred):
    """``tree`` itself, computed into buffers before any consumer runs (``pred`` must be True).

    A fusion boundary for XLA:CPU, which otherwise fuses a cheap-looking producer into each of its
    consumers and, inside a gather, recomputes it for every index component. The usual tool,
    ``lax.optimization_barrier``, is removed by XLA:CPU before fusion; a conditional is not. ``pred``
    is a traced boolean that is always True (so the branch cannot be folded away); it stays a
    conditional under ``vmap`` (``_uniform_cond``).
    """
    return _uniform_cond(pred, lambda t: t, lambda t: jax.tree_util.tree_map(jnp.zeros_like, t), tree)


def _select(words, capacity: int):
    """Compact each row's hits: ``(t [R, capacity] column of the k-th hit, count [R])``.

    Args:
        words: [R, W] uint32, bit b of word w = hit in column 32 w + b (``_pack_bits``). Columns
            past a row's count are arbitrary (masked later).
    """
    n, w_count = words.shape
    pc = jax.lax.population_count(words).astype(jnp.int32)
    incl = _prefix_sum(pc.astype(jnp.float32)).astype(jnp.int32)
    count = incl[:, -1]
    rows = jnp.arange(n, dtype=jnp.int32)[:, None]
    # word holding the k-th hit = number of words whose inclusive count is <= k
    marks = jnp.zeros((n, capacity + 1), jnp.float32).at[rows, jnp.minimum(incl, capacity)].add(1.0)
    wk = jnp.minimum(_prefix_sum(marks[:, :capacity]).astype(jnp.int32), w_count - 1)
    # the gathers' indices and the selection materialised (``_materialise``): fused into their
    # consumers, XLA:CPU recomputed them per gathered element (select + assembly 27 -> 13 ms at
    # 21k rows, 32 words, K = 120)
    wk, excl = _materialise((wk, incl - pc), count[0] >= 0)
    k = jnp.arange(capacity, dtype=jnp.int32)[None, :]
    word = jnp.take_along_axis(words, wk, axis=1, mode="promise_in_bounds")
    rank = k - jnp.take_along_axis(excl, wk, axis=1, mode="promise_in_bounds")
    return _materialise(wk * 32 + _nth_set_bit(word, rank), count[0] >= 0), count


def build(x, kind, config: Config):
    """Verlet list of particles sorted by ``sort_by_cell``.

    Args:
        x: [N, 3] positions m (each segment sorted by sub-cell); kind: [N] ``Kind`` codes.
    Returns:
        ``(idx [n_fluid, K], status, max_count, max_run)``; ``max_run`` in ``cell_capacity`` units.
    """
    sg = search_grid(config.grid)
    x = jax.lax.stop_gradient(x)
    nf, n = config.n_fluid, config.n_particles
    K = config.neighbour_capacity
    ids, c, inside = _ids(x, kind, sg)
    # merge the sorted segments: position of each particle in the joint cell order (its rank in
    # its segment plus, per other segment, the particles there with a smaller id -- or an equal
    # one in an earlier segment)
    ar_f = jnp.arange(nf, dtype=jnp.int32)
    segs = segments(config)
    pos = []
    for k, (a, b) in enumerate(segs):
        p = jnp.arange(b - a, dtype=jnp.int32)
        for m, (a2, b2) in enumerate(segs):
            if m != k:
                p = p + jnp.searchsorted(ids[a2:b2], ids[a:b], side="right" if m < k else "left").astype(jnp.int32)
        pos.append(p)
    pos_f = pos[0] if nf else ar_f
    if len(segs) > 1:
        perm = jnp.zeros((n,), jnp.int32).at[jnp.concatenate(pos)].set(jnp.arange(n, dtype=jnp.int32),
                                                                        unique_indices=True)
    else:
        perm = jnp.arange(n, dtype=jnp.int32)
    starts = _cell_starts(ids, sg.n_cells)
    start, end = _ranges(c[:nf], starts, sg)
    L, ratio = range_capacity(config)
    R = start.shape[1]
    # materialise the merged-order coordinates: fused into the per-slot gather they would be
    # recomputed (a gather of a gather) for every slot
    xm = jax.lax.optimization_barrier([jnp.concatenate([x[:, a][perm], jnp.zeros((L,), x.dtype)]) for a in range(3)])
    words = _candidate_words(x[:nf], xm, start, end, pos_f, L, config.grid, config.list_radius**2)
    t, count = _select(words, K)
    r = jnp.minimum(t // L, R - 1)
    merged_pos = jnp.take_along_axis(start, r, axis=1, mode="promise_in_bounds") + t % L
    k = jnp.arange(K, dtype=jnp.int32)[None, :]
    pm = jnp.concatenate([perm, jnp.zeros((L,), jnp.int32)])
    idx = jnp.where(k < count[:, None], take(pm, merged_pos), ar_f[:, None])
    max_count = jnp.max(count) if nf else jnp.zeros((), jnp.int32)
    run = jnp.max(end - start) if nf else jnp.zeros((), jnp.int32)
    active = kind != Kind.PAD
    status = jnp.where(max_count > K, Status.NEIGHBOUR_OVERFLOW, 0)
    status |= jnp.where(run > L, Status.CELL_OVERFLOW, 0)
    status |= jnp.where(jnp.all(inside | ~active), 0, Status.OUT_OF_DOMAIN)
    max_run = jnp.ceil(run.astype(jnp.float32) / ratio).astype(jnp.int32)
    return idx, status.astype(jnp.int32), max_count.astype(jnp.int32), max_run


def _nth_set_bit(word, n):
    """Position (0-31) of the ``n``-th (0-based) set bit of uint32 ``word`` (elementwise; 5 halvings)."""
    pos = jnp.zeros(n.shape, jnp.int32)
    for s in (16, 8, 4, 2, 1):
        low = jax.lax.population_count((word >> pos.astype(jnp.uint32)) & jnp.uint32((1 << s) - 1)).astype(jnp.int32)
        go = n >= low
        n = jnp.where(go, n - low, n)
        pos = jnp.where(go, pos + s, pos)
    return pos


def _pack_bits(hit):
    """[R, T] bool (T a multiple of 32) -> [R, T // 32] uint32 words, bit b of word w = hit[:, 32 w + b]."""
    n, t = hit.shape
    return (hit.reshape(n, t // 32, 32).astype(jnp.uint32) << jnp.arange(32, dtype=jnp.uint32)).sum(-1, dtype=jnp.uint32)


def wall_pairs(idx, kind, config: Config):
    """The list's (fluid row, wall neighbour) pairs as a flat list.

    Args:
        idx: [n_fluid, K] list; kind: [N] ``Kind`` codes.
    Returns:
        ``(row [M], col [M], count, status)`` with M = ``config.wall_pair_capacity``: the pairs in
        row order, (0, 0) past ``count``; ``WALL_PAIR_OVERFLOW`` if ``count > M``.

    No scatter over the [n_fluid, K] slots: slot m finds its row from the rows' cumulative hit
    counts (a histogram of the row ends over the slots, prefix-summed), then its column as the
    right set bit of the row's packed hit mask.
    """
    nf, K = idx.shape
    M = config.wall_pair_capacity
    if nf == 0 or M == 0:
        count = jnp.zeros((), jnp.int32)
        if nf:
            count = jnp.sum((take(kind, idx) == Kind.WALL) & (kind[:nf, None] == Kind.FLUID), dtype=jnp.int32)
        status = jnp.where(count > M, Status.WALL_PAIR_OVERFLOW, 0).astype(jnp.int32)
        return jnp.zeros((M,), jnp.int32), jnp.zeros((M,), jnp.int32), count, status
    hit = (idx >= nf) & (kind[:nf, None] == Kind.FLUID)  # listed wall neighbours (never padding)
    kp = -(-K // 32) * 32
    words = _pack_bits(jnp.pad(hit, ((0, 0), (0, kp - K))))  # [nf, W]
    pc = jax.lax.population_count(words).astype(jnp.int32)
    word_end = jnp.cumsum(pc, axis=1)  # [nf, W] inclusive, W <= 8
    per_row = word_end[:, -1]
    row_end = _cumsum_1d(per_row.astype(jnp.float32)).astype(jnp.int32)  # inclusive, exact below 2^24
    count = row_end[-1]
    m = jnp.arange(M, dtype=jnp.int32)
    valid = m < count
    # row of slot m = #{rows ending at or before m}: a histogram of the row ends, prefix-summed
    # (binary searches per slot made this function ~1.8x slower)
    ends = jnp.zeros((M,), jnp.float32).at[row_end].add(1.0, mode="drop")
    row = jnp.minimum(_cumsum_1d(ends).astype(jnp.int32), nf - 1)
    rank = m - (take(row_end, row) - take(per_row, row))  # rank of slot m within its row
    w = jnp.zeros((M,), jnp.int32)
    for j in range(words.shape[1] - 1):  # word holding the rank-th hit: number of words ending at or before it
        w = w + (take(word_end[:, j], row) <= rank).astype(jnp.int32)
    before = jnp.where(w > 0, take(word_end.reshape(-1), row * words.shape[1] + jnp.maximum(w - 1, 0)), 0)
    bit = _nth_set_bit(take(words.reshape(-1), row * words.shape[1] + w), rank - before)
    col = take(idx.reshape(-1), row * K + jnp.minimum(w * 32 + bit, K - 1))
    status = jnp.where(count > M, Status.WALL_PAIR_OVERFLOW, 0).astype(jnp.int32)
    return jnp.where(valid, row, 0), jnp.where(valid, col, 0), count.astype(jnp.int32), status


def body_pairs(row, col, count, body, config: Config):
    """The pairs of the flat wall list whose wall particle is carried by a block (``body >= 0``).

    Args:
        row, col: [M] the wall pairs (``wall_pairs``), valid below ``count``; body: [N] block of
            each particle (-1 for none).
    Returns:
        ``(row [Mb], col [Mb], count, status)`` with Mb = ``config.body_pair_capacity``, in the
        wall list's order, (0, 0) past ``count``; ``BODY_PAIR_OVERFLOW`` if ``count > Mb``.
        ``rebuild`` builds it with ``Coupling.BOUNDARY_PARTICLES`` only.
    """
    Mb = config.body_pair_capacity
    on = (jnp.arange(row.shape[0]) < count) & (take(body, col) >= 0)
    # slot of each kept pair: a blocked prefix sum (exact below 2^24) and a scatter that drops the
    # rest (2x faster than jnp.nonzero's, whose cumulative sum is serial on the CPU)
    pos = _cumsum_1d(on.astype(jnp.float32)).astype(jnp.int32) - 1
    n_on = jnp.sum(on, dtype=jnp.int32)
    slot = jnp.where(on, pos, Mb + jnp.arange(row.shape[0], dtype=jnp.int32))  # unique, dropped past Mb
    out = [jnp.zeros((Mb,), jnp.int32).at[slot].set(a, mode="drop", unique_indices=True) for a in (row, col)]
    status = jnp.where(n_on > Mb, Status.BODY_PAIR_OVERFLOW, 0).astype(jnp.int32)
    return out[0], out[1], n_on, status


def order_by_wall(row, col, count, config: Config):
    """The flat (fluid, wall) list reordered by wall (``Config.wall_ordered``).

    Args:
        row, col: [M] the pairs (``wall_pairs``), valid below ``count``.
    Returns:
        ``(row [M], col [M], start [n_wall + 1])``: the pairs sorted by wall particle (stable:
        rows ascending within a wall; padding last) and the first slot of each wall's run
        (``start[-1] == count``).

    One sort per list build, so that each step's sums onto the walls (``wall_sum``) run over
    consecutive slots instead of scattering onto the walls.
    """
    nf, n = config.n_fluid, config.n_particles
    M = row.shape[0]
    key = jnp.where(jnp.arange(M) < count, col, n)
    order = jnp.argsort(key, stable=True)
    start = jnp.searchsorted(key[order], jnp.arange(nf, n + 1, dtype=key.dtype), side="left").astype(jnp.int32)
    return take(row, order), take(col, order), start


def _segment_scan(values, first):
    """Inclusive sums of ``values`` [M, ...] along axis 0, restarting where ``first`` [M] is True
    (a parallel scan: O(M) work, O(log M) depth; each sum is over its own segment only)."""
    def op(a, b):
        (va, fa), (vb, fb) = a, b
        restart = fb.reshape(fb.shape + (1,) * (vb.ndim - fb.ndim))
        return jnp.where(restart, vb, va + vb), fa | fb

    return jax.lax.associative_scan(op, (values, first))[0]


def wall_sum(values, wp, config: Config):
    """Sum per-pair ``values`` [M, ...] of the flat (fluid, wall) list onto the pairs' walls: [N, ...].

    ``wp``: the list's ``walls.WallPairs``; ``values`` must be zero past its count (masked by
    ``wp.valid``). Fluid rows get zeros. Where ``Config.wall_ordered`` each wall's run of
    consecutive slots is summed by a segmented scan and read at its last slot; otherwise one
    ``segment_sum`` over the wall column (a scatter-add: on a GPU its atomics contend on each
    wall). The two agree to float rounding (the summation order differs).
    """
    n = config.n_particles
    if not config.wall_ordered or wp.start is None:
        return jax.ops.segment_sum(values, wp.col, num_segments=n)
    M = values.shape[0]
    if M == 0:
        return jnp.zeros((n,) + values.shape[1:], values.dtype)
    first = jnp.concatenate([jnp.ones((1,), bool), wp.col[1:] != wp.col[:-1]])
    scanned = _segment_scan(values, first)
    end = wp.start[1:]
    has = (end > wp.start[:-1]).reshape((-1,) + (1,) * (values.ndim - 1))
    walls = jnp.where(has, take(scanned, jnp.maximum(end - 1, 0)), 0)
    return jnp.concatenate([jnp.zeros((config.n_fluid,) + values.shape[1:], values.dtype), walls])


def rebuild(particles: Particles, config: Config):
    """Sort the particles by cell and build a fresh list. Returns ``(particles, NeighbourList, status)``."""
    particles = sort_by_cell(particles, config)
    idx, status, max_count, run = build(particles.x, particles.kind, config)
    if config.needs_wall_pairs:
        row, col, count, wall_status = wall_pairs(idx, particles.kind, config)
    else:  # no sum reads the (fluid, wall) pairs: the list stays empty (kept at its configured length)
        row = col = jnp.zeros((config.wall_pair_capacity,), jnp.int32)
        count, wall_status = jnp.zeros((), jnp.int32), jnp.zeros((), jnp.int32)
    if config.wall_ordered:
        row, col, start = order_by_wall(row, col, count, config)
    else:
        start = jnp.zeros((config.n_wall + 1,), jnp.int32)
    if config.has_body_pairs:
        brow, bcol, bcount, body_status = body_pairs(row, col, count, particles.body, config)
    else:  # no sub-list (kept at its configured length)
        brow = bcol = jnp.zeros((config.body_pair_capacity,), jnp.int32)
        bcount, body_status = jnp.zeros((), jnp.int32), jnp.zeros((), jnp.int32)
    nbrs = NeighbourList(idx=idx, x_ref=jax.lax.stop_gradient(particles.x), max_count=max_count, max_run=run,
                         wall_row=row, wall_col=col, wall_count=count, max_wall_count=count,
                         wall_start=start,
                         body_row=brow, body_col=bcol, body_count=bcount, max_body_count=bcount)
    return particles, nbrs, status | wall_status | body_status


def transpose_sum(values, idx, n: int):
    """Sum pair values onto their column particles.

    Args:
        values: [R, K] or [R, K, C]; idx: [R, K] column indices; n: number of particles.
    Returns:
        [n] (or [n, C]): ``out[j] = sum_{(i,k): idx[i,k]=j} values[i,k]``.
    """
    flat = values.reshape((-1,) + values.shape[2:])
    return jax.ops.segment_sum(flat, idx.reshape(-1), num_segments=n)
