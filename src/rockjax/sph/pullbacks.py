"""Hand-derived reverse mode of the default WCSPH pair functions, both ends of a pair at once.

``sph.pair_sum``'s gather-only VJP (``Adjoint.PAIR_SUMS``) visits each listed pair (r, j) from
row r twice: as the pair's i (the VJP of ``fn(r, j)`` with r's cotangent) and as its j (the VJP
of ``fn(j, r)`` with j's cotangent gathered), two generic ``jax.vjp`` evaluations of the pair
function. For the default pair functions most per-pair quantities are the same from both ends
(distance, kernel factor, ``v_ij . x_ij``, the viscous term, the hydrostatic density difference
up to sign), so one pass computes them once and gives row r's cotangents from both ends:

* ``momentum``: ``_momentum_pair`` with ``sph.viscosity.Artificial``: the acceleration of i is
  ``m_j Q_ij F_ij x_ij`` with ``Q = -(p_i + p_j) / (rho_i rho_j) - Pi_ij`` symmetric;
* ``continuity``: ``_continuity_pair`` with ``sph.diffusion.Fourtakas`` or ``NoDiffusion``:
  ``rho_i V_j v_ij . x_ij F_ij + D V_j psi_ij F_ij`` with ``psi_ji = -psi_ij`` (the diffusion's
  density difference less the odd ``hydrostatic_pair_difference``), ``D = -2 delta h c0``.

Each is a factory ``(config) -> pullback or None`` (None: the configuration is not covered, the
generic VJP runs). A pullback ``pb(own, nb, d, r, params, mask, fluid_j, g_r, g_j, g_p)`` takes a
row block's own values ``own`` ([R, 1] arrays), its neighbours' ``nb`` ([R, K]), ``d`` (three
[R, K] arrays ``x_r - x_j``), ``r`` = |d|, the pair ``mask`` and ``fluid_j``, the row's cotangents
``g_r`` ([R, 1] each output), the neighbours' ``g_j`` ([R, K], zero where j is no fluid row) and
``g_p`` (``g_r`` restricted to the rows whose parameters this block counts), and returns
``(ct_own, ct_d, ct_params)``: per-pair cotangents of row r's values (dict), of ``d`` (three
arrays; ``x_r``'s, since ``d = x_r - x_j``) and the ``Params`` cotangent (summed).
``pair_sum`` also runs it over the flat (fluid, wall) pair list with the wall as ``own``, the
fluid row as the neighbour, ``fluid_j`` False (the pair has a non-fluid end: wall viscosity, no
diffusion) and ``g_r = g_p = 0``: the wall columns' cotangents as the pairs' j ends.

Tested against the generic VJP in float64 (``tests/gradients/test_pair_sum_adjoint.py``).
Speed: ``experiments/bench_grad.py --adjoint-ab`` (RESULTS.md, "adjoint").
"""

from __future__ import annotations

from typing import Callable, Optional

import jax
import jax.numpy as jnp

from ..types import Config, Params
from .eos import hydrostatic_power

__all__ = ["momentum", "continuity"]

_V = ("v0", "v1", "v2")


def _kernel(r, mask, params: Params, config: Config):
    """``(F, dF/dr, dF/dh)`` of the pairs (zero off ``mask``), elementwise forward mode of the kernel."""
    f_fn = config.scheme.kernel.f
    h = params.fluid.h
    F, dF_dr = jax.jvp(lambda r: f_fn(r, h), (r,), (jnp.ones_like(r),))
    dF_dh = jax.jvp(lambda h: f_fn(r, h), (h,), (jnp.ones_like(h),))[1]
    z = lambda a: jnp.where(mask, a, 0.0)  # noqa: E731
    return z(F), z(dF_dr), z(dF_dh)


