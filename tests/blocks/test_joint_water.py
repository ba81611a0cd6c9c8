"""Joint water pressure (``blocks.joint_water``) against hydrostatics in closed form.

p = rho_w g max(z_w - z, 0) on a contact patch: the force is the integral of p over the patch's
wet part and acts at the centre of pressure; on a block sliding down a submerged incline it
lowers the effective normal force, m s'' = m g sin(theta) - mu (m g cos(theta) - P(s)), an ODE
with a closed-form solution.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import integrate

from rockjax.blocks import Motion, box, contact_forces, make_blocks
from rockjax.blocks.joint_water import joint_water_load, submerged_parts

from rollouts import assert_same_loads, grown_by_driver, incline_scene, run

RHO, G = 1000.0, 9.81
GRAV = (0.0, 0.0, -G)

#: ``contact_forces`` compiled once per config (op by op, each call took 10-30 s on 2 cores)
_contact_forces = jax.jit(contact_forces, static_argnums=2, static_argnames=("dt", "return_info"))


def _load(points, active, n, level):
    n = jnp.asarray(n, jnp.float64)
    a = jnp.array([1.0, 0.0, 0.0]) if abs(float(n[0])) < 0.6 else jnp.array([0.0, 1.0, 0.0])
    t1 = jnp.cross(n, a)
    t1 = t1 / jnp.linalg.norm(t1)
    t2 = jnp.cross(n, t1)
    args = (jnp.asarray(points, jnp.float64), jnp.asarray(active), n, t1, t2, jnp.asarray(level, jnp.float64))

    def f(p, a, n, t1, t2, lv):
        return joint_water_load(p, a, n, t1, t2, level=lv, density=RHO, gravity=jnp.asarray(GRAV, jnp.float64))

    eager, jitted = f(*args), jax.jit(f)(*args)
    for e, j in zip(eager, jitted):  # under jit (fused multiply-adds) the patch must not change
        np.testing.assert_allclose(np.asarray(j), np.asarray(e), rtol=1e-12, atol=1e-12)
    return jitted


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_turned_square_patch_under_jit(x64, dtype):
    """A square patch turned 8 degrees (a box resting on a floor after a slight yaw), padded with
    inactive slots: its full area under jit in float32 and float64 (the first hull test, an
    orientation test, lost 1-3 of the 4 corners under jit)."""
    th = 0.139
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    sq = np.array([[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]]) @ R.T + [0.2487, 0.2419]
    pts = np.concatenate([np.c_[sq, np.full(4, -3e-5)], np.zeros((157, 3))]).astype(dtype)
    act = np.arange(161) < 4
    n = jnp.asarray([0.0, 0.0, -1.0], dtype)
    t1 = jnp.asarray([0.0, 1.0, 0.0], dtype)
    t2 = jnp.cross(n, t1)
    fn = jax.jit(lambda p: joint_water_load(p, jnp.asarray(act), n, t1, t2, level=0.2, density=RHO,
                                            gravity=jnp.asarray(GRAV, dtype))[1])
    assert float(fn(jnp.asarray(pts))) == pytest.approx(RHO * G * (0.2 + 3e-5) * 0.01, rel=1e-5)


def test_vertical_rectangle_across_the_level(x64):
    """A 0.2 m wide vertical joint from z = -0.3 to 0.1 m, level 0: F = rho g w d^2 / 2 with
    d = 0.3 m, centre of pressure d / 3 above the bottom.  Padding points and their order do not
    matter (the points come shuffled, with inactive ones mixed in)."""
    w, zlo, zhi = 0.2, -0.3, 0.1
    pts = np.array([[w, 0, zhi], [0.05, 0, zlo], [0, 0, zlo], [0, 0, zhi], [9, 9, 9], [w, 0, zlo]], float)
    act = np.array([1, 0, 1, 1, 0, 1], bool)
    F, f, m = _load(pts, act, [0.0, 1.0, 0.0], 0.0)
    d = -zlo
    assert float(f) == pytest.approx(RHO * G * w * d**2 / 2, rel=1e-12)
    np.testing.assert_allclose(np.asarray(F), [0.0, float(f), 0.0], atol=1e-9)
    np.testing.assert_allclose(np.asarray(m) / float(f), [w / 2, 0.0, zlo + d / 3], atol=1e-12)


def test_tilted_patch_fully_submerged(x64):
    """A tilted convex pentagon below the level: F = rho g (z_w - z_c) A, A and the centroid
    z_c from the shoelace formula, with extra points inside it and on its edges (as the contact
    points of two overlapping faces can be) changing nothing."""
    th = np.radians(25.0)
    n = np.array([np.sin(th), 0.0, np.cos(th)])
    t1 = np.array([np.cos(th), 0.0, -np.sin(th)])
    t2 = np.cross(n, t1)
    poly = np.array([[0, 0], [0.3, 0], [0.4, 0.15], [0.2, 0.3], [-0.05, 0.2]])
    x2 = np.roll(poly, -1, 0)
    cr = poly[:, 0] * x2[:, 1] - x2[:, 0] * poly[:, 1]
    A = 0.5 * cr.sum()
    cxy = ((poly + x2) * cr[:, None]).sum(0) / (6 * A)
    origin = np.array([0.2, 0.1, -0.5])
    to3 = lambda q: origin + q[..., :1] * t1 + q[..., 1:] * t2  # noqa: E731
    extra = np.array([[0.15, 0.1], [0.15, 0.0], [0.1, 0.15]])
    pts = to3(np.concatenate([extra[:1], poly, extra[1:]]))
    F, f, m = _load(pts, np.ones(len(pts), bool), n, 0.0)
    zc = to3(cxy)[2]
    assert float(f) == pytest.approx(RHO * G * (0.0 - zc) * A, rel=1e-12)
    np.testing.assert_allclose(np.asarray(F), float(f) * n, atol=1e-9)


@pytest.mark.parametrize("depths", [(0.3, 0.1, 0.2), (0.3, -0.1, 0.05), (0.2, -0.3, -0.05), (-0.1, -0.2, -0.01),
                                    (0.1, 0.1, -0.2), (0.0, 0.0, 0.0)])
def test_wet_part_of_a_triangle_against_quadrature(x64, depths):
    """The clipped triangles of ``submerged_parts``: their integral of the depth field and its
    first moment equal scipy's adaptive quadrature of max(L, 0) over the triangle."""
    P = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.3, 0.9, 0.0]])
    v = np.asarray(depths)
    Q, w = submerged_parts(jnp.asarray(P), jnp.asarray(v))
    Q, w = np.asarray(Q), np.asarray(w)
    area = 0.5 * np.abs(np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0])[:, 2])
    I0 = np.sum(area * w.sum(-1) / 3)
    I1 = np.sum((area / 12)[:, None] * (np.einsum("sck,sc->sk", Q, w) + w.sum(-1)[:, None] * Q.sum(1)), 0)

    def L(a, b):  # barycentric (a, b) for vertices 1, 2
        return max(v[0] * (1 - a - b) + v[1] * a + v[2] * b, 0.0)

    jac = abs(np.cross(P[1] - P[0], P[2] - P[0])[2])
    ref0 = integrate.dblquad(lambda b, a: L(a, b), 0, 1, 0, lambda a: 1 - a, epsabs=1e-12)[0] * jac
    ref1 = [integrate.dblquad(lambda b, a: L(a, b) * (P[0, k] * (1 - a - b) + P[1, k] * a + P[2, k] * b),
                              0, 1, 0, lambda a: 1 - a, epsabs=1e-12)[0] * jac for k in range(2)]
    assert I0 == pytest.approx(ref0, rel=1e-7, abs=1e-12)
    np.testing.assert_allclose(I1[:2], ref1, rtol=1e-7, atol=1e-12)


