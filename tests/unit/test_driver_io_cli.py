"""Driver (regrow on overflow, fatal errors with the step), HDF5 round trip, CLI, host validation."""

import json
import subprocess
import sys

import numpy as np
import pytest

import rockjax as rj


@pytest.fixture(scope="module")
def small():
    return rj.scenes.hydrostatic_tank(dx=0.05, length=0.2, width=0.2, depth=0.2)


def test_regrows_neighbour_buffer_and_matches(small, tmp_path):
    tight = small.replace(config=small.config.grown(neighbours=16))
    ref = rj.simulate(small, t_end=0.02, frame_dt=0.01, progress=False)
    grown = rj.simulate(tight, t_end=0.02, frame_dt=0.01, progress=False, out=str(tmp_path / "g.h5"), keep_frames=True)
    assert grown.stats["regrows"] >= 1
    assert grown.scene.config.neighbour_capacity >= int(ref.state.nbrs.max_count)
    np.testing.assert_allclose(grown.frames["x"][-1], ref.frames["x"][-1], atol=1e-6)
    run = rj.io.read(str(tmp_path / "g.h5"))
    np.testing.assert_allclose(run.x, grown.frames["x"])
    np.testing.assert_allclose(run.time, grown.times)
    assert run.scene == "hydrostatic_tank" and run.config["scheme"]["name"] == "wcsph"
    assert run.config["scheme"]["diffusion"] == {"name": "fourtakas"}
    assert float(run.params["fluid/rho0"]) == 1000.0
    assert run.x.shape == (len(run.time), small.config.n_particles, 3)


def test_fatal_status_raises_with_step(small):
    # Params that break the run under the fixed dt: refused on the host first ...
    bad = small.replace(params=small.params.replace(fluid=small.params.fluid.replace(c0=small.params.fluid.c0 * 4)))
    with pytest.raises(ValueError, match="stability limit"):
        rj.simulate(bad, t_end=0.01, progress=False)
    # ... and h beyond the neighbour cutoff too.
    bad_h = small.replace(params=small.params.replace(fluid=small.params.fluid.replace(h=small.params.fluid.h * 1.5)))
    with pytest.raises(ValueError, match="cutoff"):
        rj.simulate(bad_h, t_end=0.01, progress=False)


def test_out_of_domain_stops_with_step():
    scene = rj.scenes.hydrostatic_tank(dx=0.05, length=0.2, width=0.2, depth=0.2)
    P = scene.state.particles
    v = P.v.at[0].set(np.array([0.0, 0.0, 40.0], np.float32))
    scene = scene.replace(state=scene.state.replace(particles=P.replace(v=v)))
    with pytest.raises(rj.SimulationError) as info:
        rj.simulate(scene, t_end=0.05, frame_dt=0.01, progress=False)
    # 40 m/s already breaks the Courant limit dt <= 0.5 h / (c0 + v_max) (h = 0.065 m, c0 = 19.8 m/s:
    # 5.4e-4 s < dt = 8.2e-4 s), so the very first step is flagged -- not the last of its chunk.
    cfg, f = scene.config, scene.params.fluid
    assert cfg.dt > 0.5 * float(f.h) / (float(f.c0) + 40.0)
    assert info.value.step == 1, info.value.step
    assert "UNSTABLE_DT" in str(info.value) and "step 1 " in str(info.value)


@pytest.mark.parametrize("kw,field", [({"dx": -1.0}, "dx"), ({"column_length": 3.0}, "column_length"),
                                       ({"dx": 0.4}, "dx")])
def test_bad_scene_input(kw, field):
    with pytest.raises(ValueError, match=field):
        rj.scenes.dam_break(**kw)


