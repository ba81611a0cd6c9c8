"""The viscous terms as objects (``rockjax.sph.viscosity``): the SPS stress of ``LaminarSPS`` in a
uniform shear flow against its closed form, and the terms' construction and lookup by name.

Closed form (Dalrymple & Rogers 2006): for ``v = (gamma z, 0, 0)`` the strain rate has
``S_xz = gamma / 2`` only, ``|S| = sqrt(2 S:S) = gamma``, the eddy viscosity ``nu_t = (C_s dx)^2 gamma``
and the stress per unit mass ``tau_xz / rho = nu_t gamma``,
``tau_xx / rho = tau_yy / rho = tau_zz / rho = -(2/3) C_I dx^2 gamma^2`` (no divergence), the
others zero. Checked at the centre particle of a block of water 10 spacings wide at h = 1.5 dx
(full kernel support), where the SPH velocity gradient's lattice moment is 1.0006 of the continuum's.
"""

import jax
import numpy as np
import pytest

import rockjax as rj
from rockjax.scenes.base import fluid_scene, lattice
from rockjax.step import refresh

GAMMA = 2.0  # shear rate [1/s]
DX = 0.01


def _block(viscosity):
    fluid = lattice([0.0, 0.0, 0.0], [10 * DX, 10 * DX, 10 * DX], DX)
    return fluid_scene(name="shear", dx=DX, fluid_x=fluid, wall_x=np.zeros((0, 3)), domain_lo=[-DX, -DX, -DX],
                       domain_hi=[11 * DX, 11 * DX, 11 * DX], periodic=(False, False, False), surface_z=None, c0=10.0,
                       scheme=rj.WCSPH(viscosity=viscosity), h_factor=1.5, alpha=0.0, nu=1e-6, delta=0.1,
                       skin_factor=0.3, rebuild_every=8, cfl=0.25, meta={})


def test_sps_stress_of_a_uniform_shear_flow(x64):
    term = rj.sph.LaminarSPS(smagorinsky=0.12, blin=0.0066)
    scene = _block(term)
    state = refresh(scene.state, scene.config)
    P = state.particles
    v = np.zeros(P.x.shape)
    v[:, 0] = GAMMA * np.asarray(P.x)[:, 2]
    tau = jax.jit(lambda x, v, rho, vol, kind, nbrs: term.values(x, v, rho, vol, kind, nbrs, scene.params,
                                                                  scene.config))(P.x, v, P.rho, P.vol, P.kind, state.nbrs)
    centre = int(np.argmin(np.linalg.norm(np.asarray(P.x) - 5 * DX, axis=1) + 1e9 * (np.asarray(P.kind) != 0)))
    rho = float(P.rho[centre])
    got = {k: float(tau[k][centre]) * rho for k in tau}  # the term stores (tau / rho) / rho
    nu_t = (term.smagorinsky * DX) ** 2 * GAMMA
    iso = -(2.0 / 3.0) * term.blin * DX**2 * GAMMA**2
    expected = {"tau_xx": iso, "tau_yy": iso, "tau_zz": iso, "tau_xy": 0.0, "tau_xz": nu_t * GAMMA, "tau_yz": 0.0}
    scale = nu_t * GAMMA
    for k, e in expected.items():
        assert abs(got[k] - e) <= 0.01 * scale, (k, got[k], e)


def test_terms_by_name_and_refusals():
    assert rj.sph.by_name("viscosity", "sps") == rj.sph.LaminarSPS()
    assert rj.sph.from_names("wcsph", viscosity="laminar", diffusion="antuono") == rj.WCSPH(
        viscosity=rj.sph.Laminar(), diffusion=rj.sph.Antuono())
    assert {"artificial", "laminar", "sps"} <= set(rj.sph.names("viscosity"))
    with pytest.raises(ValueError, match="unknown viscosity 'turbulent'.*artificial"):
        rj.sph.by_name("viscosity", "turbulent")
    with pytest.raises(ValueError, match="viscosity must be a Viscosity object"):
        rj.WCSPH(viscosity="laminar")
    with pytest.raises(ValueError, match="smagorinsky and blin must be >= 0"):
        rj.sph.LaminarSPS(smagorinsky=-0.1)
    with pytest.raises(ValueError, match="diffusion = 'antuono' does not apply to scheme 'seed'"):
        rj.sph.from_names("seed", diffusion="antuono")
    with pytest.raises(ValueError, match="SeedScheme: walls=.*no_slip=True"):
        rj.SeedScheme(walls=rj.sph.Adami(no_slip=True))
    with pytest.raises(ValueError, match="Config.scheme must be a fluid scheme object"):
        _block(rj.sph.Laminar()).config.replace(scheme="wcsph")


def test_viscous_dt_limit_follows_the_term():
    """Terms with ``nu`` (laminar, SPS) bring the viscous limit 0.125 h^2 / nu into the host time step."""
    scene = _block(rj.sph.Artificial())
    p = scene.params.replace(fluid=scene.params.fluid.replace(nu=np.asarray(1.0, scene.params.fluid.nu.dtype)))
    h = float(p.fluid.h)
    assert rj.WCSPH().stable_dt(p, cfl=0.25) > 0.125 * h * h / 1.0
    for v in (rj.sph.Laminar(), rj.sph.LaminarSPS()):
        assert rj.WCSPH(viscosity=v).stable_dt(p, cfl=0.25) == pytest.approx(0.125 * h * h / 1.0)


