"""Neighbour lists equal brute force (random clouds, periodic axes, near-empty and near-full
cells); overflow is reported in the status bits, never silent."""

import jax
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rockjax.scenes.base import empty_neighbours
from rockjax.sph.neighbours import range_capacity, rebuild
from rockjax.types import Capacities, Config, GridSpec, Kind, Particles, Status


def _particles(x, kind):
    n = len(x)
    z = np.zeros(n, np.float32)
    return Particles(x=np.asarray(x, np.float32), v=np.zeros((n, 3), np.float32), a=np.zeros((n, 3), np.float32),
                     rho=z + 1000, drho_dt=z, p=z, vol=z + 1e-6, kind=np.asarray(kind, np.int32),
                     pid=np.arange(n, dtype=np.int32))


def _brute(x, nf, radius, lengths, periodic):
    out = []
    for i in range(nf):
        d = x - x[i]
        for a in range(3):
            if periodic[a]:
                d[:, a] -= lengths[a] * np.round(d[:, a] / lengths[a])
        r = np.linalg.norm(d, axis=1)
        out.append(set(np.nonzero(r < radius)[0]) - {i})
    return out


_jit_rebuild = jax.jit(rebuild, static_argnums=1)


def _check(x, n_fluid, periodic, radius=0.1, K=64, C=64, box=(1.0, 0.6, 0.5), pad_kinds=None, M=None, n_block=0):
    x = np.asarray(x, np.float64)
    grid = GridSpec.covering((0, 0, 0), box, min_cell=radius, periodic=periodic)
    kind = np.array([Kind.FLUID] * n_fluid + [Kind.WALL] * (len(x) - n_fluid), np.int32)
    if pad_kinds is not None:
        kind[pad_kinds] = Kind.PAD
    cfg = Config(n_fluid=n_fluid, n_wall=len(x) - n_fluid, dt=1e-4, grid=grid, cutoff=radius, skin=0.0,
                 capacities=Capacities(neighbours=K, cells=C, wall_pairs=n_fluid * K if M is None else M),
                 n_block_particles=n_block)
    P, nbrs, status = _jit_rebuild(_particles(x, kind), cfg)
    xs = np.asarray(P.x, np.float64)
    idx = np.asarray(nbrs.idx)
    kinds = np.asarray(P.kind)
    expected = _brute(xs, n_fluid, radius, grid.lengths, periodic)
    if not int(status) & Status.NEIGHBOUR_OVERFLOW:
        _check_wall_pairs(nbrs, idx, kinds, n_fluid, int(status))
    return cfg, xs, idx, kinds, expected, int(status), int(nbrs.max_count)


def _check_wall_pairs(nbrs, idx, kinds, n_fluid, status):
    """The flat (fluid row, wall) list holds exactly the list's fluid-wall pairs, in row order."""
    want = [(i, int(j)) for i in range(n_fluid) if kinds[i] == Kind.FLUID
            for j in idx[i] if j != i and kinds[j] == Kind.WALL]
    count = int(nbrs.wall_count)
    assert count == len(want)
    M = nbrs.wall_row.shape[0]
    if count > M:
        assert status & Status.WALL_PAIR_OVERFLOW
        return
    assert not status & Status.WALL_PAIR_OVERFLOW
    got = list(zip(np.asarray(nbrs.wall_row)[:count].tolist(), np.asarray(nbrs.wall_col)[:count].tolist()))
    assert got == want


NF_SEG, NW_SEG = 150, 60  # fixed segment lengths (real particles + padding): few shapes, few compiles


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), periodic_y=st.booleans(), periodic_x=st.booleans(),
       n=st.integers(5, NF_SEG), n_wall=st.integers(0, NW_SEG))
