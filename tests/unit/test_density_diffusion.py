"""delta-SPH density diffusion terms (``rockjax.sph.diffusion``), checked against closed forms.

* The renormalised density gradient (``wcsph.density_gradient``, Randles & Libersky 1996) is
  exact for a linear density field, at the free surface and next to walls too (its matrix C_i
  absorbs the truncated kernel); with its fade-out it stays exact wherever det C_i is above
  ``RENORMALISATION_DET_RANGE`` and is scaled down (to 0) below.
* Antuono et al. (2010)'s consistent diffusion subtracts the linear part of each pair's density
  difference, so a linear field gets no diffusion at all (Molteni & Colagrossi's uncorrected term
  does, near the surface and the walls: the test would see a wrong correction).
* Molteni's, Antuono's and Fourtakas et al. (2019)'s terms conserve the fluid volume: sum_i V_i D_i
  = 0 (antisymmetric pair terms; ``Fourtakas``'s hydrostatic difference, taken about the pair's
  mean density, is odd in the pair). ``FourtakasSurface``'s (Fourtakas et al.'s own, from the
  surface's density) is not odd in the pair separation (rho0 ((1 + a)^(1/gamma) - 1) has an even
  part ~ -rho0 (gamma - 1) a^2 / (2 gamma^2)), so its residual is that even part's sum, computed
  here in closed form from the pairs.
* A column at rest with the exact (Tait) hydrostatic densities gets almost no ``Fourtakas``
  diffusion (Molteni's term does, where the kernel is truncated; ``FourtakasSurface`` some, at
  the bottom, where its slope from the surface's density is off by the depth's compressibility).

Scene: a small 3D dam-break column (free surface on three sides, walls below and behind),
positions jittered by up to 0.1 dx (inside the Verlet skin of the scene's list), float64.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax.sph import wcsph
from rockjax.sph.diffusion import hydrostatic_density_difference
from rockjax.sph.neighbours import pairs
from rockjax.step import advance, prime, refresh

G = np.array([30.0, -12.0, -45.0])  # kg/m^4: a linear density field rho0 + G . x


@pytest.fixture(scope="module")
def column(x64):
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4)
    P = sc.state.particles
    rng = np.random.default_rng(7)
    fluid = np.asarray(P.kind) == rj.Kind.FLUID
    jitter = np.where(fluid[:, None], rng.uniform(-0.1, 0.1, P.x.shape) * 0.1, 0.0)
    state = refresh(sc.state.replace(particles=P.replace(x=jnp.asarray(np.asarray(P.x) + jitter))), sc.config)
    assert int(state.status) == 0
    P = state.particles
    return sc, P.replace(rho=jnp.asarray(1000.0 + np.asarray(P.x) @ G)), state.nbrs.idx


def _rate(sc, P, idx, diffusion, rho=None):
    config = sc.config.replace(scheme=sc.config.scheme.replace(diffusion=diffusion))
    rho = P.rho if rho is None else rho
    pr = pairs(P.x, P.kind, idx, config)
    return np.asarray(wcsph.density_rate(pr, jnp.zeros_like(P.v), rho, P.vol, P.kind, sc.params, config))


@pytest.fixture
def no_fade(monkeypatch):
    """The renormalised gradient without its fade-out at poorly conditioned rows (the pure algebra)."""
    monkeypatch.setattr(wcsph, "RENORMALISATION_DET_RANGE", (1e-12, 2e-12))


def _det_C(sc, P, idx):
    """det of the renormalisation matrix per fluid row, computed here in numpy."""
    config, f = sc.config, sc.params.fluid
    pr = pairs(P.x, P.kind, idx, config)
    t = wcsph.pair_terms(pr, P.kind, sc.params, config)
    fl = np.asarray(t.kind_j) == rj.Kind.FLUID
    w = np.where(fl, -float(f.rho0) * np.asarray(P.vol)[np.asarray(pr.idx)] / np.asarray(P.rho)[np.asarray(pr.idx)]
                 * np.asarray(t.F), 0.0)
    r = np.stack([np.asarray(pr.d[a]) for a in range(3)], axis=-1)  # [R, K, 3]
    return np.linalg.det(np.einsum("rk,rka,rkb->rab", w, r, r))


def test_renormalised_gradient_is_exact_for_a_linear_field(column, no_fade):
    sc, P, idx = column
    config = sc.config
    pr = pairs(P.x, P.kind, idx, config)
    g = np.asarray(wcsph.density_gradient(pr, P.rho, P.vol, P.kind, sc.params, config))[:config.n_fluid]
    np.testing.assert_allclose(g, np.broadcast_to(G, g.shape), rtol=1e-9, atol=1e-9 * np.abs(G).max())


def test_renormalised_gradient_fades_only_at_poorly_conditioned_rows(column):
    """With the default fade: exact where det C is above the range, zero below it, in between a
    fraction of the exact one (``RENORMALISATION_DET_RANGE``)."""
    sc, P, idx = column
    config = sc.config
    pr = pairs(P.x, P.kind, idx, config)
    g = np.asarray(wcsph.density_gradient(pr, P.rho, P.vol, P.kind, sc.params, config))[:config.n_fluid]
    det = _det_C(sc, P, idx)
    lo, hi = wcsph.RENORMALISATION_DET_RANGE
    full, none = det >= hi, det <= lo
    assert full.sum() > 0.5 * len(det) and none.sum() > 0  # the column's free corners are below the range
    np.testing.assert_allclose(g[full], np.broadcast_to(G, g[full].shape), rtol=1e-9, atol=1e-9 * np.abs(G).max())
    np.testing.assert_array_equal(g[none], 0.0)
    s = np.clip((det - lo) / (hi - lo), 0, 1)
    np.testing.assert_allclose(g, s[:, None] * G, rtol=1e-6, atol=1e-6 * np.abs(G).max())


def test_antuono_diffusion_leaves_a_linear_field_alone(column, no_fade):
    sc, P, idx = column
    nf = sc.config.n_fluid
    scale = 2 * sc.params.fluid.delta * sc.params.fluid.h * sc.params.fluid.c0 * np.abs(G).max() / (0.5 / 5)
    molteni = _rate(sc, P, idx, rj.sph.Molteni())[:nf]
    antuono = _rate(sc, P, idx, rj.sph.Antuono())[:nf]
    assert np.abs(molteni).max() > 1e-2 * float(scale), "the uncorrected term must see the truncated kernel"
    assert np.abs(antuono).max() <= 1e-9 * float(scale), np.abs(antuono).max()


@pytest.mark.parametrize("diffusion", [rj.sph.Molteni(), rj.sph.Fourtakas(), rj.sph.FourtakasSurface(),
                                       rj.sph.Antuono()], ids=lambda d: d.name)
def test_diffusion_conserves_mass(column, diffusion):
    sc, P, idx = column
    nf = sc.config.n_fluid
    rng = np.random.default_rng(3)
    fluid = np.asarray(P.kind) == rj.Kind.FLUID
    rho = jnp.asarray(np.where(fluid, 1000.0 + rng.normal(0.0, 2.0, fluid.shape), np.asarray(P.rho)))
    d = _rate(sc, P, idx, diffusion, rho=rho)[:nf]
    V = sc.params.fluid.rho0 * np.asarray(P.vol)[:nf] / np.asarray(rho)[:nf]
    assert np.abs(d).max() > 0
    expected = 0.0
    if diffusion == rj.sph.FourtakasSurface():
        config, f = sc.config, sc.params.fluid
        pr = pairs(P.x, P.kind, idx, config)
        t = wcsph.pair_terms(pr, P.kind, sc.params, config)
        g_dx = -sum(pr.d[a] * sc.params.gravity[a] for a in range(3))
        V_j = f.rho0 * jnp.take(P.vol, pr.idx) / jnp.take(rho, pr.idx)
        rho_h = hydrostatic_density_difference(g_dx, sc.params, config.scheme.gamma)
        term = jnp.where(t.kind_j == rj.Kind.FLUID, 2.0 * f.delta * f.h * f.c0 * V_j * rho_h * t.F, 0.0)
        expected = float(np.sum(V * np.asarray(jnp.sum(term, axis=1))))
        assert abs(expected) > 1e-6 * float(np.sum(V * np.abs(d)))  # the even part is really there
    assert abs(float(np.sum(V * d)) - expected) <= 1e-10 * float(np.sum(V * np.abs(d)))


def test_fourtakas_leaves_a_hydrostatic_column_alone(column):
    """Exact hydrostatic densities (Tait, compressible) on the (unjittered) column: the Fourtakas term
    (pair-mean hydrostatic difference, exact to third order in the pair's height difference) is
    below 1e-5 of Molteni's, which sees the truncated kernel at the surface and the walls (measured
    9.7e-7); Fourtakas et al.'s surface series (``FourtakasSurface``) leaves more than
    1e-2 at the bottom layer (measured 2.3e-2: its one-sided stencil sums the series' slope error,
    ~(gamma - 2) g depth / c0^2 of the hydrostatic difference)."""
    sc, _, _ = column
    config, f = sc.config, sc.params.fluid
    state = refresh(sc.state, config)
    P, idx = state.particles, state.nbrs.idx
    nf = config.n_fluid
    z = np.asarray(P.x)[:, 2]
    top = z[:nf].max() + 0.5 * (0.5 / 5)
    # the compressible hydrostatic column: dp/dz = -rho(p) g with Tait's rho(p), in closed form
    gm = config.scheme.gamma
    rho = jnp.asarray(float(f.rho0) * (1.0 + (gm - 1.0) * 9.81 * np.maximum(top - z, 0.0) / float(f.c0) ** 2)
                      ** (1.0 / (gm - 1.0)))
    terms = {"molteni": rj.sph.Molteni(), "fourtakas": rj.sph.Fourtakas(), "surface": rj.sph.FourtakasSurface()}
    rate = {k: np.abs(_rate(sc, P, idx, d, rho=rho)[:nf]) for k, d in terms.items()}
    molteni = rate["molteni"].max()
    fourtakas, surface = rate["fourtakas"], rate["surface"]
    print(f"max |D| / Molteni's: fourtakas {fourtakas.max() / molteni:.2e}, surface series {surface.max() / molteni:.2e}")
    assert molteni > 0.0
    assert fourtakas.max() <= 1e-5 * molteni, (fourtakas.max(), molteni)
    bottom = z[:nf] < z[:nf].min() + 1e-9
    assert surface[bottom].max() > 1e-2 * molteni, (surface[bottom].max(), molteni)


def test_antuono_gradient_matches_finite_differences(x64):
    """grad of a few ANTUONO steps w.r.t. the diffusion coefficient delta (and c0) against central
    finite differences, float64: the renormalisation's safe inverse keeps the gradient finite and exact."""
    sc = rj.scenes.dam_break(dx=0.5 / 5, column_height=0.5, tank_length=1.0, tank_width=0.5, column_width=0.4,
                             scheme=rj.WCSPH(diffusion=rj.sph.Antuono()))
    config = sc.config
    state = jax.jit(lambda s, p: prime(s, p, config))(sc.state, sc.params)
    assert state.particles.grad_rho is not None

    def loss(delta, c0):
        p = sc.params.replace(fluid=sc.params.fluid.replace(delta=delta, c0=c0))
        s = jax.lax.fori_loop(0, 6, lambda _, s: advance(s, p, config), state)
        nf = config.n_fluid
        return jnp.sum(s.particles.rho[:nf] ** 2) * 1e-6 + jnp.sum(s.particles.x[:nf, 0] ** 2)

    d0, c0 = sc.params.fluid.delta, sc.params.fluid.c0
    g = jax.jit(jax.grad(loss, argnums=(0, 1)))(d0, c0)
    f = jax.jit(loss)
    for k, (x0, gk) in enumerate(zip((d0, c0), g)):
        eps = 1e-4 * float(x0)
        args_p = [d0, c0]
        args_m = [d0, c0]
        args_p[k] = x0 + eps
        args_m[k] = x0 - eps
        fd = (float(f(*args_p)) - float(f(*args_m))) / (2 * eps)
        assert np.isfinite(float(gk)) and abs(fd) > 0
        assert abs(float(gk) - fd) <= 1e-4 * abs(fd), (k, float(gk), fd)
