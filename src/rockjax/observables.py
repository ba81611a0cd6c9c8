"""Observables computed from a state (jittable): wave gauges, run-up, surge front, energies,
pressure probes; and host helpers on recorded frames (impact velocity).

Hard maxima here are for reporting; differentiable objectives use smooth versions
(``smooth_max``: log-sum-exp with a stated temperature).
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.scipy.special import logsumexp

from .sph.neighbours import min_image
from .types import Config, Kind, Params, State

__all__ = ["surge_front", "smooth_max", "energies", "probe_pressure", "fluid_mass", "gauge_elevation", "runup_kwargs",
           "runup", "smooth_runup", "block_energies", "impact_velocity", "scene_observer"]


def smooth_max(values, weights_mask, temperature):
    """``temperature * log(sum exp(values / temperature))`` over masked entries (>= the hard max)."""
    z = jnp.where(weights_mask, values / temperature, -jnp.inf)
    return temperature * logsumexp(z)


def surge_front(state: State, *, z_below: float, x_origin: float = 0.0) -> jnp.ndarray:
    """Largest x [m] of fluid particles lower than ``z_below`` [m], measured from ``x_origin``."""
    P = state.particles
    m = (P.kind == Kind.FLUID) & (P.x[:, 2] < z_below)
    return jnp.max(jnp.where(m, P.x[:, 0], -jnp.inf)) - x_origin


def fluid_mass(state: State, params: Params) -> jnp.ndarray:
    """Total fluid mass [kg] (particle masses rho0 * vol are constant)."""
    P = state.particles
    return jnp.sum(jnp.where(P.kind == Kind.FLUID, params.fluid.rho0 * P.vol, 0.0))


def energies(state: State, params: Params, config: Config) -> dict:
    """Kinetic, potential (relative to z = 0) and elastic (compression) energy of the fluid [J].

    The elastic energy is ``sum m_i e(rho_i)`` with ``e = int p / rho^2 d rho`` of the scheme's
    equation of state; kinetic + potential + elastic is conserved by the inviscid equations.
    """
    P = state.particles
    f = params.fluid
    fluid = P.kind == Kind.FLUID
    m = jnp.where(fluid, f.rho0 * P.vol, 0.0)
    kinetic = 0.5 * jnp.sum(m * jnp.sum(P.v * P.v, -1))
    potential = -jnp.sum(m * (P.x @ params.gravity))
    e = config.scheme.elastic_energy(P.rho, params)
    elastic = jnp.sum(m * e)
    return {"kinetic": kinetic, "potential": potential, "elastic": elastic, "total": kinetic + potential + elastic}


def probe_pressure(state: State, params: Params, config: Config, points) -> jnp.ndarray:
    """Shepard-interpolated fluid pressure [Pa] at probe points [M, 3] (brute force over particles)."""
    P = state.particles
    w_fn = config.scheme.kernel.w
    d = [min_image(points[:, None, a] - P.x[None, :, a], a, config.grid) for a in range(3)]
    r = jnp.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    fluid = P.kind == Kind.FLUID
    w = jnp.where(fluid[None, :], w_fn(r, params.fluid.h), 0.0) * P.vol[None, :]
    p = config.scheme.pressure(P, params)
    return jnp.sum(w * p[None, :], 1) / jnp.maximum(jnp.sum(w, 1), 1e-30)


def _wendland_2d(r, h):
    """2D Wendland C2 kernel, support 2h, integral over the plane = 1 [1/m^2]."""
    q = r / h
    return jnp.where(q < 2.0, 7.0 / (4.0 * jnp.pi * h * h) * (1.0 - 0.5 * q) ** 4 * (2.0 * q + 1.0), 0.0)


def gauge_elevation(state: State, params: Params, config: Config, points_xy, *, bottom_z, still_level,
                    radius=None) -> jnp.ndarray:
    """Free-surface elevation eta [m] above ``still_level`` at gauge points, smooth in the particles.

    The water depth over a point is the column integral of the particle volume field,
    ``depth(x, y) = sum_i V_i W2(|(x_i, y_i) - (x, y)|, h_g)`` with a 2D Wendland kernel of
    smoothing length ``h_g`` (``radius``, default the fluid h); ``eta = bottom_z + depth - still_level``.
    It is exact for a uniform column wider than the kernel, differentiable in the positions, and
    counts airborne spray over the gauge as water (as a capacitance gauge would not).

    Args:
        points_xy: [M, 2] gauge positions m. bottom_z: [M] or scalar bed elevation at the gauges m.
        still_level: still-water level m.
    Returns:
        [M] elevations m.
    """
    P = state.particles
    h = params.fluid.h if radius is None else radius
    pts = jnp.asarray(points_xy)
    d = [min_image(pts[:, None, a] - P.x[None, :, a], a, config.grid) for a in range(2)]
    r = jnp.sqrt(d[0] ** 2 + d[1] ** 2 + 1e-30)
    fluid = P.kind == Kind.FLUID
    V = jnp.where(fluid, P.vol * params.fluid.rho0 / P.rho, 0.0)
    depth = jnp.sum(V[None, :] * _wendland_2d(r, h), axis=1)
    return jnp.asarray(bottom_z) + depth - still_level


def _slope_weights(state: State, *, slope_point, slope_normal, band):
    P = state.particles
    n = jnp.asarray(slope_normal, P.x.dtype)
    n = n / jnp.linalg.norm(n)
    dist = (P.x - jnp.asarray(slope_point, P.x.dtype)) @ n  # height above the slope plane
    q = jnp.clip(dist / band, 0.0, 1.0)
    w = (1.0 - q) ** 3 * (1.0 + 3.0 * q)  # smooth: 1 on the plane, 0 beyond the band
    return jnp.where((P.kind == Kind.FLUID) & (dist > -band), w, 0.0)


def runup(state: State, *, slope_point, slope_normal, band, still_level, x_min=None) -> jnp.ndarray:
    """Run-up R [m]: the highest fluid particle within ``band`` [m] of the slope plane, above
    ``still_level`` (hard maximum, for reporting). The slope is the plane through ``slope_point``
    with upward unit normal ``slope_normal``; ``x_min`` keeps only particles with x >= x_min."""
    P = state.particles
    w = _slope_weights(state, slope_point=slope_point, slope_normal=slope_normal, band=band)
    m = w > 0
    if x_min is not None:
        m &= P.x[:, 0] >= x_min
    return jnp.max(jnp.where(m, P.x[:, 2], -jnp.inf)) - still_level


def smooth_runup(state: State, *, slope_point, slope_normal, band, still_level, temperature,
                 x_min=None) -> jnp.ndarray:
    """Differentiable run-up [m]: ``T log sum_i w_i exp(z_i / T)`` - still_level, with smooth
    weights ``w_i`` (1 on the slope, 0 at distance ``band``) and temperature ``T`` [m].

    It tends to the hard ``runup`` as T -> 0 and exceeds it by at most about T log(n_top), where
    n_top is the number of particles near the top; use T ~ dx/4 for gradients.
    """
    P = state.particles
    w = _slope_weights(state, slope_point=slope_point, slope_normal=slope_normal, band=band)
    if x_min is not None:
        w = jnp.where(P.x[:, 0] >= x_min, w, 0.0)
    z = jnp.where(w > 0, P.x[:, 2] / temperature + jnp.log(jnp.where(w > 0, w, 1.0)), -jnp.inf)
    return temperature * logsumexp(z) - still_level


def block_energies(state: State, params: Params, config: Config) -> dict:
    """Kinetic and potential energy [J] of the blocks that move (``rockjax.blocks.energies``)."""
    from . import blocks

    return blocks.energies(state.blocks, params.blocks, params.gravity, config.blocks)


def impact_velocity(times, block_x, block_v, *, block, still_level, bottom_offset):
    """Host helper on recorded frames: the velocity [3] m/s of ``block`` at the first frame where
    its lowest point (centroid z - ``bottom_offset``) is at or below ``still_level``; None if never.

    Args: times [F] s; block_x, block_v [F, B, 3] from ``Result.frames`` (``block_x``, ``block_v``).
    """
    import numpy as np

    z = np.asarray(block_x)[:, block, 2] - bottom_offset
    hit = np.nonzero(z <= still_level)[0]
    if hit.size == 0:
        return None
    return np.asarray(block_v)[hit[0], block]


def runup_kwargs(meta, *, band: float | None = None) -> dict:
    """The keywords of ``runup`` / ``smooth_runup`` for a scene's run-up slope (``meta.runup_slope``):
    ``slope_point``, ``slope_normal``, ``band`` (default 2 dx), ``still_level``, ``x_min``.
    ``meta``: a ``scenes.SceneMeta`` or a dict of its keys; a ValueError if it has no run-up slope."""
    from .scenes.meta import SceneMeta

    meta = SceneMeta.from_dict(meta)
    sl = meta.runup_slope
    if sl is None:
        raise ValueError(f"runup_kwargs: scene {meta.name!r} has no run-up slope (meta.runup_slope is None)")
    dx = float(meta.dx or 0.0)
    return dict(slope_point=jnp.asarray(sl.point), slope_normal=jnp.asarray(sl.normal),
                band=2.0 * dx if band is None else band,
                still_level=float(meta.still_level if meta.still_level is not None else 0.0), x_min=sl.x_min)


def scene_observer(meta, *, band: float | None = None, temperature: float | None = None):
    """``observe(state, params, config) -> dict`` for ``simulate(observe=...)`` from a scene's meta:
    ``gauges`` [M] m (free-surface elevation at ``meta["gauges"]``), ``runup`` (hard) and
    ``smooth_runup`` [m] on ``meta["runup_slope"]`` (band 2 dx, temperature dx/4 by default),
    the block centroids ``block_x`` [B, 3] m when the scene has blocks, and the energy budget [J]:
    ``fluid_kinetic``, ``fluid_potential``, ``fluid_elastic`` (``energies``), ``block_kinetic``,
    ``block_potential`` (moving blocks). ``meta``: a ``scenes.SceneMeta`` (``scene.meta``) or a dict
    of its keys (e.g. a run's meta read back from HDF5). Gauges and run-up absent from meta are skipped."""
    from .scenes.meta import SceneMeta

    meta = SceneMeta.from_dict(meta)
    dx = float(meta.dx or 0.0)
    still = float(meta.still_level if meta.still_level is not None else 0.0)
    temperature = 0.25 * dx if temperature is None else temperature

    def observe(state: State, params: Params, config: Config) -> dict:
        out = {}
        g = meta.gauges
        if g is not None and state.particles is not None:
            out["gauges"] = gauge_elevation(state, params, config, jnp.asarray(g.xy),
                                            bottom_z=jnp.asarray(g.bottom_z), still_level=still)
        if meta.runup_slope is not None and state.particles is not None:
            kw = runup_kwargs(meta, band=band)
            out["runup"] = runup(state, **kw)
            out["smooth_runup"] = smooth_runup(state, temperature=temperature, **kw)
        if state.particles is not None and params.fluid is not None:
            e = energies(state, params, config)
            out.update(fluid_kinetic=e["kinetic"], fluid_potential=e["potential"], fluid_elastic=e["elastic"])
        if state.blocks is not None:
            out["block_x"] = state.blocks.x
            e = block_energies(state, params, config)
            out.update(block_kinetic=e["kinetic"], block_potential=e["potential"])
        return out

    return observe