def test_matches_brute_force(seed, periodic_y, periodic_x, n, n_wall):
    """Random clouds (with padding slots in both segments) give exactly the brute-force pairs."""
    rng = np.random.default_rng(seed)
    box = np.array([1.0, 0.6, 0.5])
    nw_seg = NW_SEG if n_wall else 0
    x = rng.uniform(0, 1, (NF_SEG + nw_seg, 3)) * box
    pads = list(range(n, NF_SEG)) + list(range(NF_SEG + n_wall, NF_SEG + nw_seg))
    periodic = (periodic_x, periodic_y, False)
    cfg, xs, idx, kinds, expected, status, _ = _check(x, NF_SEG, periodic, box=tuple(box), pad_kinds=pads)
    assert status == 0, Status.describe(status)
    pad_rows = set(np.nonzero(kinds == Kind.PAD)[0].tolist())
    assert len(pad_rows) == len(pads)
    for i in range(NF_SEG):
        if i in pad_rows:
            continue
        got = set(idx[i].tolist()) - {i}
        assert not (got & pad_rows)
        want = expected[i] - pad_rows
        # distances computed in float32 on device: ignore pairs within 1e-5 of the radius
        d = xs[list(got ^ want)] - xs[i] if got ^ want else np.zeros((0, 3))
        for a in range(3):
            if periodic[a] and len(d):
                d[:, a] -= cfg.grid.lengths[a] * np.round(d[:, a] / cfg.grid.lengths[a])
        assert np.all(np.abs(np.linalg.norm(d, axis=1) - 0.1) < 1e-5), (i, got ^ want)


@pytest.mark.parametrize("seed,n_wall,n_block", [(0, 60, 20), (1, 60, 60), (2, 40, 1)])
def test_block_particle_tail_matches_brute_force(seed, n_wall, n_block):
    """With ``Config.n_block_particles`` the walls' tail (block particles, moving) is sorted apart
    from the fixed walls and the three segments are merged: the list still equals brute force,
    from an unsorted start and after the tail moved (a second build from the sorted state)."""
    from rockjax.sph.neighbours import search_grid, _ids

    rng = np.random.default_rng(seed)
    box = np.array([1.0, 0.6, 0.5])
    x = rng.uniform(0, 1, (NF_SEG + n_wall, 3)) * box
    cfg, xs, idx, kinds, expected, status, _ = _check(x, NF_SEG, (False, True, False), box=tuple(box), n_block=n_block)
    assert status == 0, Status.describe(status)
    for i in range(NF_SEG):
        assert set(idx[i].tolist()) - {i} == expected[i], i
    # each segment of the rebuilt particles is sorted by sub-cell
    ids = np.asarray(_ids(jax.numpy.asarray(xs, jax.numpy.float32), jax.numpy.asarray(kinds), search_grid(cfg.grid))[0])
    n = len(xs)
    for a, b in ((0, NF_SEG), (NF_SEG, n - n_block), (n - n_block, n)):
        assert np.all(np.diff(ids[a:b]) >= 0), (a, b)
    # the block particles move; the fixed walls do not: rebuild from the sorted state
    xs2 = xs.copy()
    xs2[n - n_block:] = rng.uniform(0, 1, (n_block, 3)) * box
    P, nbrs, status = _jit_rebuild(_particles(xs2, kinds), cfg)
    assert int(status) == 0
    xs3 = np.asarray(P.x, np.float64)
    want = _brute(xs3, NF_SEG, 0.1, cfg.grid.lengths, (False, True, False))
    got_idx = np.asarray(nbrs.idx)
    for i in range(NF_SEG):
        got = set(got_idx[i].tolist()) - {i}
        d = xs3[list(got ^ want[i])] - xs3[i] if got ^ want[i] else np.zeros((0, 3))
        d[:, 1] -= cfg.grid.lengths[1] * np.round(d[:, 1] / cfg.grid.lengths[1])
        assert np.all(np.abs(np.linalg.norm(d, axis=1) - 0.1) < 1e-5), (i, got ^ want[i])
    np.testing.assert_array_equal(np.asarray(P.x)[NF_SEG:n - n_block], xs[NF_SEG:n - n_block])  # fixed walls kept


