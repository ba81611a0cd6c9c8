"""Neighbour search: cell lists by sorting, Verlet lists with a skin, overflow reporting.

Particles live in two static segments of the arrays: fluid ``[0, n_fluid)`` and walls
``[n_fluid, n_particles)``. At each rebuild every segment is sorted by grid cell
(``sort_by_cell``), so the particles of a run of consecutive x-cells are one contiguous range
of their segment. Only fluid-segment particles get a row ``idx [n_fluid, K]`` (fluid and wall
neighbours); what wall particles need is summed over the transpose of these rows.

A row's candidates are 9 ranges per segment (3 consecutive x-cells for each of the 3x3 (y, z)
neighbour cells), or 27 single-cell ranges when x is periodic. Candidates closer than
``cutoff + skin`` are compacted with a cumulative sum; unused slots hold the row's own index.

Nothing is dropped silently: a cell run holding more than ``cell_capacity`` particles, or a row
with more neighbours than its capacity, sets a ``Status`` bit and the host driver regrows and
reruns. Indices are integers, outside any gradient.

Pair geometry is gathered component by component (1-D gathers): on the CPU, gathering a
``[N, 3]`` array by rows was measured 5x slower than three 1-D gathers.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..types import Config, GridSpec, Kind, NeighbourList, Particles, Status

__all__ = ["cell_coords", "sort_by_cell", "build", "rebuild", "pair_geometry", "safe_norm", "wrap_positions",
           "min_image", "transpose_sum", "Pairs", "pairs"]


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


def sort_by_cell(particles: Particles, config: Config) -> Particles:
    """Reorder each segment (fluid, walls) by cell id (stable); padding goes to its segment's end."""
    ids, _, _ = _ids(jax.lax.stop_gradient(particles.x), particles.kind, config.grid)
    nf = config.n_fluid
    perm = jnp.concatenate([jnp.argsort(ids[:nf], stable=True),
                            nf + jnp.argsort(ids[nf:], stable=True)]) if config.n_wall else jnp.argsort(ids, stable=True)
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


def pair_geometry(x_rows, x_all, idx, grid: GridSpec):
    """Separation components of every listed pair.

    Args:
        x_rows: [R, 3] positions of the rows; x_all: [N, 3] all positions; idx: [R, K].
    Returns:
        ``(d, r, r2)``: ``d`` a tuple of three [R, K] arrays ``x_i - x_j`` (minimum image),
        ``r`` and ``r2`` [R, K].
    """
    d = tuple(min_image(x_rows[:, a, None] - x_all[:, a][idx], a, grid) for a in range(3))
    r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    return d, safe_norm(r2), r2


class Pairs(NamedTuple):
    """Geometry of the listed pairs of the fluid rows, shared by every pass of a step.

    ``d``: three [n_fluid, K] arrays ``x_i - x_j`` (minimum image); ``r``, ``r2``: [n_fluid, K];
    ``idx``: the list; ``mask``: [n_fluid, K] True for a real pair (not the row itself, not padding).
    """

    d: tuple
    r: jax.Array
    r2: jax.Array
    idx: jax.Array
    mask: jax.Array


def pairs(x, kind, idx, config: Config) -> Pairs:
    """``Pairs`` of the fluid rows for positions ``x`` [N, 3] and list ``idx`` [n_fluid, K]."""
    nf = config.n_fluid
    d, r, r2 = pair_geometry(x[:nf], x, idx, config.grid)
    mask = (idx != jnp.arange(nf)[:, None]) & (kind[idx] != Kind.PAD) & (kind[:nf, None] != Kind.PAD)
    return Pairs(d=d, r=r, r2=r2, idx=idx, mask=mask)


def _offsets(config: Config) -> np.ndarray:
    """Static (dx, dy, dz) cell offsets searched; with run length 3, dx = 0 stands for -1..+1."""
    per_axis = []
    for ax in range(3):
        n, periodic = config.grid.shape[ax], config.grid.periodic[ax]
        if ax == 0 and config.run_length == 3:
            per_axis.append([0])
        elif periodic and n < 3:
            per_axis.append(list(range(n)))  # distinct images only
        else:
            per_axis.append([-1, 0, 1])
    return np.array(list(itertools.product(*per_axis)), dtype=np.int32)


