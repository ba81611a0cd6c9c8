"""Hydrostatic tank (WCSPH, Adami walls): after settling, pressure vs depth against rho g d;
no particle leaves; fluid mass constant; energy does not grow.

Closed form: p(d) = rho0 g d (d = depth below the free surface). The free surface of a
lattice of particles sits dx/2 above the top particle row, i.e. at z = depth.
"""

import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.observables import energies, fluid_mass, probe_pressure

DX = 0.02
DEPTH = 0.2
# h = 1.5 dx: on a cubic lattice the Wendland gradient moment sum_j V_j x_ij dW_ij/dx is -1.0006
# (at 1.3 dx it is -0.979, a 2 % bias in the pressure gradient that shows directly in p(d)).
H_FACTOR = 1.5


@pytest.fixture(scope="module")
def tank():
    scene = rj.scenes.hydrostatic_tank(dx=DX, length=0.2, width=0.2, depth=DEPTH, h_factor=H_FACTOR)
    result = rj.simulate(scene, t_end=0.4, frame_dt=0.05, progress=False)
    return scene, result


def test_pressure_matches_rho_g_depth(tank):
    scene, result = tank
    cfg, prm = result.scene.config, scene.params
    depths = np.array([0.05, 0.08, 0.11, 0.14])
    pts = jnp.asarray([[0.1, 0.1, DEPTH - d] for d in depths], jnp.float32)
    p = np.asarray(probe_pressure(result.state, prm, cfg, pts))
    exact = 1000.0 * 9.81 * depths
    rel = np.abs(p - exact) / exact
    print("hydrostatic p/exact:", np.round(p / exact, 4))
    # Stated bound at this coarse test resolution (10 particle layers): 3 % (target 1 % at benchmark dx).
    assert np.all(rel < 0.03), rel


def test_no_particle_leaves_and_mass_constant(tank):
    scene, result = tank
    x = result.frames["x"][-1][result.frames["kind"][0] == rj.Kind.FLUID]
    eps = 1e-6
    assert np.all((x[:, 0] > -eps) & (x[:, 0] < 0.2 + eps) & (x[:, 1] > -eps) & (x[:, 1] < 0.2 + eps))
    assert np.all(x[:, 2] > -eps)
    assert float(fluid_mass(result.state, scene.params)) == pytest.approx(float(fluid_mass(scene.state, scene.params)), rel=1e-7)
    assert result.stats["steps"] > 1000


def test_settles(tank):
    _, result = tank
    v = result.frames["v"][-1][result.frames["kind"][0] == rj.Kind.FLUID]
    assert np.abs(v).max() < 0.05  # m/s, vs sqrt(g depth) = 1.4 m/s


def test_energy_does_not_grow(tank):
    scene, result = tank
    cfg, prm = result.scene.config, scene.params
    e0 = energies(rj.prime(scene.state, prm, cfg), prm, cfg)["total"]
    e1 = energies(result.state, prm, cfg)["total"]
    scale = float(fluid_mass(scene.state, prm)) * 9.81 * DEPTH  # m g H, J
    print("energy change / (m g H):", float(e1 - e0) / scale)
    assert float(e1 - e0) <= 1e-3 * scale


@pytest.mark.slow
def test_pressure_within_one_percent_at_benchmark_resolution():
    """Benchmark resolution: 20 particle layers (dx = depth / 20), h = 1.5 dx, an infinite layer
    (periodic x, y; 8 dx period) so that only the floor and the free surface bound the water.

    Against the closed form rho0 g d at depths 0.05-0.17 m, within 1 % (~2 min). At h = 1.3 dx
    the same scene is not at rest: the cubic lattice rearranges and the pressure fluctuates by a
    few per cent (RESULTS.md "A layer of water at rest"), so only h = 1.5 dx meets 1 %.
    """
    dx = DEPTH / 20
    L = 8 * dx
    scene = rj.scenes.hydrostatic_tank(dx=dx, length=L, width=L, depth=DEPTH, h_factor=1.5, periodic_xy=True)
    result = rj.simulate(scene, t_end=0.4, frame_dt=0.05, progress=False)
    depths = np.array([0.05, 0.08, 0.11, 0.14, 0.17])
    pts = jnp.asarray([[L / 2, L / 2, DEPTH - d] for d in depths], jnp.float32)
    p = np.asarray(probe_pressure(result.state, scene.params, result.scene.config, pts))
    ratio = p / (1000.0 * 9.81 * depths)
    print("benchmark hydrostatic p/exact:", np.round(ratio, 4))
    assert np.all(np.abs(ratio - 1) <= 0.01), ratio
    x = result.frames["x"][-1][result.frames["kind"][0] == rj.Kind.FLUID]
    assert np.all(x[:, 2] > 0)
