"""Fluid-only built-in scenes: the dam break (Martin & Moyce 1952), the hydrostatic tank and a
linear progressive wave in a periodic box (``wave_box``: a scheme's wave damping and dispersion
without a wave maker).

Geometry: x along the tank, y across, z up; the tank floor is z = 0 and its back wall x = 0.
All lengths in metres.
"""

from __future__ import annotations

import math

import numpy as np

from ..sph.schemes import WCSPH, FluidScheme, SeedScheme
from .base import (GRAVITY, Resolution, Scene, _positive, as_scheme, fluid_scene, lattice, scheme_resolution,
                   tank_walls, whole_layers)

__all__ = ["dam_break", "hydrostatic_tank", "wave_box"]


def _scheme_defaults(scheme, alpha, nu):
    """The scheme object and the viscosity constants a scheme defaults to: alpha 0.02 and
    nu 1e-6 m^2/s with WCSPH; the seed scheme's Eq 18 is its only dissipation, so 0 and 1e-3."""
    scheme = as_scheme(scheme)
    if not isinstance(scheme, FluidScheme):
        raise ValueError(f"scheme must be a fluid scheme (rockjax.WCSPH(...), rockjax.SeedScheme(...)) or its name; got {scheme!r}")
    seed = isinstance(scheme, SeedScheme)
    if alpha is None:
        alpha = 0.0 if seed else 0.02
    if nu is None:
        nu = 1e-3 if seed else 1e-6
    return scheme, alpha, nu


def dam_break(*, dx: float = 0.5 / 14, column_length: float = 0.5, column_width: float = 0.5,
              column_height: float = 1.0, tank_length: float = 2.0, tank_width: float = 1.0,
              tank_height: float | None = None, periodic_y: bool = False,
              scheme: FluidScheme | str = WCSPH(), h_factor: float | None = None, c0: float | None = None, alpha: float | None = None, nu: float | None = None,
              delta: float = 0.1, wall_viscosity: float = 1.0, skin_factor: float | None = None, rebuild_every: int = 8,
              cfl: float | None = None) -> Scene:
    """A water column collapsing in a tank (3D; with ``periodic_y`` a 2D slab).

    The column occupies ``[0, column_length] x [0, column_width] x [0, column_height]`` in the
    corner of the tank ``[0, tank_length] x [0, tank_width]`` (open top). The default is the
    3D case of the peer comparison (0.5 x 0.5 x 1.0 m column, 2.0 x 1.0 m tank, ~5.5k particles).
    With ``periodic_y=True`` the column spans the tank width and y is periodic, which runs
    Martin & Moyce's 2D experiment as a thin slab of the 3D code.

    Args:
        dx: particle spacing [m].
        scheme: the fluid scheme and its terms (``WCSPH(...)`` default, ``SeedScheme(...)``, or a
            name: ``"wcsph"``, ``"seed"``).
        c0: speed of sound [m/s]; default 10 sqrt(2 g column_height).
        alpha / nu: artificial viscosity [-] / kinematic viscosity [m^2/s]; defaults depend on
            the scheme (WCSPH 0.02 / 1e-6; seed 0 / 1e-3, as its Eq 18 is its only dissipation).
        wall_viscosity: factor on the viscous term towards wall particles (0 = free-slip walls).
        h_factor: smoothing length / dx; cfl: the CFL number of the time step; skin_factor:
            Verlet skin / dx. None: the scheme's (``scheme_resolution``): 1.3, 0.25 and 0.3 with
            WCSPH (with the driver's displacement-triggered rebuilds the thinner lists, K 120
            instead of 160 at skin 0.6, outweigh the more frequent rebuilds,
            ``experiments/bench_skin.py``), 1.0, 0.4 and 0.05 with DFSPH (rebuilt every step at
            its time step). A rollout without the trigger, e.g. a vmapped ensemble, needs a skin
            covering ``rebuild_every`` steps of motion.
    """
    dx = _positive("dam_break: dx", dx)
    for name, val in (("column_length", column_length), ("column_width", column_width),
                      ("column_height", column_height), ("tank_length", tank_length), ("tank_width", tank_width)):
        _positive(f"dam_break: {name}", val)
    if column_length > tank_length:
        raise ValueError(f"dam_break: column_length ({column_length} m) must not exceed tank_length ({tank_length} m)")
    if periodic_y:
        column_width = tank_width
    elif column_width > tank_width:
        raise ValueError(f"dam_break: column_width ({column_width} m) must not exceed tank_width ({tank_width} m)")
    if min(column_length, column_width, column_height) < 2 * dx:
        raise ValueError(f"dam_break: dx = {dx} m is too coarse for the column; use dx <= {min(column_length, column_width, column_height) / 4:.4g} m")
    tank_height = 1.5 * column_height if tank_height is None else _positive("dam_break: tank_height", tank_height)
    scheme, alpha, nu = _scheme_defaults(scheme, alpha, nu)
    h_factor, cfl, skin_factor = scheme_resolution(scheme, h_factor, cfl, skin_factor)
    c0 = 10.0 * math.sqrt(2 * GRAVITY * column_height) if c0 is None else _positive("dam_break: c0", c0)
    layers = Resolution(dx, h_factor).wall_layers
    periodic = (False, bool(periodic_y), False)
    lo = np.array([0.0, 0.0, 0.0])
    hi = np.array([tank_length, tank_width, tank_height])
    fluid = lattice(lo, [column_length, column_width, column_height], dx)
    walls = tank_walls(lo, hi, dx, layers, periodic=periodic, open_top=True)
    pad = layers * dx
    dom_lo = [-pad, 0.0 if periodic_y else -pad, -pad]
    dom_hi = [tank_length + pad, tank_width if periodic_y else tank_width + pad, tank_height + 2 * column_height]
    meta = dict(column_length=column_length, column_width=column_width, column_height=column_height,
                tank_length=tank_length, tank_width=tank_width, tank_height=tank_height, periodic_y=periodic_y)
    return fluid_scene(name="dam_break", dx=dx, fluid_x=fluid, wall_x=walls, domain_lo=dom_lo, domain_hi=dom_hi,
                       periodic=periodic, surface_z=column_height, c0=c0, scheme=scheme, h_factor=h_factor, alpha=alpha, nu=nu,
                       delta=delta, wall_viscosity=wall_viscosity, skin_factor=skin_factor, rebuild_every=rebuild_every,
                       cfl=cfl, meta=meta)