def test_overlap_patch_of_two_boxes(x64):
    """A 0.2 m cube pressed on a 0.3 m cube's top, offset so that their faces overlap over
    x in [0, 0.15], y in [0.05, 0.15] m: ``contact_forces`` finds that overlap as the patch (its
    corners are contact points: two vertices, two edge crossings) and its water load is
    rho g (z_w - 0.3 m) A along the contact normal, up on the top block and down on the bottom
    one, acting at the overlap's centre, to within the 1e-5 m penetration of the pair (the
    contact points sit between the two faces: relative 1e-5 / 0.7 m).  Off by default: no key,
    no load."""
    pos = np.array([[0.0, 0.0, 0.15], [0.1, 0.15, 0.4 - 1e-5]])
    kw = dict(positions=pos, motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6)
    shapes = [box(0.3, 0.3, 0.3), box(0.2, 0.2, 0.2)]
    level, A, centre = 1.0, 0.15 * 0.1, np.array([0.075, 0.1, 0.3])
    cfg, par, st = make_blocks(shapes, joint_water=True, joint_water_level=level, **kw)
    F, T, _, status, info = _contact_forces(st, par, cfg, dt=1e-4, gravity=GRAV, return_info=True)
    assert int(status) == 0
    expect = RHO * G * (level - 0.3) * A
    Fw = np.asarray(info["joint_water_force"])[np.asarray(info["pair_mask"])]
    rel = 1e-5 / (level - 0.3)
    np.testing.assert_allclose(np.abs(Fw.sum(0)), [0.0, 0.0, expect], rtol=rel, atol=1e-9)
    cfg0, par0, st0 = make_blocks(shapes, **kw)
    F0, T0, _, _, info0 = _contact_forces(st0, par0, cfg0, dt=1e-4, return_info=True)
    assert "joint_water_force" not in info0
    np.testing.assert_allclose(np.asarray(F[1] - F0[1]), [0, 0, expect], rtol=rel, atol=1e-6)
    np.testing.assert_allclose(np.asarray(F[0] - F0[0]), [0, 0, -expect], rtol=rel, atol=1e-6)
    r = centre - pos[1]
    np.testing.assert_allclose(np.asarray(T[1] - T0[1]), np.cross(r, [0, 0, expect]), rtol=2 * rel, atol=1e-6)


