"""The WCSPH step summed in blocks of rows (``Tuning.row_tile``, ``neighbours.scan_rows``) equals
the step over all rows at once: same state (to float rounding) and same gradients, for both wall
models, with a tile that does not divide the row count (the last block overlaps its predecessor,
and its overlapping rows must not be counted twice); and the walls' sums over the flat fluid-wall
pair list equal the same sums taken as transposes of the full rows."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.sph import wcsph
from rockjax.sph.neighbours import block_plan, pairs, scan_rows
from rockjax.step import advance, prime


def test_block_plan_balances_blocks():
    assert block_plan(686, 512) == (343, 2)
    assert block_plan(21296, 512) == (508, 42)
    for n in range(1, 300):
        for tile in (1, 5, 17, 64):
            size, count = block_plan(n, tile)
            assert size <= max(tile, 1) and (count - 1) * size < n <= count * size


def test_scan_rows_covers_each_row_once():
    n, tile = 23, 5  # blocks of 5: the last one overlaps its predecessor by 2 rows

    def fn(rows, own, acc):
        ids = rows.ids()
        acc = acc.at[ids].add(1 if own is None else jnp.where(own, 1, 0))
        return acc, ids * 10

    acc, out = scan_rows(fn, n, tile, jnp.zeros((n,), jnp.int32))
    np.testing.assert_array_equal(np.asarray(acc), np.ones(n))  # every row contributed exactly once
    np.testing.assert_array_equal(np.asarray(out), 10 * np.arange(n))
    acc1, out1 = scan_rows(fn, n, 0, jnp.zeros((n,), jnp.int32))  # one block, own=None
    np.testing.assert_array_equal(np.asarray(acc1), np.ones(n))
    np.testing.assert_array_equal(np.asarray(out1), 10 * np.arange(n))


@pytest.fixture(scope="module", params=[rj.sph.Adami(), rj.sph.DynamicWalls()], ids=["adami", "dynamic"])
def primed(request, x64):
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4,
                             scheme=rj.WCSPH(walls=request.param))
    config = sc.config.tuned(row_tile=0)
    state = jax.jit(lambda s, p: prime(s, p, config))(sc.state, sc.params)
    yield config, sc.params, state


def _run(config, params, state, steps=5):
    def body(s, _):
        return advance(s, params, config), None
    return jax.lax.scan(body, state, None, length=steps)[0]


def test_tiled_step_equals_untiled(primed, x64):
    config, params, state = primed
    nf = config.n_fluid
    size, count = block_plan(nf, 17)
    assert count > 2 and nf % size, "the check needs several blocks and an overlapping last one"
    ref = jax.jit(lambda s: _run(config, params, s))(state).particles
    tiled = config.tuned(row_tile=17)
    out = jax.jit(lambda s: _run(tiled, params, s))(state).particles
    for name in ("x", "v", "a", "rho", "p", "drho_dt"):
        a, b = np.asarray(getattr(out, name)), np.asarray(getattr(ref, name))
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10 * np.abs(b).max(), err_msg=name)
    assert np.abs(np.asarray(ref.p)[nf:]).max() > 0, "walls must carry pressure for the check to mean anything"


def test_tiled_gradient_equals_untiled(primed, x64):
    config, params, state = primed
    def loss(c0, cfg):
        p = params.replace(fluid=params.fluid.replace(c0=c0))
        P = _run(cfg, p, state, steps=3).particles
        return jnp.sum(P.x[:, 0] ** 2) + 1e-6 * jnp.sum(P.p)

    c0 = params.fluid.c0
    g_ref = jax.jit(jax.grad(lambda c: loss(c, config)))(c0)
    g_tiled = jax.jit(jax.grad(lambda c: loss(c, config.tuned(row_tile=17))))(c0)
    assert np.isfinite(g_ref) and g_ref != 0
    np.testing.assert_allclose(float(g_tiled), float(g_ref), rtol=1e-9)


def test_row_gather_equals_component_gather(primed, x64):
    """``GatherForm.ROWS`` (the neighbours' values stacked and gathered by rows) gives the same
    steps, and the same gradient under both adjoints, as one 1-D gather per value (float64)."""
    config, params, state = primed
    rows = config.tuned(gather=rj.GatherForm.ROWS)
    a = jax.jit(lambda s: _run(config, params, s))(state).particles
    b = jax.jit(lambda s: _run(rows, params, s))(state).particles
    for name in ("x", "v", "rho", "p"):
        np.testing.assert_allclose(np.asarray(getattr(b, name)), np.asarray(getattr(a, name)), rtol=1e-12, atol=1e-12)
    if config.scheme.walls.dynamic:
        pytest.skip("the gradient part runs with the Adami walls only (compile time)")

    def loss(c0, cfg):
        p = params.replace(fluid=params.fluid.replace(c0=c0))
        P = _run(cfg, p, state, steps=3).particles
        return jnp.sum(P.x[:, 0] ** 2) + 1e-6 * jnp.sum(P.p)

    c0 = params.fluid.c0
    ref = float(jax.jit(jax.grad(lambda c: loss(c, config.tuned(adjoint=rj.Adjoint.AUTODIFF))))(c0))
    assert np.isfinite(ref) and ref != 0
    for adjoint in (rj.Adjoint.AUTODIFF, rj.Adjoint.PAIR_SUMS):
        g = jax.jit(jax.grad(lambda c: loss(c, rows.tuned(adjoint=adjoint))))(c0)
        np.testing.assert_allclose(float(g), ref, rtol=1e-9, err_msg=adjoint.value)


def test_row_tile_validated():
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4)
    with pytest.raises(ValueError, match="row_tile"):
        sc.config.tuned(row_tile=-1)


def test_flat_wall_sums_equal_row_transpose(primed, x64):
    """The step's wall sums run over the flat fluid-wall list (``NeighbourList.wall_row``); they
    equal the same sums taken as transposes of the full rows (``wcsph.pressure`` / ``density_rate``)."""
    config, params, state = primed
    nf = config.n_fluid
    assert int(state.nbrs.wall_count) > 0
    P0 = state.particles
    P = jax.jit(lambda s: advance(s, params, config))(state).particles
    pr = pairs(P.x, P.kind, state.nbrs.idx, config)
    if not config.scheme.walls.dynamic:
        p_rows, _ = wcsph.pressure(pr, P.rho, P.kind, params, config)
        np.testing.assert_allclose(np.asarray(P.p)[nf:], np.asarray(p_rows)[nf:], rtol=1e-10,
                                   atol=1e-10 * float(np.abs(p_rows).max()))
    else:
        fluid = (P0.kind == rj.Kind.FLUID)[:, None]
        v_half = jnp.where(fluid, P0.v + 0.5 * config.dt * P0.a, P0.v)
        rate = wcsph.density_rate(pr, v_half, P0.rho, P0.vol, P0.kind, params, config)
        np.testing.assert_allclose(np.asarray(P.drho_dt)[nf:], np.asarray(rate)[nf:], rtol=1e-10,
                                   atol=1e-10 * float(np.abs(rate).max()))
    assert np.abs(np.asarray(P.p)[nf:]).max() > 0


def test_default_row_tile_depends_on_list_size():
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4)
    c = sc.config
    assert c.tuning.row_tile is None and c.effective_row_tile == 0  # a few hundred rows: one block
    big = c.replace(n_fluid=2**20 // c.neighbour_capacity + 1)
    assert big.effective_row_tile == 512
    assert c.tuned(row_tile=0).effective_row_tile == 0 and c.tuned(row_tile=64).effective_row_tile == 64


def test_default_row_tile_is_one_block_on_accelerators(monkeypatch):
    """On a GPU the row blocks are a sequential scan: the default there is one block, and with it
    the ``AUTODIFF`` adjoint (an explicit ``row_tile`` still wins)."""
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4)
    big = sc.config.replace(n_fluid=2**20 // sc.config.neighbour_capacity + 1)
    assert big.effective_row_tile == 512 and big.effective_adjoint == rj.Adjoint.PAIR_SUMS  # here: the CPU
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert big.effective_row_tile == 0 and big.effective_adjoint == rj.Adjoint.AUTODIFF
    assert big.tuned(row_tile=512).effective_row_tile == 512


def test_default_gather_is_rows_on_accelerators_only(monkeypatch):
    """``GatherForm`` resolves by backend: 1-D gathers on the CPU (their forward is faster there),
    row gathers on a GPU (their reverse mode is faster there); an explicit ``gather`` still wins."""
    c = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4).config
    assert c.tuning.gather is None and c.effective_gather == rj.GatherForm.COMPONENTS  # here: the CPU
    assert c.tuned(gather=rj.GatherForm.ROWS).effective_gather == rj.GatherForm.ROWS
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert c.effective_gather == rj.GatherForm.ROWS
    assert c.tuned(gather=rj.GatherForm.COMPONENTS).effective_gather == rj.GatherForm.COMPONENTS


def _assert_same_coupled(a, b, *, block_rtol, block_atol):
    """Two coupled states agree: water to 1e-12, blocks to the given tolerances; the wedge moved."""
    for name in ("x", "v", "rho", "p"):
        x, y = np.asarray(getattr(b.particles, name)), np.asarray(getattr(a.particles, name))
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * np.abs(y).max(), err_msg=name)
    for name in ("x", "v", "omega"):
        x, y = np.asarray(getattr(b.blocks, name)), np.asarray(getattr(a.blocks, name))
        np.testing.assert_allclose(x, y, rtol=block_rtol, atol=block_atol, err_msg=f"blocks.{name}")
    assert np.abs(np.asarray(a.blocks.v)).max() > 0, "the wedge must move for the check to mean anything"


def test_row_gather_equals_component_gather_in_a_coupled_step(x64):
    """The accelerators' default ``GatherForm.ROWS`` gives the same coupled steps as the CPU's 1-D
    gathers (float64): a small wedge sliding into water with boundary particles, whose block
    particles enter the pair sums and whose loads are summed over the body sub-list."""
    sc = rj.scenes.sliding_wedge(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                                 flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                 coupling=rj.Coupling.BOUNDARY_PARTICLES)
    config = sc.config.tuned(gather=rj.GatherForm.COMPONENTS)
    rows = config.tuned(gather=rj.GatherForm.ROWS)
    state = jax.jit(lambda s, p: prime(s, p, config))(sc.state, sc.params)
    a = jax.jit(lambda s: _run(config, sc.params, s, steps=4))(state)
    b = jax.jit(lambda s: _run(rows, sc.params, s, steps=4))(state)
    _assert_same_coupled(a, b, block_rtol=1e-12, block_atol=1e-14)


def _wall_ordered_run(config, params, sc_state, steps=5):
    """Prime (a list build: with ``WallSums.RANGES`` the flat wall list comes out in wall order) and step."""
    state = jax.jit(lambda s, p: prime(s, p, config))(sc_state, params)
    return state, jax.jit(lambda s: _run(config, params, s, steps=steps))(state)


def test_order_by_wall_matches_numpy():
    """``order_by_wall`` sorts the valid pairs by wall (rows ascending within a wall, padding last)
    and gives each wall's first slot; ``wall_sum`` over it equals ``segment_sum`` over the row order."""
    from rockjax.sph.neighbours import order_by_wall, wall_sum
    from rockjax.sph.walls import WallPairs

    rng = np.random.default_rng(3)
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4)
    config = sc.config.tuned(wall_sums=rj.WallSums.RANGES)
    nf, n, M, count = config.n_fluid, config.n_particles, 64, 50
    row = np.sort(rng.integers(0, nf, M)).astype(np.int32)
    col = rng.integers(nf, nf + 7, M).astype(np.int32)  # a few walls, several pairs each
    row[count:], col[count:] = 0, 0
    r, c, start = (np.asarray(a) for a in order_by_wall(jnp.asarray(row), jnp.asarray(col), count, config))
    order = np.argsort(col[:count], kind="stable")
    np.testing.assert_array_equal(c[:count], col[:count][order])
    np.testing.assert_array_equal(r[:count], row[:count][order])
    np.testing.assert_array_equal(start, np.searchsorted(col[:count][order], np.arange(nf, n + 1)))
    vals = rng.normal(size=(M, 2))
    vals[count:] = 0.0
    valid = jnp.arange(M) < count
    ref = jax.ops.segment_sum(jnp.asarray(vals), jnp.asarray(col), num_segments=n)
    wp = WallPairs(row=jnp.asarray(r), col=jnp.asarray(c), d=None, r=None, valid=valid, start=jnp.asarray(start))
    got = wall_sum(jnp.asarray(vals[:count][order].tolist() + vals[count:].tolist()), wp, config)
    np.testing.assert_allclose(np.asarray(got), np.asarray(ref), rtol=1e-6, atol=1e-6)
    assert np.abs(np.asarray(ref)[nf:nf + 7]).min() > 0