def test_cli_list_and_run(tmp_path):
    out = subprocess.run([sys.executable, "-m", "rockjax.cli", "list"], capture_output=True, text=True, check=True)
    assert "dam_break" in out.stdout and "hydrostatic_tank" in out.stdout
    h5 = tmp_path / "run.h5"
    res = subprocess.run([sys.executable, "-m", "rockjax.cli", "run", "hydrostatic_tank", "--dx", "0.05",
                          "--t-end", "0.01", "--out", str(h5), "--quiet"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout.strip().splitlines()[-1])
    assert summary["scene"] == "hydrostatic_tank" and summary["steps"] > 0
    assert rj.io.read(str(h5)).x.shape[0] >= 2
    bad = subprocess.run([sys.executable, "-m", "rockjax.cli", "run", "nope"], capture_output=True, text=True)
    assert bad.returncode == 2 and "rockjax list" in bad.stderr


def test_scheduled_step_replays_the_rollout():
    # the driver's chunks scan rollout.scheduled_step: stepping with it must reproduce
    # make_rollout (same rebuilds at block starts and on displacement)
    import jax

    from rockjax.rollout import make_rollout, scheduled_step

    scene = rj.scenes.dam_break(dx=0.1, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8,
                                tank_width=0.3)
    s0 = rj.prime(scene.state, scene.params, scene.config)
    n_blocks = 3
    ref, _ = jax.jit(make_rollout(scene.config, n_blocks, checkpoint=False))(s0, scene.params)
    step = jax.jit(scheduled_step(scene.config))
    s = s0
    for _ in range(n_blocks * scene.config.rebuild_every):
        s = step(s, scene.params)
    assert int(s.step) == int(ref.step) == n_blocks * scene.config.rebuild_every
    assert float(np.max(np.abs(np.asarray(ref.particles.v)))) > 0.05  # the column is collapsing
    np.testing.assert_allclose(np.asarray(s.particles.x), np.asarray(ref.particles.x), rtol=0, atol=1e-6)
    np.testing.assert_array_equal(np.asarray(s.nbrs.idx), np.asarray(ref.nbrs.idx))


def test_undamped_wcsph_is_warned(small):
    """WCSPH with alpha = 0 and no density diffusion is allowed but warned about (measured unstable,
    experiments/energy_creep.py); the defaults, or either damping alone, are not warned about."""
    import warnings

    f = small.params.fluid
    undamped = small.params.replace(fluid=f.replace(alpha=0.0 * f.alpha, delta=0.0 * f.delta))
    with pytest.warns(RuntimeWarning, match="alpha"):
        rj.scenes.check_params(small.config, undamped)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rj.scenes.check_params(small.config, small.params)
        rj.scenes.check_params(small.config, small.params.replace(fluid=f.replace(alpha=0.0 * f.alpha)))
        rj.scenes.check_params(small.config, small.params.replace(fluid=f.replace(delta=0.0 * f.delta)))


def test_unwritable_out_is_refused_before_the_run(small, tmp_path, capsys):
    """An output path whose folder does not exist is refused by ``simulate`` and by the CLI (also
    with ``--dry-run``) before anything runs: a ValueError / exit 2 naming the path, no chunk
    compiled, no file written."""
    from rockjax import driver
    from rockjax.cli import main

    out = tmp_path / "missing" / "run.h5"
    compiled = driver._compiled_chunk.cache_info().misses
    with pytest.raises(ValueError, match=r"out = .*run\.h5.*does not exist; create it"):
        rj.simulate(small, t_end=0.01, out=str(out), progress=False)
    for extra in (["--dry-run"], ["--quiet"]):
        assert main(["run", "hydrostatic_tank", "--dx", "0.05", "--t-end", "0.01", "--out", str(out), *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "missing" in err[0], err
    assert driver._compiled_chunk.cache_info().misses == compiled
    assert not out.parent.exists()


def test_non_finite_mid_chunk_names_the_first_step_and_field(small, monkeypatch):
    """A NaN that appears in the particle velocities after step 7 of a 12-step chunk: the
    SimulationError names step 7 (each chunk carries the index of its first fatal step through
    its scan) and the field ``particles.v`` -- not the chunk's last step, and not the fields
    the NaN reached later (positions, densities)."""
    import jax.numpy as jnp

    from rockjax import driver
    from rockjax.types import Status

    real = driver.scheduled_step

    def poisoned(config, period):
        one = real(config, period=period)

        def step(s, params):
            s = one(s, params)
            hit = s.step == 7
            v = jnp.where(hit, jnp.nan, s.particles.v)
            return s.replace(particles=s.particles.replace(v=v),
                             status=s.status | jnp.where(hit, int(Status.NON_FINITE), 0).astype(jnp.int32))

        return step

    monkeypatch.setattr(driver, "scheduled_step", poisoned)
    driver._compiled_chunk.cache_clear()
    try:
        frame_dt = 12 * small.config.dt
        with pytest.raises(rj.SimulationError) as info:
            rj.simulate(small, t_end=3 * frame_dt, frame_dt=frame_dt, progress=False)
    finally:
        driver._compiled_chunk.cache_clear()  # drop the poisoned program
    e = info.value
    assert e.step == 7 and "step 7 " in str(e), str(e)
    assert e.fields == ("particles.v",) and "NON_FINITE in particles.v." in str(e), str(e)
    assert e.status & Status.NON_FINITE


def test_chunk_carry_leaves_the_state_bit_for_bit(small):
    """The driver's chunk carries the first fatal step and a field mask beside the state; the
    state it returns is bit for bit that of a plain scan of ``rollout.scheduled_step``."""
    import jax

    from rockjax import driver
    from rockjax.rollout import scheduled_step

    cfg, params = small.config, small.params
    s0 = rj.prime(small.state, params, cfg)
    one = scheduled_step(cfg, period=32)
    ref = jax.jit(lambda s, p: jax.lax.scan(lambda c, _: (one(c, p), None), s, None, length=6)[0])(s0, params)
    got, first, fields = driver._compiled_chunk(cfg, 6, 32)(s0, params)
    assert int(first) == -1 and int(fields) == 0 and int(got.step) == 6
    for a, b in zip(jax.tree_util.tree_leaves(got), jax.tree_util.tree_leaves(ref)):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