def _sharp_pi(mu, c0=10.0, alpha=0.1, rho=1000.0):
    return np.where(mu < 0, -2.0 * alpha * c0 * mu / (2 * rho), 0.0)


def test_artificial_approach_band_closed_form(x64):
    """``Artificial(approach_band=b)``: Monaghan's Pi exactly beyond |mu| >= b c0, half of it at
    mu = 0, continuous with a continuous slope across the band's edges (the sharp switch's slope
    jumps from the approaching value to 0 at mu = 0)."""
    import jax.numpy as jnp

    c0, alpha, rho, h = 10.0, 0.1, 1000.0, 0.013
    params = rj.scenes.dam_break(dx=0.1, column_length=0.4, column_width=0.4, column_height=0.4,
                                 tank_length=0.8, tank_width=0.4).params
    params = params.replace(fluid=params.fluid.replace(c0=c0, alpha=alpha, h=h, rho0=rho))
    band = 0.01

    def pi_of(term, mu):
        # a pair along x at r = h: vr = v r, mu = h vr / (r^2 + 0.01 h^2)
        r = h
        vr = mu * (r * r + 0.01 * h * h) / h
        v = vr / r
        q, _, _ = term.pair(1.0, jnp.asarray(rho), jnp.asarray(rho), (jnp.asarray(v), 0.0, 0.0), (jnp.asarray(r), 0.0, 0.0),
                            jnp.asarray(r * r), None, jnp.asarray(True), params, {}, {})
        return float(q)

    smooth, sharp = rj.sph.Artificial(approach_band=band), rj.sph.Artificial()
    w = band * c0
    for mu in (-3 * w, -1.0001 * w, 1.0001 * w, 2 * w):  # beyond the band: Monaghan's
        assert pi_of(smooth, mu) == pytest.approx(float(_sharp_pi(mu, c0, alpha, rho)), rel=1e-12, abs=1e-15)
        assert pi_of(sharp, mu) == pytest.approx(float(_sharp_pi(mu, c0, alpha, rho)), rel=1e-12, abs=1e-15)
    slope = -2.0 * alpha * c0 / (2 * rho)  # dPi/dmu of an approaching pair
    # inside: Pi = S(u) slope mu, u = (1 - mu / w) / 2, S the cubic smoothstep
    for mu in (-0.5 * w, 0.0, 0.3 * w):
        u = 0.5 - 0.5 * mu / w
        assert pi_of(smooth, mu) == pytest.approx(u * u * (3 - 2 * u) * slope * mu, rel=1e-12, abs=1e-18)
    # the slope: continuous at the edges and at 0 (half the approaching slope there)
    e = 1e-6 * w
    d = lambda term, m: (pi_of(term, m + e) - pi_of(term, m - e)) / (2 * e)  # noqa: E731
    assert d(smooth, 0.0) == pytest.approx(0.5 * slope, rel=1e-6)
    assert d(smooth, -w) == pytest.approx(slope, rel=1e-4)
    assert abs(d(smooth, w)) < 1e-4 * abs(slope)
    left, right = (pi_of(sharp, 0.0) - pi_of(sharp, -e)) / e, (pi_of(sharp, e) - pi_of(sharp, 0.0)) / e
    assert left == pytest.approx(slope, rel=1e-9) and right == 0.0  # the kink the band removes


def test_adami_floor_band_closed_form(x64):
    """``smooth_max0(x, w)`` (``Adami(floor_band=w)``): max(x, 0) exactly beyond |x| >= w, 3 w / 16
    at 0, slope 1/2 at 0, value and slope continuous at the band's edges; w = 0 is the sharp max."""
    import jax
    import jax.numpy as jnp

    from rockjax.sph.walls import smooth_max0

    w = 50.0
    f = lambda x: float(smooth_max0(jnp.asarray(x), w))  # noqa: E731
    df = lambda x: float(jax.grad(lambda y: smooth_max0(y, w))(jnp.asarray(x)))  # noqa: E731
    for x in (-200.0, -w, w, 70.0):
        assert f(x) == max(x, 0.0)
    assert f(0.0) == pytest.approx(3 * w / 16, rel=1e-14)
    assert df(0.0) == pytest.approx(0.5, rel=1e-14)
    assert df(w * (1 - 1e-9)) == pytest.approx(1.0, abs=1e-8) and df(-w * (1 - 1e-9)) == pytest.approx(0.0, abs=1e-8)
    assert f(w * (1 - 1e-9)) == pytest.approx(w, rel=1e-8)
    xs = np.linspace(-2 * w, 2 * w, 801)
    vals = np.array([f(x) for x in xs])
    assert np.all(np.diff(vals) >= 0) and np.all(vals >= np.maximum(xs, 0.0) - 1e-12)  # monotone, above the floor
    assert float(smooth_max0(jnp.asarray(-3.0), 0.0)) == 0.0 and float(smooth_max0(jnp.asarray(3.0), 0.0)) == 3.0
