"""The incompressible scheme's solves (``rockjax.DFSPH``, ``sph.dfsph``) against what they promise.

* the density solve leaves the predicted density ``rho/rho0 + dt D(v) - 1`` at or below its
  tolerance on average over the compressed rows, recomputed here from the step's input geometry
  and output velocities (not read from the solver's record);
* the divergence solve brings the mean compression rate ``dt D`` of a compressed velocity field to
  its tolerance;
* the pressure forces between fluid particles are equal and opposite: their sum over a periodic
  box (no walls) vanishes to round-off for any pressures;
* a solve that cannot converge within its cap is reported by the driver (step and cause), not
  passed over;
* a run resumed from its checkpoint continues it exactly (the warm-start pressures are state);
* water at rest in a tank carries the hydrostatic pressure ``rho0 g d`` (closed form; time mean over
  the second half second, solves at 1e-4; Akinci's walls, ``DFSPH(wall_pressure="akinci")``, give
  4-16 % more) and its level does not drift.

Scene: a 4 x 4 x 8-particle water column (dx 0.025 m) collapsing in a 0.2 m tank (dam break), a
few steps in, when the flow compresses the water against the walls.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import scenes
from rockjax.scenes.base import fluid_scene, lattice
from rockjax.sph import dfsph
from rockjax.step import make_step, prime, refresh

DX = 0.025


def _column(scheme):
    return scenes.dam_break(dx=DX, column_length=0.1, column_width=0.1, column_height=0.2, tank_length=0.2,
                            tank_width=0.1, tank_height=0.3, scheme=scheme)


@pytest.fixture(scope="module")
def flowing():
    """The column 10 steps into its collapse, and the step function (list rebuilt every step)."""
    scene = _column(rj.DFSPH())
    config = scene.config.replace(rebuild_every=1)
    step = jax.jit(make_step(config))
    state = prime(scene.state, scene.params, config)
    for _ in range(10):
        state = step(state, scene.params)
    assert int(state.status) == 0, rj.Status.describe(int(state.status))
    return config, scene.params, state, step


def test_density_solve_meets_its_tolerance(flowing):
    config, params, state, step = flowing
    out = step(state, params)  # rebuilds the list (sorts) first: take the geometry it used
    refreshed = refresh(state, config)
    P = refreshed.particles
    geo = dfsph.geometry(P.x, P.kind, P.vol, refreshed.nbrs, params, config)
    assert np.array_equal(np.asarray(out.particles.pid), np.asarray(P.pid))  # the step's own order
    v_new = out.particles.v
    fluid = np.asarray(P.kind)[: config.n_fluid] == rj.Kind.FLUID
    r = np.asarray(geo.rho + config.dt * dfsph.divergence(geo, v_new) - 1.0)[fluid]
    compressed = np.maximum(r, 0.0)
    print(f"rows {fluid.sum()}: mean max(r, 0) {compressed.mean():.2e}, max {compressed.max():.2e}, "
          f"sweeps {np.asarray(out.particles.solver)[0, 4]:.0f}")
    assert compressed.mean() <= config.scheme.tolerance
    assert np.asarray(out.particles.solver)[0, 4] < config.scheme.max_iterations


def test_divergence_solve_meets_its_tolerance(flowing):
    config, params, state, _ = flowing
    refreshed = refresh(state, config)
    P = refreshed.particles
    nf = config.n_fluid
    geo = dfsph.geometry(P.x, P.kind, P.vol, refreshed.nbrs, params, config)
    fluid = P.kind[:nf] == rj.Kind.FLUID
    centre = jnp.mean(jnp.where(fluid[:, None], P.x[:nf], 0.0), axis=0) * nf / jnp.sum(fluid)
    v = P.v.at[:nf].set(jnp.where(fluid[:, None], -0.5 * (P.x[:nf] - centre), 0.0))  # 1/s compression
    dt = config.dt
    residual = lambda geo, v: dt * dfsph.divergence(geo, v)  # noqa: E731
    before = float(jnp.mean(jnp.where(fluid, jnp.maximum(residual(geo, v), 0.0), 0.0)))
    tol = 1e-4
    sol = dfsph._solve(geo, v, jnp.zeros((nf,), v.dtype), residual, fluid, fluid, implicit=False, tolerance=tol,
                       min_iterations=2, max_iterations=500, fixed=None, relaxation=0.4, dt=dt, model="akinci",
                       adjoint_iterations=1)
    after = np.asarray(residual(geo, sol.v))[np.asarray(fluid)]
    print(f"mean dt D: {before:.2e} before, {np.maximum(after, 0).mean():.2e} after ({int(sol.iterations)} sweeps)")
    assert before > 10 * tol  # the field was compressive
    assert np.maximum(after, 0).mean() <= tol
    assert int(sol.iterations) < 500


def test_pressure_forces_are_equal_and_opposite():
    dx, L = 0.02, 0.12
    fx = lattice([0, 0, 0], [L, L, L], dx)
    fx = fx + np.random.default_rng(1).uniform(-0.2, 0.2, fx.shape) * dx  # off the lattice
    sc = fluid_scene(name="box", dx=dx, fluid_x=fx % L, wall_x=np.zeros((0, 3)), domain_lo=[0, 0, 0],
                     domain_hi=[L, L, L], periodic=(True, True, True), surface_z=None, c0=5.0, scheme=rj.DFSPH(),
                     h_factor=1.3, alpha=0.0, nu=1e-6, delta=0.0, skin_factor=0.3, rebuild_every=1, cfl=0.25, meta={})
    state = refresh(sc.state, sc.config)
    P = state.particles
    geo = dfsph.geometry(P.x, P.kind, P.vol, state.nbrs, sc.params, sc.config)
    kappa = jnp.asarray(np.random.default_rng(2).uniform(0.0, 2.0, sc.config.n_fluid), P.x.dtype)
    a = np.asarray(dfsph.pressure_acceleration(geo, kappa), np.float64)
    total, scale = a.sum(axis=0), np.abs(a).sum(axis=0)
    print("sum of a:", total, "sum of |a|:", scale)
    assert np.all(np.abs(total) < 1e-5 * scale)  # float32 round-off of ~1700 x 90 terms


def test_non_converged_solve_is_reported():
    scene = _column(rj.DFSPH(min_iterations=1, max_iterations=1, tolerance=1e-9))
    with pytest.raises(rj.SimulationError, match="SOLVER_NOT_CONVERGED") as info:
        rj.simulate(scene, t_end=5 * scene.config.dt, progress=False)
    assert "step" in str(info.value) and "max_iterations" in str(info.value)
    print(info.value)


def test_checkpoint_and_resume_continue_the_run_exactly(tmp_path):
    """The solve record (warm-start pressures) is part of the state from the scene's first array on,
    so a run resumed from its checkpoint matches the straight run to the bit."""
    scene = rj.scenes.hydrostatic_tank(dx=0.04, depth=0.2, scheme=rj.DFSPH())
    out = str(tmp_path / "run.h5")
    rj.simulate(scene, t_end=0.1, frame_dt=0.05, out=out, progress=False, checkpoint_every=1)
    resumed = rj.simulate(scene, t_end=0.2, frame_dt=0.05, out=out, progress=False, resume=out)
    straight = rj.simulate(scene, t_end=0.2, frame_dt=0.05, progress=False)
    a, b = resumed.state.particles, straight.state.particles
    ia, ib = np.argsort(np.asarray(a.pid)), np.argsort(np.asarray(b.pid))
    assert np.array_equal(np.asarray(a.x)[ia], np.asarray(b.x)[ib])
    assert np.array_equal(np.asarray(a.solver)[ia], np.asarray(b.solver)[ib])


HYDRO_DX, HYDRO_DEPTH = 0.02, 0.2
HYDRO_DEPTHS = np.array([0.05, 0.08, 0.11, 0.14, 0.17])


@pytest.fixture(scope="module")
def resting():
    """A 0.2 m deep, 0.2 x 0.2 m tank at dx 0.02 (1000 particles), DFSPH (its default walls and
    viscosity) with the solves at 1e-4
    (tight, so what is measured is the discretisation, not the solver's tolerance), run 1 s; per
    step of the second half: the mean particle pressure of each layer at HYDRO_DEPTHS over rho0 g d
    (d below the lattice's free surface, dx/2 above its top row), and the water's mean height."""
    scheme = rj.DFSPH(tolerance=1e-4, divergence_tolerance=1e-4, max_iterations=400)
    sc = scenes.hydrostatic_tank(dx=HYDRO_DX, length=0.2, width=0.2, depth=HYDRO_DEPTH, scheme=scheme)
    config = sc.config.replace(rebuild_every=1)
    step = jax.jit(make_step(config))

    @jax.jit
    def layers(state):
        P = state.particles
        fluid = P.kind == rj.Kind.FLUID
        d = HYDRO_DEPTH - P.x[:, 2]
        sel = fluid[None, :] & (jnp.abs(d[None, :] - jnp.asarray(HYDRO_DEPTHS)[:, None]) < HYDRO_DX / 2)
        mean_p = jnp.sum(jnp.where(sel, P.p[None, :], 0.0), axis=1) / jnp.sum(sel, axis=1)
        height = jnp.sum(jnp.where(fluid, P.x[:, 2], 0.0)) / jnp.sum(fluid)
        return mean_p / (1000.0 * 9.81 * jnp.asarray(HYDRO_DEPTHS)), height

    state = prime(sc.state, sc.params, config)
    n = int(round(1.0 / config.dt))
    ratios, heights = [], []
    for k in range(n):
        state = step(state, sc.params)
        if k >= n // 2:
            r, z = layers(state)
            ratios.append(np.asarray(r))
            heights.append(float(z))
    assert int(state.status) == 0, rj.Status.describe(int(state.status))
    return np.array(ratios), np.array(heights)


def test_pressure_at_rest_is_hydrostatic(resting):
    ratios, _ = resting
    mean = ratios.mean(axis=0)
    print("time-mean p / rho0 g d at depths", HYDRO_DEPTHS, ":", np.round(mean, 4), " sd", np.round(ratios.std(axis=0), 3))
    # the target is 1 %; measured 0.2-1.1 % at 4-8.5 dx below the surface, and 1.8 % (2.8 % over a
    # 1 s window) at 2.5 dx, where the surface row's clamped pressure is within the kernel (as the
    # WCSPH tank's bound at this resolution, 3 %); Akinci's walls: 4-16 % high
    assert np.all(np.abs(mean[1:] - 1.0) < 0.015), mean
    assert abs(mean[0] - 1.0) < 0.03, mean


def test_level_at_rest_does_not_drift(resting):
    _, heights = resting
    half = len(heights) // 2
    drift = abs(heights[half:].mean() - heights[:half].mean())
    print(f"mean water height {heights.mean():.5f} m, drift between quarters of a second {drift:.2e} m")
    assert drift < 0.02 * HYDRO_DX