def test_clustered_cells_and_padding():
    """Many particles in one sub-cell (exactly full), isolated ones (near-empty), padding never listed."""
    rng = np.random.default_rng(0)
    cluster = 0.3 + 0.02 * rng.uniform(size=(40, 3))
    lone = np.array([[0.9, 0.5, 0.45], [0.05, 0.05, 0.05]])
    walls = rng.uniform(0, 1, (30, 3)) * [1.0, 0.6, 0.5]
    x = np.concatenate([cluster, lone, walls])
    pads = [3, 7]
    # the 40 clustered particles share one search sub-cell: a range capacity of exactly 40 slots
    C = 40 * 24 // 5  # range_capacity = ceil8(5/24 * C) = 40 (run mode: x has >= 5 sub-cells)
    cfg, xs, idx, kinds, expected, status, max_count = _check(x, 42, (False, False, False), pad_kinds=pads, C=C)
    assert range_capacity(cfg)[0] == 40
    assert status == 0, Status.describe(status)
    pad_rows = set(np.nonzero(kinds == Kind.PAD)[0].tolist())
    for i in range(42):
        got = set(idx[i].tolist()) - {i}
        if i in pad_rows:
            continue
        assert got == expected[i] - pad_rows
        assert not (got & pad_rows)
    assert max_count >= 37


def test_overflow_is_reported():
    rng = np.random.default_rng(1)
    x = 0.3 + 0.02 * rng.uniform(size=(40, 3))
    *_, status, max_count = _check(x, 40, (False, False, False), K=8, C=192)
    assert status & Status.NEIGHBOUR_OVERFLOW and max_count == 39
    *_, status, _ = _check(x, 40, (False, False, False), K=64, C=16)
    assert status & Status.CELL_OVERFLOW
    walls = 0.3 + 0.02 * rng.uniform(size=(10, 3))
    xw = np.concatenate([x, walls])
    *_, status, _ = _check(xw, 40, (False, False, False), K=64, C=400, M=8)  # 400 fluid-wall pairs
    assert status & Status.WALL_PAIR_OVERFLOW

def test_out_of_domain_is_reported():
    x = np.array([[0.5, 0.3, 0.2], [0.52, 0.3, 0.2], [1.5, 0.3, 0.2]])
    *_, status, _ = _check(x, 3, (False, False, False))
    assert status & Status.OUT_OF_DOMAIN


def test_empty_neighbours_shapes():
    grid = GridSpec.covering((0, 0, 0), (1, 1, 1), min_cell=0.2)
    cfg = Config(n_fluid=5, n_wall=3, dt=1e-4, grid=grid, cutoff=0.2, skin=0.0, capacities=Capacities(neighbours=16))
    nb = empty_neighbours(cfg, np.zeros((8, 3)))
    assert nb.idx.shape == (5, 16)
    assert np.all(np.asarray(nb.idx) == np.arange(5)[:, None])


def test_periodic_axis_too_short_is_refused():
    with pytest.raises(ValueError, match="periodic axis 1"):
        GridSpec.covering((0, 0, 0), (1, 0.15, 1), min_cell=0.1, periodic=(False, True, False))


@pytest.fixture(scope="module")
def moving_column():
    """A coarse dam-break column thrown sideways at 2 m/s with a tiny skin (0.1 dx, i.e. rebuild
    needed every ~3 steps) and long blocks of 16 steps: primed state, config, params."""
    import rockjax as rj
    from rockjax.step import prime

    scene = rj.scenes.dam_break(dx=0.125, skin_factor=0.1, rebuild_every=16)
    # a 0.1 dx skin makes search sub-cells small: more room per cell run than the scene's default
    config, params = scene.config.grown(cells=256), scene.params
    P = scene.state.particles
    v = np.where((np.asarray(P.kind) == Kind.FLUID)[:, None], np.array([2.0, 0.0, 0.0]), 0.0).astype(P.v.dtype)
    state = scene.state.replace(particles=P.replace(v=jax.numpy.asarray(v)))
    state = jax.jit(lambda s, p: prime(s, p, config))(state, params)
    return state, config, params


def _by_pid(P):
    order = np.argsort(np.asarray(P.pid))
    return np.asarray(P.x)[order], np.asarray(P.v)[order]


