"""Particle shifting (``sph.shifting``): what the displacement does on a lattice, off it, at a free
surface and for a drop, and that a scheme without it runs the same program as before."""

import pathlib

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.sph.shifting import bulk_divergence
from rockjax.step import refresh
from rockjax.types import Kind

DX = 0.05


@pytest.fixture(scope="module")
def tank():
    """A periodic layer of water 6 layers deep on its lattice at uniform density (Wendland C2,
    h = 1.5 dx), its list built, every particle moving at 0.2 m/s along x (the shift scales with the
    speed)."""
    scheme = rj.WCSPH(shifting=rj.sph.Fickian())
    sc = rj.scenes.hydrostatic_tank(dx=DX, length=0.5, width=0.3, depth=6 * DX, periodic_xy=True, scheme=scheme)
    st = refresh(sc.state, sc.config)
    P = st.particles
    fluid = np.asarray(P.kind) == int(Kind.FLUID)
    v = np.zeros(P.x.shape, np.float32)
    v[fluid, 0] = 0.2
    st = st.replace(particles=P.replace(v=jnp.asarray(v), rho=jnp.full_like(P.rho, float(sc.params.fluid.rho0))))
    return sc, st


def test_volumes_follow_the_density():
    """The concentration counts ``m / rho`` volumes: a lattice carrying the hydrostatic densities of a
    soft fluid (1.4 % denser at the bed) is, by those densities, too loose at depth, and its deep rows
    are shifted down, towards the spacing the densities give (with the lattice's volumes nothing
    would move, and a settled, compressed column would be pushed up instead)."""
    scheme = rj.WCSPH(shifting=rj.sph.Fickian())
    sc = rj.scenes.hydrostatic_tank(dx=DX, length=0.5, width=0.3, depth=12 * DX, periodic_xy=True, scheme=scheme,
                                    c0=20.0)
    st = refresh(sc.state, sc.config)
    P = st.particles
    fl = np.asarray(P.kind) == int(Kind.FLUID)
    assert np.asarray(P.rho)[fl].max() / float(sc.params.fluid.rho0) > 1.005
    v = np.where(fl[:, None], [0.2, 0.0, 0.0], 0.0)
    st = st.replace(particles=P.replace(v=jnp.asarray(v, P.x.dtype)))
    dr = _shift(sc, st)
    z = np.asarray(st.particles.x)[:, 2]
    inner = fl & (z > 1.4 * DX) & (z < 5.0 * DX)  # off the bed's rows and the surface's band
    assert dr[inner, 2].max() < 0.0
    assert np.abs(dr[inner, :2]).max() < 1e-3 * np.abs(dr[inner, 2]).min()


def _shift(sc, st, x=None):
    P = st.particles if x is None else st.particles.replace(x=x)
    return np.asarray(sc.config.scheme.shifting.displacement(P, st.nbrs, sc.params, sc.config))


def test_bulk_divergence_is_three():
    for kernel, hf in ((rj.sph.WendlandC2(), 1.5), (rj.sph.WendlandC2(), 2.0), (rj.sph.CubicSpline(), 1.0)):
        assert abs(bulk_divergence(kernel, hf) - 3.0) < 0.07


def test_lattice_is_not_shifted_and_displaced_particle_goes_back(tank):
    sc, st = tank
    x = np.asarray(st.particles.x)
    dr = _shift(sc, st)
    assert np.max(np.linalg.norm(dr, axis=1)) < 1e-6 * DX  # a lattice is in balance (symmetry)
    fluid = np.flatnonzero(np.asarray(st.particles.kind) == int(Kind.FLUID))
    mid = fluid[np.argmin(np.abs(x[fluid, 2] - 2.5 * DX) + np.abs(x[fluid, 0] - 0.25) + np.abs(x[fluid, 1] - 0.15))]
    x2 = x.copy()
    x2[mid] += np.array([0.2 * DX, 0.1 * DX, 0.0])
    dr = _shift(sc, st, jnp.asarray(x2))
    back = dr[mid] / np.linalg.norm(dr[mid])
    assert back[0] < -0.8 and back[1] < 0.0  # towards its lattice site, mostly along the larger offset
    # the size: A h |v| dt |grad C|, a small fraction of dx per step
    assert 1e-6 * DX < np.linalg.norm(dr[mid]) < 0.05 * DX