def _ranges(c_rows, starts, offset: int, config: Config):
    """Candidate ranges [R_rows, n_off] (global start, end) in a segment for rows in cells ``c_rows``."""
    grid = config.grid
    shape = np.asarray(grid.shape, np.int32)
    periodic = np.asarray(grid.periodic)
    offs = jnp.asarray(_offsets(config))
    cn = c_rows[:, None, :] + offs[None, :, :]
    valid = jnp.all(jnp.where(periodic, True, (cn >= 0) & (cn < shape)), axis=-1)
    cn = jnp.where(periodic, jnp.mod(cn, shape), jnp.clip(cn, 0, shape - 1))
    if config.run_length == 3:
        lo = cn.at[..., 0].set(jnp.maximum(c_rows[:, None, 0] - 1, 0))
        hi = cn.at[..., 0].set(jnp.minimum(c_rows[:, None, 0] + 1, shape[0] - 1))
    else:
        lo = hi = cn
    start = starts[_flat(lo, grid.shape)]
    end = jnp.where(valid, starts[_flat(hi, grid.shape) + 1], start)
    return start + offset, end + offset


def _compact(rows, x_rows, start, end, x, capacity: int, config: Config):
    """Compact candidates within the list radius into ``[R, capacity]``; returns (idx, counts)."""
    L = config.cell_capacity
    n = x.shape[0]
    r_list2 = config.list_radius**2
    ar = jnp.arange(L, dtype=jnp.int32)
    grid = config.grid
    xs = tuple(x[:, a] for a in range(3))

    def one_row(args):
        i, xi, st, en = args
        j = (st[:, None] + ar[None, :]).reshape(-1)
        ok = j < jnp.repeat(en, L, total_repeat_length=en.shape[0] * L)
        j = jnp.minimum(j, n - 1)
        r2 = sum(min_image(xi[a] - xs[a][j], a, grid) ** 2 for a in range(3))
        m = ok & (r2 < r_list2) & (j != i)
        pos = jnp.cumsum(m.astype(jnp.int32)) - 1
        out = jnp.full((capacity,), i, jnp.int32).at[jnp.where(m, pos, capacity)].set(j, mode="drop")
        return out, jnp.sum(m.astype(jnp.int32))

    if rows.shape[0] == 0:
        return jnp.zeros((0, capacity), jnp.int32), jnp.zeros((0,), jnp.int32)
    return jax.lax.map(one_row, (rows, x_rows, start, end), batch_size=min(rows.shape[0], 1024))


def build(x, kind, config: Config):
    """Verlet list of particles sorted by ``sort_by_cell``.

    Args:
        x: [N, 3] positions m (each segment sorted by cell); kind: [N] ``Kind`` codes.
    Returns:
        ``(idx [n_fluid, K], status, max_count, max_run)``.
    """
    grid = config.grid
    x = jax.lax.stop_gradient(x)
    nf, nw = config.n_fluid, config.n_wall
    ids, c, inside = _ids(x, kind, grid)
    cells = jnp.arange(grid.n_cells + 1, dtype=ids.dtype)
    starts_f = jnp.searchsorted(ids[:nf], cells, side="left").astype(jnp.int32)
    start, end = _ranges(c[:nf], starts_f, 0, config)
    if nw:
        starts_w = jnp.searchsorted(ids[nf:], cells, side="left").astype(jnp.int32)
        sw, ew = _ranges(c[:nf], starts_w, nf, config)
        start, end = jnp.concatenate([start, sw], 1), jnp.concatenate([end, ew], 1)
    run = jnp.max(end - start)
    idx, count = _compact(jnp.arange(nf, dtype=jnp.int32), x[:nf], start, end, x, config.neighbour_capacity, config)
    max_count = jnp.max(count)
    active = kind != Kind.PAD
    status = jnp.where(max_count > config.neighbour_capacity, Status.NEIGHBOUR_OVERFLOW, 0)
    status |= jnp.where(run > config.cell_capacity, Status.CELL_OVERFLOW, 0)
    status |= jnp.where(jnp.all(inside | ~active), 0, Status.OUT_OF_DOMAIN)
    return idx, status.astype(jnp.int32), max_count.astype(jnp.int32), run.astype(jnp.int32)


def rebuild(particles: Particles, config: Config):
    """Sort the particles by cell and build a fresh list. Returns ``(particles, NeighbourList, status)``."""
    particles = sort_by_cell(particles, config)
    idx, status, max_count, run = build(particles.x, particles.kind, config)
    nbrs = NeighbourList(idx=idx, x_ref=jax.lax.stop_gradient(particles.x), max_count=max_count, max_run=run)
    return particles, nbrs, status


def transpose_sum(values, idx, n: int):
    """Sum pair values [R, K] onto their column particles: result [n], ``out[j] = sum_{(i,k): idx[i,k]=j} values[i,k]``."""
    return jax.ops.segment_sum(values.reshape(-1), idx.reshape(-1), num_segments=n)