def test_displacement_trigger_rebuilds_before_the_list_goes_stale(moving_column):
    """With the trigger a 16-step block on a 0.1 dx skin never uses a stale list and matches a
    rebuild every step (to float32 summation-order rounding); without it the stale bit is set."""
    from rockjax.rollout import make_rollout, needs_rebuild

    state, config, params = moving_column
    step_disp = 2.0 * config.dt
    assert step_disp > 0.1 * config.skin  # the column outruns half the skin within a block
    assert not bool(needs_rebuild(state, config))  # fresh list
    run = jax.jit(lambda s, p: make_rollout(config, 1, checkpoint=False)(s, p)[0])
    plain = jax.jit(lambda s, p: make_rollout(config, 1, checkpoint=False, rebuild_on_displacement=False)(s, p)[0])
    every = config.replace(rebuild_every=1)
    ref = jax.jit(lambda s, p: make_rollout(every, 16, checkpoint=False, rebuild_on_displacement=False)(s, p)[0])
    out, out_plain, out_ref = run(state, params), plain(state, params), ref(state, params)
    assert int(out.status) == 0, Status.describe(int(out.status))
    assert int(out_ref.status) == 0, Status.describe(int(out_ref.status))
    assert int(out_plain.status) & Status.NEIGHBOUR_STALE
    x, v = _by_pid(out.particles)
    x_ref, v_ref = _by_pid(out_ref.particles)
    # same pairs within the support, summed in another order: float32 rounding only
    assert np.max(np.abs(x - x_ref)) < 1e-5 * 0.125
    assert np.max(np.abs(v - v_ref)) < 1e-4


def test_vmapped_build_keeps_its_conditionals_and_equals_each_member():
    """Under ``jax.vmap`` the list build's two conditionals (the fixed walls' sort, skipped when
    already sorted, and the fusion boundary ``_materialise``) stay conditionals instead of selects
    of both branches (``_uniform_cond``), and each member's list equals its own build: here one
    member's walls are sorted and the other's are not, so the batch takes the full branch."""
    import jax.numpy as jnp

    from rockjax.sph.neighbours import _uniform_cond

    rng = np.random.default_rng(7)
    nf, nw, box = 60, 40, np.array([1.0, 0.6, 0.5])
    kind = np.array([Kind.FLUID] * nf + [Kind.WALL] * nw, np.int32)
    grid = GridSpec.covering((0, 0, 0), tuple(box), min_cell=0.1, periodic=(False, False, False))
    cfg = Config(n_fluid=nf, n_wall=nw, dt=1e-4, grid=grid, cutoff=0.1, skin=0.0,
                 capacities=Capacities(neighbours=64, cells=64, wall_pairs=nf * 64))
    members = [_particles(rng.uniform(0, 1, (nf + nw, 3)) * box, kind) for _ in range(2)]
    members[0] = _jit_rebuild(members[0], cfg)[0]  # its walls now sorted by cell; the other's not
    batch = jax.tree_util.tree_map(lambda *a: jnp.stack(a), *members)
    vmapped = jax.vmap(lambda P: rebuild(P, cfg))
    assert str(jax.make_jaxpr(vmapped)(batch)).count("cond[") >= 3  # the sort's and two _materialise
    Pb, nb, sb = jax.jit(vmapped)(batch)
    for m, P in enumerate(members):
        P1, n1, s1 = _jit_rebuild(P, cfg)
        assert int(sb[m]) == int(s1) == 0
        np.testing.assert_array_equal(np.asarray(Pb.pid[m]), np.asarray(P1.pid))
        np.testing.assert_array_equal(np.asarray(nb.idx[m]), np.asarray(n1.idx))
        np.testing.assert_array_equal(np.asarray(nb.wall_col[m]), np.asarray(n1.wall_col))

    # the batched rule: the fast branch for all only when the predicate holds for every member
    f = jax.vmap(lambda p, x: _uniform_cond(p, lambda t: t + 1, lambda t: t - 1, x))
    np.testing.assert_array_equal(np.asarray(f(jnp.array([True, True]), jnp.zeros(2))), [1, 1])
    np.testing.assert_array_equal(np.asarray(f(jnp.array([True, False]), jnp.zeros(2))), [-1, -1])