def test_submerged_incline_closed_form():
    """A 0.2 m cube sliding down a 30 degree incline (mu = 0.3) below a still level, blocks only:
    the joint carries P(s) = rho g A (d0 + s sin(theta)) (its depth grows as it slides), so
    s'' = a0 + kappa s with a0 = g (sin - mu cos) + mu rho g A d0 / m, kappa = mu rho g A sin / m,
    and s(t) = a0 / kappa (cosh(sqrt(kappa) t) - 1), while P < m g cos(theta) (d0 = 0.02 m,
    0.7 s: P grows from 8 to 140 N, m g cos = 180 N; beyond, the load would lift the block off --
    in a blocks-only scene no water presses on its other faces).  Measured: within 1 % at the end,
    2 % throughout after 0.25 s; and 10 % faster than the dry block, s = g (sin - mu cos) t^2 / 2."""
    th, mu, d0 = np.radians(30.0), 0.3, 0.02
    cfg, par, st, down, _ = incline_scene(theta_deg=30.0, b=0.2, h=0.2, phi_deg=np.degrees(np.arctan(mu)), s0=-1.5)
    base_z = float(st.x[1, 2]) - 0.1 * np.cos(th)
    cfg = dataclasses.replace(cfg, joint_water=True)
    par = par.replace(joint_water_level=jnp.asarray(base_z + d0, par.density.dtype))
    dt, n, every = 2.5e-4, 2800, 40
    st1, x, _, _, stat = run(cfg, st, par, dt=dt, n_steps=n, every=every, gravity=GRAV)
    assert stat == 0, stat
    t = dt * every * np.arange(1, n // every + 1)
    s = (x[:, 1] - np.asarray(st.x[1])) @ down
    m, A = 2650.0 * 0.2**3, 0.2 * 0.2
    a0 = G * (np.sin(th) - mu * np.cos(th)) + mu * RHO * G * A * d0 / m
    kap = mu * RHO * G * A * np.sin(th) / m
    exact = a0 / kap * (np.cosh(np.sqrt(kap) * t) - 1)
    dry = 0.5 * G * (np.sin(th) - mu * np.cos(th)) * t**2
    print(f"s(0.7 s) = {s[-1]:.4f} m, closed form {exact[-1]:.4f}, dry {dry[-1]:.4f}")
    assert exact[-1] > 1.1 * dry[-1]  # the water matters here
    assert s[-1] == pytest.approx(exact[-1], rel=1e-2)
    sel = t >= 0.25
    np.testing.assert_allclose(s[sel], exact[sel], rtol=2e-2)


def test_grad_of_joint_load_matches_finite_differences(x64):
    """A 0.2 m cube pressed sideways against a fixed block, turned 0.3 rad about the contact
    normal so that the block's top edge clips the patch, with the level crossing it: the load
    (force and torque) differentiated w.r.t. the level and the cube's height by jax.grad equals
    central differences (float64)."""
    a = 0.3
    cfg, par, st = make_blocks([box(0.6, 0.6, 0.3), box(0.2, 0.2, 0.2)],
                               positions=np.array([[0.0, 0.0, 0.0], [0.0, 0.4 - 1e-5, 0.05]]),
                               orientations=np.array([[1.0, 0, 0, 0], [np.cos(a / 2), 0.0, np.sin(a / 2), 0.0]]),
                               motion=[Motion.FIXED, Motion.DYNAMIC], joint_water=True, normal_stiffness=1e6)

    def load(level, z):
        p = par.replace(joint_water_level=level)
        s = st.replace(x=st.x.at[1, 2].add(z))
        F, T, _, _, info = contact_forces(s, p, cfg, dt=1e-4, gravity=GRAV, return_info=True)
        return jnp.sum(info["joint_water_force"][:, 1]) + 3.0 * T[1, 0] + 2.0 * T[1, 2]

    lv, z = jnp.asarray(0.05), jnp.asarray(0.0)
    g = jax.jit(jax.grad(load, argnums=(0, 1)))(lv, z)
    load = jax.jit(load)
    assert abs(float(load(lv, z))) > 1.0
    eps = 1e-6
    fd = [(load(lv + eps, z) - load(lv - eps, z)) / (2 * eps), (load(lv, z + eps) - load(lv, z - eps)) / (2 * eps)]
    np.testing.assert_allclose(np.asarray(g), np.asarray(fd), rtol=1e-5)


def test_patch_points_gathered_and_overflow_flagged(x64):
    """The joint patch is built from the pair's active points gathered into
    ``joint_patch_points`` slots: the same load as from all 161 slots when they fit (the offset
    boxes' patch has 4 corners among its active points), and JOINT_PATCH_OVERFLOW when they do not
    (3 slots), which the driver's ``_grow`` cures by doubling the slots."""
    from rockjax.types import Status

    pos = np.array([[0.0, 0.0, 0.15], [0.1, 0.15, 0.4 - 1e-5]])
    kw = dict(positions=pos, motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6, joint_water=True,
              joint_water_level=1.0)
    shapes = [box(0.3, 0.3, 0.3), box(0.2, 0.2, 0.2)]
    out = {}
    for k in (200, 8, 3):
        cfg, par, st = make_blocks(shapes, joint_patch_points=k, **kw)
        F, T, _, status, info = _contact_forces(st, par, cfg, dt=1e-4, gravity=GRAV, return_info=True)
        out[k] = (np.asarray(F), np.asarray(T), int(status), int(np.asarray(info["active"]).sum()))
    assert out[200][2] == 0 and out[8][2] == 0
    assert 3 < out[200][3] <= 8  # the patch's active points fit in 8 slots, not in 3
    assert_same_loads(out[8], out[200])
    assert out[3][2] & Status.JOINT_PATCH_OVERFLOW
    assert Status.JOINT_PATCH_OVERFLOW & Status.growable()
    cfg3, _, _ = make_blocks(shapes, joint_patch_points=3, **kw)
    assert grown_by_driver(cfg3, Status.JOINT_PATCH_OVERFLOW).joint_patch_points == 6


def _tilted_cube_load(s, ap, level, fade):
    """The joint-water load [N] of a 0.2 m cube on a 0.3 m cube's top, tilted about y so that one
    bottom edge is 1e-5 m deep and the opposite one lifted by ``s`` [m] (aperture ``ap``)."""
    th = np.arcsin(s / 0.2)
    c, sn = np.cos(th), np.sin(th)
    R = np.array([[c, 0.0, sn], [0.0, 1.0, 0.0], [-sn, 0.0, c]])
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1)]) @ R.T
    pos = np.array([[0.0, 0.0, 0.15], [0.0, 0.0, 0.3 - 1e-5 - corners[:, 2].min()]])
    cfg, par, st = make_blocks([box(0.3, 0.3, 0.3), box(0.2, 0.2, 0.2)], positions=pos,
                               orientations=np.array([[1.0, 0, 0, 0], [np.cos(th / 2), 0.0, np.sin(th / 2), 0.0]]),
                               motion=[Motion.FIXED, Motion.DYNAMIC], normal_stiffness=1e6, joint_water=True,
                               joint_water_level=level, joint_aperture=ap)
    cfg = dataclasses.replace(cfg, joint_fade_points=fade)
    _, _, _, status, info = _contact_forces(st, par, cfg, dt=1e-4, gravity=GRAV, return_info=True)
    assert int(status) == 0
    return float(np.abs(np.asarray(info["joint_water_force"]).sum(0)[2]))