def test_wall_ranges_equal_scatter(primed, x64):
    """``WallSums.RANGES`` (the accelerators' default: the wall list in wall order, summed onto the
    walls by a segmented scan) gives the steps of ``WallSums.SCATTER`` (``segment_sum``), float64,
    for the Adami walls (with and without their no-slip velocity) and dynamic walls."""
    config, params, state = primed
    nf = config.n_fluid
    schemes = [config.scheme]
    if not config.scheme.walls.dynamic:
        schemes.append(rj.WCSPH(walls=rj.sph.Adami(no_slip=True)))
    for scheme in schemes:
        base = config.replace(scheme=scheme).tuned(wall_sums=rj.WallSums.SCATTER)
        ranges = base.tuned(wall_sums=rj.WallSums.RANGES)
        assert ranges.wall_ordered and not base.wall_ordered
        _, a = _wall_ordered_run(base, params, state)
        s_r, b = _wall_ordered_run(ranges, params, state)
        count = int(s_r.nbrs.wall_count)
        col = np.asarray(s_r.nbrs.wall_col)[:count]
        assert count > 0 and np.all(np.diff(col) >= 0), "the list must come out in wall order"
        np.testing.assert_array_equal(np.asarray(s_r.nbrs.wall_start), np.searchsorted(col, np.arange(nf, config.n_particles + 1)))
        for name in ("x", "v", "rho", "p", "drho_dt"):
            x, y = np.asarray(getattr(b.particles, name)), np.asarray(getattr(a.particles, name))
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * np.abs(y).max(), err_msg=f"{scheme}: {name}")
        assert int(b.status) == 0
    walls = np.asarray(a.particles.drho_dt if config.scheme.walls.dynamic else a.particles.p)[nf:]
    assert np.abs(walls).max() > 0, "the walls' sums must be non-zero for the check to mean anything"