def _radial(F_b, dF_dr, r, mask):
    """``dL/dr / r`` of a pair term ``F(r)`` with cotangent ``F_b`` (zero at r = 0 and off ``mask``)."""
    on = mask & (r > 0)
    return jnp.where(on, F_b * dF_dr / jnp.where(on, r, 1.0), 0.0)


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _params_ct(params: Params, gravity=None, **fluid):
    """A ``Params`` cotangent: zeros but the given fluid leaves (summed scalars) and gravity [3]."""
    zero = jax.tree_util.tree_map(jnp.zeros_like, params)
    ct = zero.replace(fluid=zero.fluid.replace(**{k: jnp.sum(v).astype(zero.fluid.h.dtype) for k, v in fluid.items()}))
    return ct if gravity is None else ct.replace(gravity=gravity.astype(zero.gravity.dtype))


def momentum(config: Config) -> Optional[Callable]:
    """The pullback of ``wcsph._momentum_pair`` (artificial viscosity; None otherwise)."""
    from .viscosity import Artificial

    if type(config.scheme.viscosity) is not Artificial or config.scheme.viscosity.approach_band > 0:
        return None

    def pullback(own, nb, d, r, params: Params, mask, fluid_j, g_r, g_j, g_p):
        f = params.fluid
        h = f.h
        F, dF_dr, dF_dh = _kernel(r, mask, params, config)
        r2 = r * r
        m_j, m_r = f.rho0 * nb["vol"], f.rho0 * own["vol"]
        rho_r, rho_j = own["rho"], nb["rho"]
        inv_rr = 1.0 / (rho_r * rho_j)
        psum = own["p"] + nb["p"]
        den = r2 + 0.01 * h * h
        vij = tuple(own[_V[a]] - nb[_V[a]] for a in range(3))
        vr = _dot(vij, d)
        mu = h * vr / den
        rs = rho_r + rho_j
        neg = vr < 0
        visc = jnp.where(fluid_j, 1.0, f.wall_viscosity)
        # Pi = k mu / rs for approaching pairs, k = -2 alpha c0 visc
        mu_rs = jnp.where(neg, mu / rs, 0.0)
        k = (-2.0 * f.alpha * f.c0) * visc
        pi = k * mu_rs
        Q = -psum * inv_rr - pi  # symmetric: acceleration of i is m_j Q F x_ij, of j is m_i Q F x_ji
        s_i = _dot(g_r, d)  # cotangent of fn(r, j) along x_rj
        s_j = -_dot(g_j, d)  # of fn(j, r) along x_jr = -d
        w = m_j * s_i + m_r * s_j
        Q_b = F * w
        mu_b = jnp.where(neg, -Q_b * k / rs, 0.0)
        vr_b = mu_b * h / den
        radial = -2.0 * mu_b * mu / den + _radial(Q * w, dF_dr, r, mask)
        QF = Q * F
        ct_d = tuple(QF * (m_j * g_r[a] - m_r * g_j[a]) + vr_b * vij[a] + radial * d[a] for a in range(3))
        ct_own = {"rho": Q_b * (psum * inv_rr / rho_r + pi / rs), "p": -inv_rr * Q_b, "vol": f.rho0 * QF * s_j,
                  **{_V[a]: vr_b * d[a] for a in range(3)}}
        # parameters: fn(r, j) only (each pair is some row's i once), L_i = m_j Q F s_p
        s_p = _dot(g_p, d)
        ms = m_j * s_p
        pi_b = -ms * F  # dL_i/dPi
        mu_h = (vr - 0.02 * h * mu) / den
        ct_params = _params_ct(
            params,
            h=ms * Q * dF_dh + pi_b * jnp.where(neg, k * mu_h / rs, 0.0),
            c0=pi_b * (-2.0 * f.alpha) * visc * mu_rs,
            alpha=pi_b * (-2.0 * f.c0) * visc * mu_rs,
            wall_viscosity=jnp.where(fluid_j, 0.0, pi_b * (-2.0 * f.alpha * f.c0) * mu_rs),
            rho0=nb["vol"] * QF * s_p)
        return ct_own, ct_d, ct_params

    return pullback