@pytest.mark.parametrize("fade", [False, True], ids=["sharp", "fade_points"])
def test_joint_patch_as_a_corner_leaves_the_aperture(x64, fade):
    """A 0.2 m cube on a 0.3 m cube's top, tilted about y so that one bottom edge touches (1e-5 m
    deep) and the opposite edge lifts by s = 0.2 sin(theta); aperture 0.01 m (near points within
    ap / 2 = 5 mm). As s crosses 5 mm the far corners leave the joint: the patch (the hull of the
    near points) collapses from the whole bottom face to the touching edge. Without
    ``joint_fade_points`` the load drops from ~rho g (z_w - 0.3) 0.04 m^2 to 0 at once; with it
    the far corners move in from the patch's weighted centre as s goes from ap/4 to ap/2, so the
    load falls continuously to 0, and up to s = ap/4 it equals the sharp patch's load."""
    ap, level = 0.01, 1.0

    def load(s):
        return _tilted_cube_load(s, ap, level, fade)

    full = RHO * G * (level - 0.3) * 0.04
    s_edge = 0.5 * ap + 1e-5  # the far corners are s - 1e-5 above the face
    below, above = load(s_edge - 1e-6), load(s_edge + 1e-6)
    assert above < 1e-9 * full  # the far corners have left: the patch is the touching edge
    if not fade:
        assert below > 0.9 * full  # the whole face, then nothing
    else:
        assert below < 1e-3 * full  # continuous: the far corners have moved in to the centre
        loads = np.array([load(s) for s in np.linspace(0.25 * ap + 1e-5, s_edge, 11)])
        assert np.all(np.diff(loads) <= 1e-9 * full)  # falls monotonically over the band
        # weights 1 up to s = ap / 4: the sharp patch's load
        np.testing.assert_allclose(load(0.2 * ap), _tilted_cube_load(0.2 * ap, ap, level, False), rtol=1e-9)