def test_wall_ranges_gradient_equals_scatter(primed, x64):
    """The reverse mode through the segmented scan (``AUTODIFF``) and through ``PAIR_SUMS``'s wall
    columns (which sum over the wall list too) equals the scatter form's gradient, float64."""
    config, params, state = primed
    if config.scheme.walls.dynamic:
        pytest.skip("the gradient part runs with the Adami walls only (compile time)")

    def loss(c0, cfg):
        st = prime(state, params, cfg)
        p = params.replace(fluid=params.fluid.replace(c0=c0))
        P = _run(cfg, p, st, steps=3).particles
        return jnp.sum(P.x[:, 0] ** 2) + 1e-6 * jnp.sum(P.p)

    c0 = params.fluid.c0
    base = config.tuned(wall_sums=rj.WallSums.SCATTER, adjoint=rj.Adjoint.AUTODIFF)
    ref = float(jax.jit(jax.grad(lambda c: loss(c, base)))(c0))
    assert np.isfinite(ref) and ref != 0
    for adjoint in (rj.Adjoint.AUTODIFF, rj.Adjoint.PAIR_SUMS):
        cfg = config.tuned(wall_sums=rj.WallSums.RANGES, adjoint=adjoint)
        g = jax.jit(jax.grad(lambda c: loss(c, cfg)))(c0)
        np.testing.assert_allclose(float(g), ref, rtol=1e-9, err_msg=adjoint.value)