def test_free_surface_shift_is_tangential_and_drop_is_not_shifted(tank):
    sc, st = tank
    x = np.asarray(st.particles.x)
    kind = np.asarray(st.particles.kind)
    fluid = np.flatnonzero(kind == int(Kind.FLUID))
    top = fluid[x[fluid, 2] > x[fluid, 2].max() - 0.5 * DX]
    rng = np.random.default_rng(0)
    x2 = x.copy()
    x2[top, :2] += rng.uniform(-0.15, 0.15, (len(top), 2)) * DX  # a disordered top layer
    dr = _shift(sc, st, jnp.asarray(x2))
    assert np.max(np.linalg.norm(dr[top, :2], axis=1)) > 1e-5 * DX  # it is being evened out ...
    # ... along the surface: without the surface treatment the top layer is pushed up into the void
    bulk_only = sc.config.replace(scheme=sc.config.scheme.replace(shifting=rj.sph.Fickian(surface=0.0, splash=0.0)))
    up = np.asarray(bulk_only.scheme.shifting.displacement(st.particles.replace(x=jnp.asarray(x2)), st.nbrs, sc.params,
                                                           bulk_only))[top, 2].mean()
    assert up > 1e-4 * DX
    assert abs(dr[top, 2].mean()) < 0.05 * up
    # a drop: one top particle lifted 1.6 h above the water keeps its place
    drop = top[len(top) // 2]
    x3 = x.copy()
    x3[drop, 2] += 1.6 * float(sc.params.fluid.h)
    assert np.all(_shift(sc, st, jnp.asarray(x3))[drop] == 0.0)


@pytest.mark.parametrize("scheme", ["wcsph", "dfsph"])
def test_shift_joins_the_drift(tank, scheme):
    """One step with and without shifting from a disordered state: the positions differ by the
    displacement exactly (the velocities and densities are the step's own)."""
    sc, st = tank
    if scheme == "dfsph":
        dfsph = rj.DFSPH(kernel=rj.sph.WendlandC2(), relaxation=0.2, shifting=rj.sph.Fickian())
        sc = sc.replace(config=sc.config.replace(scheme=dfsph))
    x = np.asarray(st.particles.x).copy()
    fluid = np.asarray(st.particles.kind) == int(Kind.FLUID)
    x[fluid] += np.random.default_rng(1).uniform(-0.05, 0.05, (int(fluid.sum()), 3)) * DX
    st = st.replace(particles=st.particles.replace(x=jnp.asarray(x)))
    st = rj.step.prime(st, sc.params, sc.config)  # (sorts the particles by cell)
    dr = _shift(sc, st)
    plain = sc.config.replace(scheme=sc.config.scheme.replace(shifting=rj.sph.NoShifting()))
    a = jax.jit(rj.step.advance, static_argnums=2)(st, sc.params, sc.config)
    b = jax.jit(rj.step.advance, static_argnums=2)(st, sc.params, plain)
    diff = np.asarray(a.particles.x) - np.asarray(b.particles.x)
    assert np.max(np.abs(diff - dr)) < 1e-6 * DX
    assert np.max(np.abs(dr)) > 1e-5 * DX


def test_bad_shifting_values_and_names():
    with pytest.raises(ValueError, match="surface"):
        rj.sph.Fickian(surface=1.2)
    with pytest.raises(ValueError, match="shifting"):
        rj.WCSPH(shifting="fickian")
    with pytest.raises(ValueError, match="fickian"):
        rj.sph.by_name("shifting", "fick")
    assert rj.sph.from_names("dfsph", shifting="fickian").shifting == rj.sph.Fickian()


def test_scene_file_names_the_shifting():
    text = (pathlib.Path(__file__).parents[2] / "examples" / "wave_box.toml").read_text().replace('diffusion = "fourtakas" }',
                                                        'diffusion = "fourtakas", shifting = "fickian" }')
    scene = rj.scenes.scenefile.load_scene(text)
    assert scene.config.scheme.shifting == rj.sph.Fickian()
    with pytest.raises(ValueError, match="shifting"):
        rj.scenes.scenefile.load_scene(text.replace('shifting = "fickian"', 'shifting = "fick"'))