def hydrostatic_tank(*, dx: float = 0.02, length: float = 0.2, width: float = 0.2, depth: float = 0.2,
                     periodic_xy: bool = False, scheme: FluidScheme | str = WCSPH(), h_factor: float | None = None,
                     c0: float | None = None, alpha: float | None = None, nu: float | None = None,
                     delta: float = 0.1, wall_viscosity: float = 1.0, skin_factor: float | None = None, rebuild_every: int = 8,
                     cfl: float | None = None) -> Scene:
    """Still water of ``depth`` [m] in a closed-bottom tank ``length x width`` [m] (open top).

    Initial densities follow the hydrostatic pressure ``rho0 g (depth - z)`` (WCSPH).
    With ``periodic_xy`` the side walls are replaced by periodic axes (an infinite layer).
    """
    dx = _positive("hydrostatic_tank: dx", dx)
    for name, val in (("length", length), ("width", width), ("depth", depth)):
        _positive(f"hydrostatic_tank: {name}", val)
    if depth < 3 * dx:
        raise ValueError(f"hydrostatic_tank: depth ({depth} m) must hold at least 3 particle layers; use dx <= {depth / 3:.4g} m")
    scheme, alpha, nu = _scheme_defaults(scheme, alpha, nu)
    h_factor, cfl, skin_factor = scheme_resolution(scheme, h_factor, cfl, skin_factor)
    c0 = 10.0 * math.sqrt(2 * GRAVITY * depth) if c0 is None else _positive("hydrostatic_tank: c0", c0)
    layers = Resolution(dx, h_factor).wall_layers
    periodic = (bool(periodic_xy), bool(periodic_xy), False)
    lo = np.array([0.0, 0.0, 0.0])
    hi = np.array([length, width, depth + 0.5 * depth])
    fluid = lattice(lo, [length, width, depth], dx)
    walls = tank_walls(lo, hi, dx, layers, periodic=periodic, open_top=True)
    pad = layers * dx
    dom_lo = [0.0 if periodic_xy else -pad, 0.0 if periodic_xy else -pad, -pad]
    dom_hi = [length if periodic_xy else length + pad, width if periodic_xy else width + pad, 2.0 * depth]
    meta = dict(length=length, width=width, depth=depth, periodic_xy=periodic_xy)
    return fluid_scene(name="hydrostatic_tank", dx=dx, fluid_x=fluid, wall_x=walls, domain_lo=dom_lo, domain_hi=dom_hi,
                       periodic=periodic, surface_z=depth, c0=c0, scheme=scheme, h_factor=h_factor, alpha=alpha, nu=nu,
                       delta=delta, wall_viscosity=wall_viscosity, skin_factor=skin_factor, rebuild_every=rebuild_every,
                       cfl=cfl, meta=meta)