def continuity(config: Config) -> Optional[Callable]:
    """The pullback of ``wcsph._continuity_pair`` (``Fourtakas`` or ``NoDiffusion``; None otherwise)."""
    from .diffusion import Fourtakas, NoDiffusion

    dd = type(config.scheme.diffusion)
    if dd not in (Fourtakas, NoDiffusion):
        return None
    diffusion = dd is Fourtakas
    gamma = config.scheme.gamma

    def pullback(own, nb, d, r, params: Params, mask, fluid_j, g_r, g_j, g_p):
        f = params.fluid
        F, dF_dr, dF_dh = _kernel(r, mask, params, config)
        rho_r, rho_j = own["rho"], nb["rho"]
        V_j, V_r = f.rho0 * nb["vol"] / rho_j, f.rho0 * own["vol"] / rho_r
        vij = tuple(own[_V[a]] - nb[_V[a]] for a in range(3))
        vr = _dot(vij, d)  # the same from both ends
        (c_r,), (c_j,), (c_p,) = g_r, g_j, g_p
        A = c_r * rho_r * V_j + c_j * rho_j * V_r  # coefficient of vr F in both ends' terms
        L_F = A * vr  # dL/dF
        ct_rho = c_r * V_j * vr * F - c_j * V_r * rho_j * vr * F / rho_r
        ct_vol = c_j * rho_j * vr * F * f.rho0 / rho_r
        ct_d = [F * A * vij[a] for a in range(3)]
        h_b = c_p * rho_r * V_j * vr * dF_dh
        rho0_b = c_p * rho_r * vr * F * nb["vol"] / rho_j
        extra = {}
        if diffusion:
            # psi = (rho_j - rho_r) - H, H = rho0 g_dx / c0^2 P(e), g_dx = -g . d, e = (rho_r + rho_j) / (2 rho0) - 1
            g = params.gravity
            g_dx = -(d[0] * g[0] + d[1] * g[1] + d[2] * g[2])
            e = 0.5 * (rho_r + rho_j) / f.rho0 - 1.0
            P, dP = jax.jvp(lambda e: hydrostatic_power(e, gamma), (e,), (jnp.ones_like(e),))
            Hg = f.rho0 / f.c0**2 * P  # H / g_dx
            psi = (rho_j - rho_r) - Hg * g_dx
            D = -2.0 * f.delta * f.h * f.c0
            use = fluid_j  # the diffusion runs over fluid pairs (``fluid_j`` False: a wall or block end)
            c_jd = jnp.where(use, c_j, 0.0)
            B = jnp.where(use, c_r * V_j, 0.0) - c_jd * V_r  # fn(r, j) has + psi, fn(j, r) has -psi
            L_F = L_F + D * psi * B
            psi_b = D * B * F
            ct_rho = ct_rho + c_jd * V_r * D * psi * F / rho_r - psi_b * (1.0 + g_dx / (2.0 * f.c0**2) * dP)
            ct_vol = ct_vol - c_jd * D * psi * F * f.rho0 / rho_r
            ct_d = [ct_d[a] + psi_b * Hg * g[a] for a in range(3)]
            # parameters, from fn(r, j): c_p D V_j psi F
            q = jnp.where(use, c_p * V_j * F, 0.0)  # dL_i / d(D psi)
            H = Hg * g_dx
            h_b = h_b + jnp.where(use, c_p * V_j * D * psi, 0.0) * dF_dh + q * psi * D / f.h
            rho0_b = rho0_b + q * (D * psi / f.rho0 - D * g_dx / f.c0**2 * (P - (e + 1.0) * dP))
            extra = dict(c0=q * psi * D / f.c0 + q * D * 2.0 * H / f.c0, delta=q * psi * (-2.0 * f.h * f.c0))
            gravity = jnp.stack([jnp.sum(q * D * Hg * d[a]) for a in range(3)])
        else:
            gravity = None
        radial = _radial(L_F, dF_dr, r, mask)
        ct_d = tuple(ct_d[a] + radial * d[a] for a in range(3))
        A_F = A * F
        ct_own = {"rho": ct_rho, "vol": ct_vol, **{_V[a]: A_F * d[a] for a in range(3)}}
        return ct_own, ct_d, _params_ct(params, gravity=gravity, h=h_b, rho0=rho0_b, **extra)

    return pullback
