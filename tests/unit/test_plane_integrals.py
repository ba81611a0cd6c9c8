"""The kernels' plane integrals (``sph.kernels.plane_integrals``), used by the semi-analytical wall
term of ``Coupling.BOUNDARY_INTEGRAL``, against numerical quadrature (scipy) of the 3D kernels,
written here in numpy from their textbook definitions (Wendland C2: 21/(16 pi h^3) (1 - q/2)^4
(2q + 1); cubic spline, Monaghan & Lattanzio 1985: 1/(pi h^3) (1 - 3q^2/2 + 3q^3/4 | (2 - q)^3/4))."""

import numpy as np
import pytest
from scipy import integrate

from rockjax.sph import kernels
from rockjax.sph.kernels import CubicSpline, WendlandC2


def _wendland(r, h):
    q = r / h
    return 21.0 / (16.0 * np.pi * h**3) * max(1.0 - q / 2.0, 0.0) ** 4 * (2.0 * q + 1.0)


def _cubic(r, h):
    q = r / h
    return (1.0 - 1.5 * q**2 + 0.75 * q**3 if q < 1.0 else 0.25 * max(2.0 - q, 0.0) ** 3) / (np.pi * h**3)


KERNELS = [(WendlandC2(), _wendland), (CubicSpline(), _cubic)]


def _plane(w, s, h):
    """int over the plane at distance s of W: 2 pi int_0^R W(sqrt(s^2 + rho^2)) rho d rho."""
    kink = [np.sqrt(h * h - s * s)] if s < h else None  # the cubic spline's q = 1
    return integrate.quad(lambda rho: w(np.hypot(s, rho), h) * 2 * np.pi * rho, 0.0, 2 * h, points=kink,
                          epsabs=1e-13, epsrel=1e-11)[0]


@pytest.mark.parametrize("kind,w", KERNELS, ids=[k.name for k, _ in KERNELS])
def test_plane_integrals_match_quadrature(x64, kind, w):
    h = 0.013
    fn = kernels.plane_integrals(kind)
    for s in [0.0, 0.1 * h, 0.45 * h, h, 1.3 * h, 1.9 * h, 2 * h, 2.5 * h]:
        area, beyond = (float(v) for v in fn(np.float64(s), np.float64(h)))
        a_ref = _plane(w, s, h)
        g_ref = integrate.quad(lambda t: _plane(w, t, h), s, 2 * h, epsabs=1e-13)[0] if s < 2 * h else 0.0
        assert area == pytest.approx(a_ref, rel=1e-8, abs=1e-10 / h), (s / h, area, a_ref)
        assert beyond == pytest.approx(g_ref, rel=1e-7, abs=1e-12), (s / h, beyond, g_ref)
    # the half space holds half the kernel; int G ds equals the first moment int s A ds
    assert float(fn(0.0, h)[1]) == pytest.approx(0.5, abs=1e-14)
    s = np.linspace(0.0, 2 * h, 4001)
    area, beyond = (np.asarray(v) for v in fn(s, np.float64(h)))
    assert np.trapezoid(area, s) == pytest.approx(0.5, rel=1e-6)
    assert np.trapezoid(beyond, s) == pytest.approx(np.trapezoid(s * area, s), rel=1e-6)


def test_face_share_approximation(x64):
    """``coupling.penalty.wall_terms`` takes the share of a face plane's kernel integral inside a
    face edge at in-plane distance e as 1 - G(e) (G(-e) outside). Against the exact share (2D
    quadrature of the Wendland C2 kernel over the half plane), for the first water layers
    (s <= 0.8 h): within 0.01."""
    h = 1.0
    _, beyond = kernels.plane_integrals(WendlandC2())(np.asarray([0.3, 0.6]), h)
    approx = {0.3: 1.0 - float(beyond[0]), 0.6: 1.0 - float(beyond[1]), -0.3: float(beyond[0]), -0.6: float(beyond[1])}
    for s in [0.0, 0.4, 0.8]:
        R = np.sqrt(4 * h * h - s * s)
        total = _plane(_wendland, s, h)
        for e, share in approx.items():
            exact = integrate.dblquad(lambda y, x: _wendland(np.sqrt(s * s + x * x + y * y), h), -R, min(e, R),
                                      lambda x: -np.sqrt(max(R * R - x * x, 0.0)),
                                      lambda x: np.sqrt(max(R * R - x * x, 0.0)), epsabs=1e-9)[0] / total
            assert abs(exact - share) < 0.01, (s, e, exact, share)