def wave_box(*, dx: float = 0.03, depth: float = 0.3, kd: float = 1.0, amplitude: float = 0.02, gauges: int = 64,
             scheme: FluidScheme | str = WCSPH(), h_factor: float | None = 1.5, c0: float | None = None,
             alpha: float | None = None, nu: float | None = None, delta: float = 0.1, wall_viscosity: float = 1.0,
             cfl: float | None = None, settle: float = 0.0) -> Scene:
    """One wavelength of water ``depth`` [m] deep, periodic in x and y over a wall bed (z = 0),
    started as a linear (Airy) progressive wave of ``amplitude`` a [m] travelling towards +x.

    The length is the whole number of ``dx`` nearest ``2 pi depth / kd`` (``meta["k"]`` is the wave
    number it gives); ``depth`` must be a whole number of ``dx``. Every particle at rest height ``z``
    above the bed is moved along its linear orbit, ``xi = -a cosh(kz) / sinh(kd) sin(kx)``,
    ``zeta = a sinh(kz) / sinh(kd) cos(kx)``, given the orbit velocity ``a omega (cosh(kz) cos(kx),
    0, sinh(kz) sin(kx)) / sinh(kd)`` and (WCSPH) the density of linear theory's pressure at its
    displaced position. The first Fourier mode of the ``gauges`` surface elevations
    (``meta["gauges"]``, evenly across the box at mid-width) then rotates at the dispersion
    relation's ``omega = sqrt(g k tanh kd)`` (``meta["omega"]``) and decays at the scheme's damping:
    what a wave flume loses per wavelength, without its paddle and beach
    (``experiments/wave_box.py``). Defaults: the wave flumes' h = 1.5 dx and c0 = 15 sqrt(g depth).

    ``settle`` [s] > 0 first relaxes the still water (``scenes.settle``) and starts the wave from
    the relaxed particles (their positions as rest positions, their densities plus linear theory's
    change): a cubic lattice is not the discrete equilibrium, and in a wave it rearranges, with
    sideways motion growing from round-off.
    """
    import jax.numpy as jnp

    from ..types import Kind

    dx = _positive("wave_box: dx", dx)
    for name, val in (("depth", depth), ("kd", kd), ("amplitude", amplitude)):
        _positive(f"wave_box: {name}", val)
    whole_layers("wave_box", "depth", depth, dx, "the gauges and the wave")
    if not (isinstance(gauges, int) and gauges >= 4):
        raise ValueError(f"wave_box: gauges must be an integer >= 4 (got {gauges!r})")
    n_x = int(round(2 * math.pi * depth / kd / dx))
    L = n_x * dx
    k = 2 * math.pi / L
    if amplitude * k > 0.3 or amplitude > 0.5 * depth:
        raise ValueError(f"wave_box: amplitude = {amplitude} m is not a linear wave here (k a = {k * amplitude:.3g}, "
                         f"a / depth = {amplitude / depth:.3g}); use k a <= 0.3 and a <= depth / 2")
    scheme = as_scheme(scheme)
    hf = scheme_resolution(scheme, h_factor, cfl)[0]
    width = math.ceil(2 * (2 * hf + 0.6) - 1e-9) * dx  # the narrowest periodic width its list allows (2 h support, skin)
    scene = hydrostatic_tank(dx=dx, length=L, width=width, depth=depth, periodic_xy=True, scheme=scheme,
                             h_factor=h_factor, c0=15.0 * math.sqrt(GRAVITY * depth) if c0 is None else c0,
                             alpha=alpha, nu=nu, delta=delta, wall_viscosity=wall_viscosity, cfl=cfl)
    if not (settle >= 0 and math.isfinite(settle)):
        raise ValueError(f"wave_box: settle must be a time >= 0 s (got {settle!r})")
    if settle > 0:
        from .settle import settle as _settle

        scene = _settle(scene, t_settle=float(settle))
    P = scene.state.particles
    x, v, rho = np.array(P.x), np.array(P.v), np.array(P.rho)
    fluid = np.asarray(P.kind) == Kind.FLUID
    omega = math.sqrt(GRAVITY * k * math.tanh(k * depth))
    z = x[fluid, 2]
    ch, sh = np.cosh(k * z) / math.sinh(k * depth), np.sinh(k * z) / math.sinh(k * depth)
    s, c = np.sin(k * x[fluid, 0]), np.cos(k * x[fluid, 0])
    zd = z + amplitude * sh * c
    v[fluid, 0] = amplitude * omega * ch * c
    v[fluid, 2] = amplitude * omega * sh * s
    rho0, c0_ = float(scene.params.fluid.rho0), float(scene.params.fluid.c0)
    p = rho0 * GRAVITY * (depth - zd) + rho0 * GRAVITY * amplitude * np.cosh(k * z) / math.cosh(k * depth) * c
    dens = scheme.initial_density(p, rho0=rho0, c0=c0_)
    if dens is not None and settle > 0:  # the relaxed densities plus the wave's change
        rho[fluid] = rho[fluid] + dens - scheme.initial_density(rho0 * GRAVITY * (depth - z), rho0=rho0, c0=c0_)
    elif dens is not None:
        rho[fluid] = dens
    x[fluid, 0] = np.mod(x[fluid, 0] - amplitude * ch * s, L)
    x[fluid, 2] = zd
    P = P.replace(x=jnp.asarray(x, P.x.dtype), v=jnp.asarray(v, P.v.dtype), rho=jnp.asarray(rho, P.rho.dtype))
    gx = (np.arange(gauges) + 0.5) * L / gauges
    meta = scene.meta.with_items(name="wave_box", kd=k * depth, k=k, omega=omega, amplitude=amplitude,
                                 wavelength=L, still_level=depth,
                                 gauges=dict(names=[f"x={g:.3f}" for g in gx],
                                             xy=[[float(g), 0.5 * width] for g in gx], bottom_z=[0.0] * gauges))
    return scene.replace(state=scene.state.replace(particles=P), meta=meta)
