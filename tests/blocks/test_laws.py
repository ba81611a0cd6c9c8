"""The contact laws alone (``rockjax.blocks.laws``) against closed forms: no geometry, no step."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rockjax.blocks import BlockParams, ContactLaw, ContactPoint, PenaltyCoulomb, box, make_blocks
from rockjax.blocks.laws import CLOSING_FLOOR, LawResult, SmoothPenaltyCoulomb, onset_factor, smooth_ramp, smoothstep

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


def law(p, history=(0.0, 0.0, 0.0), resolve_step=True, **kw):
    return PenaltyCoulomb(resolve_step=resolve_step)(p, jnp.asarray(history, jnp.float64), params(**kw), DT)


def resolved_closing(w, spring, n_points, cn):
    """The closing speed [m/s] the resolved dashpot sees (``PenaltyCoulomb`` doc): the mid-step
    speed w less half a step of the pair's deceleration by its springs, at least CLOSING_FLOOR w,
    over 1 + zeta omega dt."""
    decel = 0.5 * DT * n_points * spring / M_RED
    return max(w - decel, CLOSING_FLOOR * w) / (1.0 + 0.5 * DT * n_points * cn / M_RED)


def test_normal_spring_at_rest(x64):
    r = law(point(2e-4))
    assert isinstance(r, LawResult)
    np.testing.assert_allclose(float(r.normal_force), KN * 2e-4, rtol=1e-15)
    assert not np.any(np.asarray(r.tangential_force)) and not np.any(np.asarray(r.history))


@pytest.mark.parametrize("resolve_step", [False, True], ids=["plain", "resolved"])
@pytest.mark.parametrize("n_points", [1.0, 4.0])
def test_damping_acts_only_while_closing(x64, n_points, resolve_step):
    d, v = 2e-4, 0.05  # deeper than a step closes (v DT = 5 um): not the contact's first step
    cn = 2 * ZETA * math.sqrt(KN * M_RED / n_points)
    closing = law(point(d, (0.0, 0.0, -v), n_points), resolve_step=resolve_step)  # j moves towards i
    w = resolved_closing(v, KN * d, n_points, cn) if resolve_step else v
    np.testing.assert_allclose(float(closing.normal_force), KN * d + cn * w, rtol=1e-14)
    if resolve_step:  # the springs' half-step deceleration, 0.4 % (n = 1) / 1.6 % (4) of v, and 1 + zeta omega dt
        assert 0.97 * v < w < 0.995 * v
    opening = law(point(d, (0.0, 0.0, 5.0), n_points), resolve_step=resolve_step)  # the spring alone, never a pull
    np.testing.assert_allclose(float(opening.normal_force), KN * d, rtol=1e-15)
    assert float(opening.normal_force) > 0


@pytest.mark.parametrize("phase", [0.01, 0.3, 0.5, 0.8, 0.999])
def test_first_step_carries_the_impulse_since_the_onset(x64, phase):
    # a point closing at v that is delta = phase v DT deep began at t_n - delta / v; up to
    # t_n + DT/2 the spring's impulse is k (delta + v DT/2)^2 / (2 v) and the dashpot's c v_c (delta / v + DT/2)
    v = 0.5
    d = phase * v * DT
    cn = 2 * ZETA * math.sqrt(KN * M_RED)
    r = law(point(d, (0.0, 0.0, -v)))
    wc = resolved_closing(v, KN * d, 1.0, cn)
    t_in = d / v + DT / 2
    np.testing.assert_allclose(float(r.normal_force) * DT, KN * v * t_in**2 / 2 + cn * wc * t_in, rtol=1e-13)
    plain = law(point(d, (0.0, 0.0, -v)), resolve_step=False)
    np.testing.assert_allclose(float(plain.normal_force), KN * d + cn * v, rtol=1e-14)
    # one step later the point is an old one: the plain spring and the centred dashpot
    later = law(point(d + v * DT, (0.0, 0.0, -v)))
    np.testing.assert_allclose(float(later.normal_force),
                               KN * (d + v * DT) + cn * resolved_closing(v, KN * (d + v * DT), 1.0, cn), rtol=1e-14)


def test_onset_factor_carries_the_missed_impulse_continuously(x64):
    # f(s) + f(s + 1) = s + 3/2 for the onset at a phase s of the step before; C1; 0 at the onset, 1 from 2 steps
    s = jnp.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(np.asarray(onset_factor(s) + onset_factor(s + 1.0)), np.asarray(s) + 1.5, atol=1e-14)
    np.testing.assert_allclose(np.asarray(onset_factor(jnp.asarray([-1.0, 0.0, 1.0, 2.0, 5.0]))),
                               [0.0, 0.0, 1.5, 1.0, 1.0], atol=1e-15)
    for x0 in (0.0, 1.0, 2.0):
        g = [float(jax.grad(onset_factor)(jnp.asarray(x0 + e))) for e in (-1e-9, 1e-9)]
        np.testing.assert_allclose(g[0], g[1], atol=1e-7)


@pytest.mark.parametrize("smooth_law", [False, True], ids=["sharp", "smooth"])
def test_resolved_law_gradients_are_finite(x64, smooth_law):
    # at the switches of the resolved dashpot (onset, first step, floor, no closing) the gradients
    # in the depth and the normal velocity are finite
    f = (lambda p: SMOOTH(p, jnp.zeros(3), params(), DT)) if smooth_law else (lambda p: law(p))
    v = 0.5
    for d, vz in ((1e-12, -v), (v * DT, -v), (0.5 * v * DT, -v), (2e-4, 0.0), (2e-4, -1e-30), (2e-4, 3.0),
                  (1e-3, -1e-4), (DS, -DS / DT), (1e-7, -1e-7)):
        g = jax.grad(lambda dv: f(point(dv[0], (0.0, 0.0, dv[1]))).normal_force)(jnp.asarray([d, vz]))
        assert np.all(np.isfinite(np.asarray(g))), (d, vz, g)


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


# --------------------------------------------------------------------------------------------
# SmoothPenaltyCoulomb: the sharp law outside its bands, continuous across them
# --------------------------------------------------------------------------------------------

DS, VS, BAND = 1e-5, 1e-3, 0.05
SMOOTH = SmoothPenaltyCoulomb(onset_depth=DS, closing_speed=VS, slip_band=BAND)


def smooth(p, history=(0.0, 0.0, 0.0), resolve_step=True, **kw):
    lw = SMOOTH if resolve_step else dataclasses.replace(SMOOTH, resolve_step=False)
    return lw(p, jnp.asarray(history, jnp.float64), params(**kw), DT)


def corner(n_points=1.0, resolve_step=True):
    """The smooth law's dashpot force [N] at v_n = 0 and depth >= d_s: its closing switch's
    rounded corner, ``c_n VS / 4``; resolved, CLOSING_FLOOR of it over 1 + zeta omega dt (at the
    depths used here, >= 45 um, the springs' half-step deceleration is beyond VS / 4, so the floor
    holds exactly: the rounded floor's band ends at 0.15 of it)."""
    cn = 2 * ZETA * math.sqrt(KN * M_RED / n_points)
    if not resolve_step:
        return cn * VS / 4
    return cn * CLOSING_FLOOR * VS / 4 / (1.0 + 0.5 * DT * n_points * cn / M_RED)


def test_smooth_ramp_and_smoothstep_closed_forms(x64):
    x = jnp.linspace(-2.0, 2.0, 41)
    r = np.asarray(smooth_ramp(x, 0.5))
    xn = np.asarray(x)
    np.testing.assert_allclose(r, np.where(xn >= 0.5, xn, np.where(xn <= -0.5, 0.0, (xn + 0.5) ** 2 / 2.0)), rtol=1e-15)
    np.testing.assert_array_equal(np.asarray(smooth_ramp(x, 0.0)), np.maximum(xn, 0.0))
    # C1 at both band edges: the one-sided slopes agree
    for x0, slope in ((-0.5, 0.0), (0.5, 1.0)):
        g = [float(jax.grad(lambda t: smooth_ramp(t, 0.5))(jnp.asarray(x0 + s))) for s in (-1e-9, 1e-9)]
        np.testing.assert_allclose(g, slope, atol=1e-8)
    t = jnp.asarray([0.0, 0.25, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(np.asarray(smoothstep(t)), [0.0, 0.15625, 0.5, 1.0, 1.0], rtol=1e-15)
    assert float(jax.grad(lambda a: smooth_ramp(a, 0.0))(jnp.asarray(0.5))) == 1.0  # no NaN at width 0


@pytest.mark.parametrize("resolve_step", [False, True], ids=["plain", "resolved"])
@pytest.mark.parametrize("vz", [-0.05, 0.0, 5.0])
def test_smooth_law_is_the_sharp_law_beyond_its_bands(x64, vz, resolve_step):
    # deep (depth >= d_s, shifted by d_s/2), closing or opening faster than VS (or at rest), and a
    # tangential state far below / far above the cap: equal to PenaltyCoulomb to round-off
    d = 2e-4
    for hist, vt in (((1e-5, 0.0, 0.0), 0.0), ((1e-3, 2e-4, 0.0), 0.02)):
        vel = (vt, 0.0, vz)
        sharp = law(point(d, vel, 2.0), history=hist, resolve_step=resolve_step)
        soft = smooth(point(d + 0.5 * DS, vel, 2.0), history=hist, resolve_step=resolve_step)
        if vz == 0.0:
            np.testing.assert_allclose(float(soft.normal_force), float(sharp.normal_force)
                                       + corner(2.0, resolve_step), rtol=1e-13)
            continue  # at v_n = 0 the dashpot's rounded corner adds c_n VS / 4 (the band's middle)
        np.testing.assert_allclose(float(soft.normal_force), float(sharp.normal_force), rtol=1e-13)
        np.testing.assert_allclose(np.asarray(soft.tangential_force), np.asarray(sharp.tangential_force),
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(np.asarray(soft.history), np.asarray(sharp.history), rtol=1e-12, atol=1e-18)


def test_smooth_onset_starts_from_zero_force(x64):
    # closing fast with cohesion and a sliding velocity: at depth 0 every force is 0, and the normal
    # force and its depth-slope rise continuously from there (the sharp law jumps to c_n |v_n|)
    vel = (0.3, 0.0, -0.5)
    f = lambda dep: smooth(point(dep, vel), cohesion=30.0)
    r0 = f(0.0)
    assert float(r0.normal_force) == 0.0 and not np.any(np.asarray(r0.tangential_force))
    assert float(law(point(1e-12, vel), cohesion=30.0).normal_force) > 10.0  # the sharp law's jump
    fn = np.array([float(f(d).normal_force) for d in (1e-9, 1e-8, 1e-7)])
    assert np.all(np.diff(fn) > 0) and fn[0] < 1e-3 * fn[-1] * 100  # ~ quadratic (w ~ 3 t^2) near 0
    dfn = float(jax.grad(lambda dep: f(dep).normal_force)(jnp.asarray(1e-12)))
    assert abs(dfn) < 1e-3 * KN  # the slope starts from 0 too (C1 onset)
    # beyond the onset band the spring is the sharp one, shifted by d_s / 2
    # (plus c_n VS / 4: at v_n = 0 the closing-only dashpot sits in its rounded corner)
    np.testing.assert_allclose(float(smooth(point(5 * DS)).normal_force), KN * 4.5 * DS + corner(), rtol=1e-14)


def test_smooth_point_count(x64):
    depth = jnp.asarray([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [1.0, 0.25, 0.25, 0.0]]) * 2 * DS
    active = depth > 0
    n = np.asarray(SMOOTH.pair_points(jnp.sum(active, -1), depth, active))
    np.testing.assert_allclose(n[:2], [2.0, 1.0], rtol=1e-15)  # integer counts where weights are 0 or 1
    w = 0.5  # smoothstep(0.5): one full point and two half points count 1 + 2 w (the product is 0)
    np.testing.assert_allclose(n[2], 1.0 + 2 * w, rtol=1e-15)
    half = np.asarray(SMOOTH.pair_points(jnp.asarray([2]), depth[2:, 1:], active[2:, 1:]))
    np.testing.assert_allclose(half, 2 * w + (1 - w) ** 2, rtol=1e-15)  # two half points: 1.25
    # the default law's count is max(count, 1), as before
    np.testing.assert_array_equal(np.asarray(PenaltyCoulomb().pair_points(jnp.sum(active, -1), depth, active)),
                                  [2.0, 1.0, 3.0])
    # continuous and >= 1 as one point ramps in
    ws = jnp.linspace(0.0, 2 * DS, 21)
    counts = [float(SMOOTH.pair_points(jnp.asarray([1]), jnp.asarray([[d, 2 * DS]]), jnp.asarray([[True, True]]))[0])
              for d in ws]
    assert min(counts) >= 1.0 and max(np.abs(np.diff(counts))) < 0.2


def test_smooth_stick_slip_is_continuous(x64):
    # stretch the shear spring through the cap: the force's magnitude and the new history move
    # continuously and monotonically; the sharp law's history jumps by c_t v_t / k_s at the cap
    d, vt = 2e-4, 0.02
    dep = d + 0.5 * DS
    ct = 2 * ZETA * math.sqrt(KS * M_RED)
    cap = (KN * d + corner()) * math.tan(PHI)  # v_n = 0: the dashpot's corner
    # the trial force a = k_s (u0 + vt dt) + ct vt, swept from 0.8 to 1.2 caps
    u0s = (np.linspace(0.8, 1.2, 401) * cap - ct * vt) / KS - vt * DT
    f_soft, h_soft, h_sharp = [], [], []
    for u0 in u0s:
        s = smooth(point(dep, (vt, 0.0, 0.0)), history=(u0, 0.0, 0.0))
        f_soft.append(-float(s.tangential_force[0]))
        h_soft.append(float(s.history[0]))
        h_sharp.append(float(law(point(d, (vt, 0.0, 0.0)), history=(u0, 0.0, 0.0)).history[0]))
    f_soft, h_soft, h_sharp = map(np.asarray, (f_soft, h_soft, h_sharp))
    step = (u0s[1] - u0s[0]) * KS
    assert np.all(np.diff(f_soft) >= -1e-9) and np.max(np.diff(f_soft)) <= step * 1.0001
    np.testing.assert_allclose(f_soft[-1], cap, rtol=1e-12)  # exactly on the cap beyond the band
    jump_sharp = np.max(np.abs(np.diff(h_sharp)))
    jump_soft = np.max(np.abs(np.diff(h_soft)))
    assert jump_sharp == pytest.approx(ct * vt / KS, rel=0.02)
    assert jump_soft < 0.1 * jump_sharp  # spread over the band: 2 BAND cap / step ~ 40 samples


def test_smooth_law_gradient_in_the_band(x64):
    # d f_t / d phi inside the slip band vs a central secant (the law is C1 there)
    d, u0 = 2e-4 + 0.5 * DS, None
    cap = KN * 2e-4 * math.tan(PHI)
    u0 = cap * 1.01 / KS
    f = lambda phi: smooth(point(d), history=(u0, 0.0, 0.0), friction_angle=phi).tangential_force[0]
    g = float(jax.grad(f)(jnp.asarray(PHI)))
    for h in (1e-6, 1e-7):
        fd = (float(f(jnp.asarray(PHI + h))) - float(f(jnp.asarray(PHI - h)))) / (2 * h)
        np.testing.assert_allclose(g, fd, rtol=1e-6)


@pytest.mark.parametrize("field,value", [("onset_depth", 0.0), ("closing_speed", -1.0), ("slip_band", 1.5),
                                         ("slip_band", float("nan"))])
def test_smooth_law_rejects_bad_widths(field, value):
    with pytest.raises(ValueError, match=field):
        SmoothPenaltyCoulomb(**{field: value})
