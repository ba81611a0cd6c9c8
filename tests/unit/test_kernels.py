"""Kernels: normalisation (integral = 1), compact support, gradient = finite difference."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad

from rockjax.sph import kernels as K

H = 0.013  # smoothing length [m]

SMOOTH = [
    ("wendland_c2", K.wendland_c2, K.wendland_c2_f),
    ("cubic_spline", K.cubic_spline, K.cubic_spline_f),
    ("poly6", K.poly6, K.poly6_f),
    ("spiky", K.spiky, K.spiky_f),
]


pytestmark = pytest.mark.usefixtures("x64")  # float64 for the whole module (tests/conftest.py)


@pytest.mark.parametrize("name,w,f", SMOOTH + [("viscosity", K.viscosity_kernel, None)])
def test_normalised(name, w, f):
    R = K.SUPPORT_FACTOR * H
    integral, err = quad(lambda r: 4 * math.pi * r * r * float(w(jnp.asarray(r), H)), 0, R, limit=200)
    assert abs(integral - 1.0) < 1e-6, (name, integral)


@pytest.mark.parametrize("name,w,f", SMOOTH)
def test_compact_support(name, w, f):
    R = K.SUPPORT_FACTOR * H
    r = jnp.linspace(R, 3 * R, 50)
    assert float(jnp.max(jnp.abs(w(r, H)))) == 0.0
    assert float(jnp.max(jnp.abs(f(r, H)))) == 0.0
    assert float(w(jnp.asarray(0.999 * R), H)) > 0.0


@pytest.mark.parametrize("name,w,f", SMOOTH)
def test_gradient_matches_finite_difference(name, w, f):
    R = K.SUPPORT_FACTOR * H
    r = np.linspace(0.05 * R, 0.98 * R, 41)
    eps = 1e-7 * R
    fd = (np.asarray(w(jnp.asarray(r + eps), H)) - np.asarray(w(jnp.asarray(r - eps), H))) / (2 * eps)
    analytic = np.asarray(f(jnp.asarray(r), H)) * r  # f = (dW/dr)/r
    np.testing.assert_allclose(analytic, fd, rtol=1e-5, atol=1e-8 * np.abs(fd).max())


@pytest.mark.parametrize("name,w,f", SMOOTH)
def test_autodiff_gradient_agrees(name, w, f):
    """jax.grad of W agrees with the hand-written derivative (so gradients through W are right)."""
    R = K.SUPPORT_FACTOR * H
    for r in (0.1 * R, 0.5 * R, 0.9 * R):
        g = float(jax.grad(lambda s: w(s, H))(jnp.asarray(r)))
        assert abs(g - float(f(jnp.asarray(r), H)) * r) <= 1e-9 * abs(g) + 1e-12


def test_viscosity_laplacian_is_laplacian_of_its_kernel():
    """Seed Eq 19 is the 3D Laplacian (1/r^2 d/dr (r^2 dW/dr)) of Mueller's viscosity kernel."""
    R = K.SUPPORT_FACTOR * H
    w = lambda r: K.viscosity_kernel(r, H)  # noqa: E731
    dw = jax.grad(w)
    lap = jax.vmap(lambda r: jax.grad(lambda s: s * s * dw(s))(r) / (r * r))
    r = jnp.linspace(0.1 * R, 0.95 * R, 20)
    np.testing.assert_allclose(np.asarray(lap(r)), np.asarray(K.viscosity_laplacian(r, H)), rtol=1e-8)


def test_wendland_finite_gradient_at_origin():
    assert np.isfinite(float(K.wendland_c2_f(jnp.asarray(0.0), H)))
