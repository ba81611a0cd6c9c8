"""The contact laws alone (``rockjax.blocks.laws``) against closed forms: no geometry, no step."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rockjax.blocks import BlockParams, ContactLaw, ContactPoint, PenaltyCoulomb, box, make_blocks
from rockjax.blocks.laws import LawResult

KN, KS, ZETA, PHI, COH = 1e6, 4e5, 0.2, math.radians(30.0), 0.0
M_RED = 50.0  # kg
N = np.array([0.0, 0.0, 1.0])  # from i to j
DT = 1e-4


def params(**kw):
    vals = dict(density=2650.0, friction_angle=PHI, cohesion=COH, tensile_strength=0.0, normal_stiffness=KN,
                shear_stiffness=KS, damping_ratio=ZETA, stroke=0.0, period=1.0, joint_water_level=0.0,
                joint_water_density=1000.0)
    vals.update(kw)
    return BlockParams(**{k: jnp.asarray(v, jnp.float64) for k, v in vals.items()})


def point(depth, velocity=(0.0, 0.0, 0.0), n_points=1.0):
    return ContactPoint(depth=jnp.asarray(depth, jnp.float64), normal=jnp.asarray(N), velocity=jnp.asarray(velocity),
                        reduced_mass=jnp.asarray(M_RED), pair_points=jnp.asarray(n_points))


def law(p, history=(0.0, 0.0, 0.0), **kw):
    return PenaltyCoulomb()(p, jnp.asarray(history, jnp.float64), params(**kw), DT)


def test_normal_spring_at_rest(x64):
    r = law(point(2e-4))
    assert isinstance(r, LawResult)
    np.testing.assert_allclose(float(r.normal_force), KN * 2e-4, rtol=1e-15)
    assert not np.any(np.asarray(r.tangential_force)) and not np.any(np.asarray(r.history))


@pytest.mark.parametrize("n_points", [1.0, 4.0])
def test_damping_acts_only_while_closing(x64, n_points):
    d, v = 2e-4, 0.05
    cn = 2 * ZETA * math.sqrt(KN * M_RED / n_points)
    closing = law(point(d, (0.0, 0.0, -v), n_points))  # j moves towards i
    np.testing.assert_allclose(float(closing.normal_force), KN * d + cn * v, rtol=1e-14)
    opening = law(point(d, (0.0, 0.0, 5.0), n_points))  # fast opening: the spring alone, never a pull
    np.testing.assert_allclose(float(opening.normal_force), KN * d, rtol=1e-15)
    assert float(opening.normal_force) > 0


def test_stick_below_the_cap(x64):
    # a shear spring stretched by u0 along x; no tangential velocity: f_t = -k_s u0, kept
    d, u0 = 1e-3, 1e-4
    r = law(point(d), history=(u0, 0.0, 0.0))
    assert KS * u0 < KN * d * math.tan(PHI)  # below the cap
    np.testing.assert_allclose(np.asarray(r.tangential_force), [-KS * u0, 0.0, 0.0], rtol=1e-15, atol=0)
    np.testing.assert_allclose(np.asarray(r.history), [u0, 0.0, 0.0], rtol=1e-15, atol=0)


def test_history_is_projected_on_the_plane_and_advanced(x64):
    # a normal component of the stored spring is dropped; the tangential velocity adds v_t dt;
    # the dashpot adds -c_t v_t while sticking
    d, u0, vt = 1e-3, 1e-5, 0.01
    r = law(point(d, (vt, 0.0, 0.0)), history=(u0, 0.0, 3e-5))
    ct = 2 * ZETA * math.sqrt(KS * M_RED)
    u = u0 + vt * DT
    np.testing.assert_allclose(np.asarray(r.history), [u, 0.0, 0.0], rtol=1e-14, atol=1e-20)
    np.testing.assert_allclose(np.asarray(r.tangential_force), [-KS * u - ct * vt, 0.0, 0.0], rtol=1e-14, atol=1e-12)


@pytest.mark.parametrize("cohesion", [0.0, 30.0])
def test_slip_at_the_cap(x64, cohesion):
    # stretched well past the cap along (1, 1, 0)/sqrt2: the force sits on the cap, opposite to the
    # stretch, and the spring is reset to the cap's stretch (no dashpot: no velocity here)
    d, u0 = 1e-4, 1e-3
    e = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    r = law(point(d), history=tuple(u0 * e), cohesion=cohesion)
    cap = KN * d * math.tan(PHI) + cohesion
    assert KS * u0 > cap
    np.testing.assert_allclose(np.asarray(r.tangential_force), -cap * e, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(np.asarray(r.history), cap / KS * e, rtol=1e-14, atol=1e-18)
    np.testing.assert_allclose(float(r.normal_force), KN * d, rtol=1e-15)


def test_broadcasts_over_pairs_and_slots_and_differentiates(x64):
    # [S=2, L=3] points with per-pair fields [S, 1], as contact_forces calls it
    depth = jnp.asarray([[1e-4, 2e-4, 3e-4], [4e-4, 5e-4, 6e-4]])
    p = ContactPoint(depth=depth, normal=jnp.broadcast_to(jnp.asarray(N), (2, 1, 3)),
                     velocity=jnp.zeros((2, 3, 3)), reduced_mass=jnp.asarray([[M_RED], [2 * M_RED]]),
                     pair_points=jnp.asarray([[3.0], [3.0]]))
    r = PenaltyCoulomb()(p, jnp.zeros((2, 3, 3)), params(), DT)
    assert r.normal_force.shape == (2, 3) and r.tangential_force.shape == r.history.shape == (2, 3, 3)
    np.testing.assert_allclose(np.asarray(r.normal_force), KN * np.asarray(depth), rtol=1e-15)
    # d f_t / d phi on the cap is -k_n d / cos^2(phi) along the stretch
    g = jax.grad(lambda phi: law(point(1e-4), history=(1e-3, 0.0, 0.0), friction_angle=phi).tangential_force[0])(
        jnp.asarray(PHI))
    np.testing.assert_allclose(float(g), -KN * 1e-4 / math.cos(PHI) ** 2, rtol=1e-12)


def test_the_law_is_a_static_choice_on_the_config():
    cfg, _, _ = make_blocks([box(1.0, 1.0, 1.0), box(1.0, 1.0, 1.0)], positions=[[0, 0, 0], [0, 0, 1.0]])
    assert cfg.law == PenaltyCoulomb() and hash(cfg) == hash(dataclasses.replace(cfg, law=PenaltyCoulomb()))
    assert isinstance(cfg.law, ContactLaw)

    @dataclasses.dataclass(frozen=True)
    class Frictionless(PenaltyCoulomb):
        def __call__(self, point, history, params, dt):
            return super().__call__(point, history, params.replace(friction_angle=0.0 * params.friction_angle), dt)

    other = dataclasses.replace(cfg, law=Frictionless())
    assert other != cfg and other.law == Frictionless()
    assert make_blocks([box(1.0, 1.0, 1.0)], law=Frictionless())[0].law == Frictionless()
    with pytest.raises(ValueError, match="ContactLaw"):
        dataclasses.replace(cfg, law="penalty")
    with pytest.raises(ValueError, match="ContactLaw"):
        make_blocks([box(1.0, 1.0, 1.0)], law=object())
