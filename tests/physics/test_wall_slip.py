"""Free-slip and viscous walls (``FluidParams.wall_viscosity``, DualSPHysics' ViscoBoundFactor).

Closed form: a uniform stream u over a flat bed in a layer periodic in x and y has no velocity
gradient in the fluid, so the only tangential force on it is the bed's. With a free-slip bed
(``wall_viscosity = 0``) the mean x-velocity stays u; with the viscous bed (1) it decays.

Scene: ``hydrostatic_tank(periodic_xy=True)`` 0.14 x 0.14 m, 0.08 m deep, dx = 0.02 m, the water
given u = 0.2 m/s, 384 steps (0.2 s: the fluid lattice slides two spacings over the wall lattice).
The walls' pressure forces on the sliding lattice oscillate with the lattice phase (period dx / u,
measured amplitude ~0.3 % of u), so the test compares the mean velocity over the first and the
second lattice period. Bounds: free slip changes it by less than 1e-3 u; the viscous bed
(artificial viscosity alpha = 0.02 next to the bed) slows it by more than 1e-2 u.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj

U = 0.2
DX = 0.02


@pytest.fixture(scope="module")
def scene():
    sc = rj.scenes.hydrostatic_tank(dx=DX, length=0.14, width=0.14, depth=0.08, periodic_xy=True)
    P = sc.state.particles
    v = jnp.where((P.kind == rj.Kind.FLUID)[:, None], jnp.asarray([U, 0.0, 0.0], P.v.dtype), P.v)
    return sc.replace(state=sc.state.replace(particles=P.replace(v=v)))


@pytest.fixture(scope="module")
def period_means(scene):
    cfg = scene.config
    per_period = int(round(DX / U / cfg.dt / cfg.rebuild_every))  # blocks per lattice period

    def mean_u(state, params):
        P = state.particles
        fluid = P.kind == rj.Kind.FLUID
        return jnp.sum(jnp.where(fluid, P.vol * P.v[:, 0], 0.0)) / jnp.sum(jnp.where(fluid, P.vol, 0.0))

    roll = jax.jit(rj.make_rollout(cfg, 2 * per_period, checkpoint=False, observe=mean_u))

    def run(wall_viscosity):
        fl = scene.params.fluid
        params = scene.params.replace(fluid=fl.replace(wall_viscosity=jnp.asarray(wall_viscosity, fl.h.dtype)))
        out, u = roll(rj.prime(scene.state, params, cfg), params)
        assert int(out.status) == 0, int(out.status)
        u = np.asarray(u) / U
        return float(u[:per_period].mean()), float(u[per_period:].mean()), u

    return run


def test_free_slip_bed_keeps_the_stream(period_means):
    first, second, u = period_means(0.0)
    print(f"free slip: mean u / U over lattice periods 1, 2: {first:.5f}, {second:.5f}; range {u.min():.5f}..{u.max():.5f}")
    assert abs(second - first) <= 1e-3
    assert np.all(np.abs(u - 1.0) <= 1e-2)


def test_viscous_bed_slows_the_stream(period_means):
    first, second, _ = period_means(1.0)
    print(f"viscous bed: mean u / U over lattice periods 1, 2: {first:.5f}, {second:.5f}")
    assert second < first - 1e-2
