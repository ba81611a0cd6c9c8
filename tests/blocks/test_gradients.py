"""Gradients through the block step (float64): jax.grad vs central finite differences.

A box slides down a 30 deg slope (mu = tan(phi) = 0.3) for 0.25 s (1000 steps of 2.5e-4 s);
loss = its final down-slope position.  Closed form for a rigid contact:
ds/dphi = -t^2 g cos(theta) / (2 cos^2 phi), here -0.2894 m/rad (measured AD -0.28338, FD
-0.28354; the 2 % gap to the closed form is the penalty start-up transient).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from rollouts import incline_scene, rollout_fn

DT, N = 2.5e-4, 1000


@pytest.fixture(scope="module")
def scene(x64):
    cfg, par, st, down, _ = incline_scene(theta_deg=30.0, b=0.2, h=0.2, phi_deg=np.degrees(np.arctan(0.3)), s0=-1.0)
    assert st.x.dtype == jnp.float64
    run = rollout_fn(cfg, N, N)
    g = jnp.asarray([0.0, 0.0, -9.81])

    def loss(par):
        s, _, _ = run(st, par, jnp.asarray(DT), g)
        return s.x[1] @ jnp.asarray(down)

    return par, jax.jit(loss), jax.jit(jax.grad(loss))


def _fd(loss, par, field, h):
    base = getattr(par, field)
    hi = float(loss(par.replace(**{field: base + h})))
    lo = float(loss(par.replace(**{field: base - h})))
    return (hi - lo) / (2 * h)


@pytest.mark.slow  # the default run covers the same check in tests/gradients/test_blocks_grad.py
def test_grad_friction_angle_matches_fd(scene):
    par, loss, grad = scene
    g = float(grad(par).friction_angle)
    fd = _fd(loss, par, "friction_angle", 1e-4)
    phi = float(par.friction_angle)
    t = N * DT
    closed = -(t**2) * 9.81 * np.cos(np.radians(30)) / (2 * np.cos(phi) ** 2)
    assert np.isfinite(g)
    print("dphi: AD", g, "FD", fd, "closed", closed)
    assert g == pytest.approx(fd, rel=1e-2), (g, fd)
    # and the physics: within 5 % of the rigid closed form (penalty start-up transient)
    assert g == pytest.approx(closed, rel=5e-2), (g, closed)


@pytest.mark.slow  # likewise (tests/gradients/test_blocks_grad.py, density)
def test_grad_density_finite_and_matches_fd(scene):
    """Sliding is mass-independent for a rigid contact; with penalty springs the mass enters
    through the contact compliance only, so d s / d rho is tiny: compare AD with FD on the
    scale of the friction sensitivity (1e-2 of |ds/dphi| per 1 % density change)."""
    par, loss, grad = scene
    gd = np.asarray(grad(par).density)
    print("drho AD", gd)
    assert np.all(np.isfinite(gd))
    h = 1.0  # kg/m^3 on 2650
    base = par.density
    fd = (float(loss(par.replace(density=base.at[1].add(h)))) - float(loss(par.replace(density=base.at[1].add(-h))))) / (2 * h)
    print("drho FD", fd)
    scale = 1e-2 * 0.2894 / (0.01 * 2650)
    assert abs(gd[1] - fd) <= max(1e-2 * abs(fd), 1e-3 * scale), (gd[1], fd)
    assert gd[0] == 0.0  # the FIXED slope's density does not matter


def test_tied_max_derivative_averages_ties_and_never_divides_by_zero(x64):
    """``rotation.tied_max`` (the narrow phase's max): at an exact tie its derivative is
    ``jnp.max``'s (the mean of the tied tangents); entries within 4 ulps of the max tie too (they
    may be one value rounded twice), where ``jnp.max`` takes only the larger one; ``tied_min`` mirrors it."""
    from rockjax.blocks.rotation import tied_max, tied_min

    t = jnp.asarray([1.0, 3.0, 5.0])
    exact = jnp.asarray([1.0, 1.0, 0.5])
    near = jnp.asarray([1.0, np.nextafter(1.0, 2.0), 0.5])
    for x, want in ((exact, 2.0), (near, 2.0)):
        v, dv = jax.jvp(tied_max, (x,), (t,))
        assert float(v) == float(jnp.max(x)) and float(dv) == want
    assert float(jax.jvp(jnp.max, (near,), (t,))[1]) == 3.0  # the one it replaces
    v, dv = jax.jvp(lambda x: tied_min(x, 0), (-exact[:, None],), (t[:, None],))
    assert float(v[0]) == -1.0 and float(dv[0]) == 2.0
    g = jax.grad(lambda x: tied_max(x))(near)  # the transpose (reverse mode) of the same rule
    np.testing.assert_allclose(np.asarray(g), [0.5, 0.5, 0.0])


def test_common_plane_tangent_does_not_depend_on_the_compile(x64):
    """A box resting flat on a 30 deg slope (1e-5 m overlap): its face normal and the slope's tie in
    the common-plane choice. The tangent of (normal, gap) w.r.t. the box's pose must be finite and
    the same whether XLA optimises the program or not (``jax_disable_most_optimizations``): the
    tie rule of ``fcp._best`` and ``tied_max`` gives ties to the first candidate, i's (the box's)
    face normals, instead of leaving the choice to round-off."""
    from fcp_cases import fcp_fn, padded
    from rockjax.blocks import geometry as geo

    th = np.radians(30.0)
    n = np.array([np.sin(th), 0.0, np.cos(th)])
    rot = np.array([[np.cos(th), 0.0, np.sin(th)], [0.0, 1.0, 0.0], [-np.sin(th), 0.0, np.cos(th)]])
    box = geo.ConvexPolyhedron.from_vertices(geo.box(0.2, 0.2, 0.1).vertices @ rot.T + (0.05 - 1e-5) * n)
    slope = geo.slope(4.0, 2.0, 0.2, 30.0)
    bi, bj = padded(box), padded(slope)
    q0 = jnp.asarray([1.0, 0.0, 0.0, 0.0])
    xi, xj = jnp.asarray(box.centroid_world), jnp.asarray(slope.centroid_world)
    run = fcp_fn(0)

    def f(x, q):
        out = run(bi, q, x, bj, q0, xj, jnp.asarray(n), jnp.asarray(True))
        return out["normal"], out["gap"]

    primal = f(xi, q0)
    # the box's bottom normal = minus the slope's top normal: a tie
    assert np.allclose(np.asarray(primal[0]), -n) and abs(float(primal[1]) + 1e-5) < 1e-9
    rng = np.random.default_rng(0)
    dx, dq = jnp.asarray(rng.normal(size=3)), jnp.asarray(rng.normal(size=4))
    flag = "jax_disable_most_optimizations"
    old = jax.config.values[flag]
    tangents = []
    try:
        for off in (False, True):
            jax.config.update(flag, off)
            tangents.append(jax.jit(lambda x, q, a, b: jax.jvp(f, (x, q), (a, b))[1])(xi, q0, dx, dq))
    finally:
        jax.config.update(flag, old)
    (n_opt, g_opt), (n_o0, g_o0) = tangents
    assert np.all(np.isfinite(np.asarray(n_o0))) and np.isfinite(float(g_o0))
    assert float(jnp.linalg.norm(n_opt)) > 0.1  # the box's normal (it turns with the box), not the slope's
    np.testing.assert_allclose(np.asarray(n_o0), np.asarray(n_opt), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(float(g_o0), float(g_opt), rtol=1e-9, atol=1e-12)
