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