def test_default_wall_sums_are_ranges_on_accelerators_only(monkeypatch):
    """``WallSums`` resolves by backend: the scatter on the CPU (serial there: 2x faster than the
    scan), the wall-ordered scan on a GPU (the scatter's atomics were half a 1M step there); an
    explicit setting wins; schemes that leave the wall list empty (DFSPH without blocks) sort nothing."""
    c = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4).config
    d = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4,
                            scheme=rj.DFSPH()).config
    assert c.tuning.wall_sums is None and not c.wall_ordered  # here: the CPU
    assert c.tuned(wall_sums=rj.WallSums.RANGES).wall_ordered
    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")
    assert c.wall_ordered and not d.wall_ordered
    assert not c.tuned(wall_sums=rj.WallSums.SCATTER).wall_ordered
    with pytest.raises(ValueError, match="wall_sums"):
        rj.Tuning(wall_sums="ranges")


def test_wall_ranges_in_a_coupled_step(x64):
    """With boundary particles the block sub-list is cut from the wall list: in wall order it gives
    the same coupled steps (water and blocks) as the row order, float64."""
    sc = rj.scenes.sliding_wedge(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                                 flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                 coupling=rj.Coupling.BOUNDARY_PARTICLES)
    base = sc.config.tuned(wall_sums=rj.WallSums.SCATTER)
    ranges = sc.config.tuned(wall_sums=rj.WallSums.RANGES)
    _, a = _wall_ordered_run(base, sc.params, sc.state, steps=4)
    _, b = _wall_ordered_run(ranges, sc.params, sc.state, steps=4)
    _assert_same_coupled(a, b, block_rtol=1e-11, block_atol=1e-13)
