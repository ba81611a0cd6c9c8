"""Scenes with rock blocks: the seed's sliding wedge and piston wave maker, a jointed rock slope
(blocks cut from joint sets), a floating box, a block dropped into a tank, and a blocks-only
incline.

Geometry conventions (SI units, z up): the still-water level is z = 0 unless said otherwise.
``sliding_wedge``: the slide slope's surface passes through the origin and descends along +x at
``slope_angle_deg``; the floor is z = -water_depth; a far beach rises at ``far_slope_deg`` at the
end of a flat of ``flat_length``; the flume spans y in [0, width] between side walls.

Every builder returns a ``Scene`` whose ``Config`` switches on only what it needs: a blocks-only
scene has no particles (no SPH is traced); a scene whose blocks are all fixed has no coupling.
"""

from __future__ import annotations

import math
from typing import Sequence

import jax.numpy as jnp
import numpy as np

from ..sph.schemes import WCSPH, FluidScheme
from ..sph.viscosity import Laminar
from ..types import Capacities, Config, Coupling, CouplingParams, State, float_dtype
from .base import GRAVITY, Resolution, Scene, _ceil8, whole_layers, _density, _lengths, _positive, as_scheme, make_state, particle_layout, scheme_resolution, stable_dt, water_params
from .block_sampling import sample_block_particles, submerged_pair_count
from .meta import SceneMeta
from .shapes import fill, plane, shell

__all__ = ["coupled_scene", "sliding_wedge", "rock_slope", "floating_box", "block_drop", "piston_wavemaker", "block_on_incline",
           "sample_block_particles", "coupling_params"]


#: WCSPH's time step on a coupled scene's default resolution, in dx / c0 (cfl 0.25 x h 1.3 dx): the
#: block step ``coupled_scene`` keeps when a fluid scheme takes longer steps (``block_substeps``).
ACOUSTIC_STEP = 0.25 * 1.3


def coupling_params(*, dx: float, c0: float, stiffness: float | None = None, damping: float | None = None,
                    interaction_distance: float | None = None,
                    coupling: Coupling = Coupling.PENALTY) -> CouplingParams:
    """Seed Eq 22 constants for resolution ``dx`` [m] and sound speed ``c0`` [m/s].

    Defaults: ``r0 = dx / 2`` (half the particle spacing: a particle at rest against a face then
    fills the space up to it, as a lattice particle of volume dx^3 would, so the displaced volume
    -- hence buoyancy -- is unbiased); with ``Coupling.BOUNDARY_PARTICLES``, where the penalty is
    only a guard (``Config.coupling_guard``), and with ``Coupling.BOUNDARY_INTEGRAL``, where the wall
    term carries the pressure, ``r0 = dx / 4``: water at rest stays ~dx/2 from a
    face (a spacing from the block's outer particle layer, dx/2 deep), so the guard acts only on
    water pressed closer; ``K_S = (2 c0 / dx)^2`` [1/s^2], so a particle arriving
    at the flow's largest speed (~c0 / 10) stops within ~r0 / 10 and the penalty oscillation
    ``sqrt(K_S) dt`` stays ~0.65 at the fluid's Courant step; ``K_D = sqrt(K_S)`` [1/s] (half of
    critical damping).
    """
    r0_default = 0.5 * dx if coupling == Coupling.PENALTY else 0.25 * dx  # the others: a guard
    r0 = r0_default if interaction_distance is None else _positive("interaction_distance", interaction_distance)
    ks = (2.0 * c0 / dx) ** 2 if stiffness is None else _positive("penalty stiffness", stiffness)
    kd = math.sqrt(ks) if damping is None else float(damping)
    if kd < 0:
        raise ValueError(f"coupling: penalty damping must be >= 0 (got {kd})")
    t = float_dtype()
    return CouplingParams(penalty_stiffness=jnp.asarray(ks, t), penalty_damping=jnp.asarray(kd, t),
                          interaction_distance=jnp.asarray(r0, t))


def _blocks_api():
    from .. import blocks

    return blocks


def coupled_scene(*, name: str, dx: float | None, polyhedra: Sequence, positions, motion, block_density,
                  friction_angle_deg: float, fluid_x: np.ndarray | None = None, wall_x: np.ndarray | None = None,
                  domain_lo=None, domain_hi=None, periodic=(False, False, False), still_level: float | None = None,
                  coupling: Coupling = Coupling.PENALTY, c0: float | None = None, h_factor: float = 1.3,
                  alpha: float = 0.02, nu: float = 1e-6, delta: float = 0.1, wall_viscosity: float = 1.0,
                  skin_factor: float = 0.6,
                  rebuild_every: int = 8, cfl: float = 0.25, scheme: FluidScheme | str = WCSPH(),
                  velocities=None, joint_water: bool = False, coupling_guard: bool = True, guard_fixed: bool = False,
                  block_kwargs: dict | None = None, meta: dict | None = None, block_substeps: int | None = None) -> Scene:
    """Assemble a scene of water (optional) and blocks from host data.

    Args:
        polyhedra, positions, motion: the blocks (``blocks.geometry`` shapes placed at their
            centroids [B, 3] m; ``blocks.Motion`` per block).
        block_density: [B] or scalar kg/m^3. friction_angle_deg: joint friction angle (degrees).
        fluid_x / wall_x: [n, 3] water and fixed-wall particles (None: a blocks-only scene).
        still_level: initial free surface z [m] for hydrostatic densities.
        coupling: how the water and the moving blocks exchange forces.
        joint_water: block faces pressed together (a block on a slope or a floor) carry the
            hydrostatic pressure of water at ``still_level`` (``blocks.joint_water``): the water
            the particles cannot put into a joint thinner than dx. Needs ``still_level``. The
            joint aperture is dx/2 (faces closer than that carry it, fading out as they part);
            ``block_kwargs`` may override ``joint_water_level`` / ``joint_aperture``.
        coupling_guard: with boundary particles, the seed Eq 22 penalty within dx/4 of a face as
            well (``Config.coupling_guard``): no water pressed into a block between its particles.
        guard_fixed: with that guard, the FIXED blocks' faces too (``Config.guard_fixed``, off by
            default: ~0.2 ms/step per fixed block at 4.3k water particles).
        block_kwargs: extra keywords for ``blocks.make_blocks`` (stiffness, damping, ...).
        block_substeps: block steps per fluid step (``Config.block_substeps``): the rock contact
            stiffness is softened only as far as the block step ``dt / block_substeps`` needs.
            None: 1, or with a fluid step over twice WCSPH's acoustic one on this scene
            (``ACOUSTIC_STEP dx / c0``; DFSPH: ~12x) as many as make the block step that one, so
            the rocks keep the stiffness they have with WCSPH. With such a step the penalty
            coupling's (or guard's) stiffness is lowered to ``(0.65 / dt)^2``.
    """
    if block_substeps is not None and not (isinstance(block_substeps, int) and block_substeps >= 1):
        raise ValueError(f"{name}: block_substeps must be an integer >= 1 (got {block_substeps!r})")
    blocks = _blocks_api()
    B = len(polyhedra)
    if joint_water:
        if still_level is None:
            raise ValueError(f"{name}: joint_water needs still_level (the water level whose pressure the joints carry)")
        jw = dict(joint_water=True, joint_water_level=float(still_level), joint_water_density=1000.0)
        if dx is not None:  # no particle fits in a gap below ~dx: a joint up to dx/2, faded out
            jw["joint_aperture"] = 0.5 * float(dx)
        block_kwargs = {**jw, **(block_kwargs or {})}  # the caller's keywords win
    density = np.broadcast_to(np.asarray(block_density, float), (B,))
    bconfig, bparams, bstate = blocks.make_blocks(
        list(polyhedra), positions=np.asarray(positions, float), motion=tuple(motion), velocities=velocities,
        density=density, friction_angle_deg=friction_angle_deg, **(block_kwargs or {}))
    meta = dict(meta or {}, name=name, dx=dx)
    moving = [i for i, m in enumerate(motion) if m != blocks.Motion.FIXED]
    if fluid_x is None:
        gravity = jnp.asarray([0.0, 0.0, -GRAVITY], float_dtype())
        from ..types import Params

        params = Params(gravity=gravity, blocks=bparams)
        dt = float(blocks.stable_dt(bconfig, bparams, bstate))
        config = Config(n_fluid=0, n_wall=0, dt=dt, grid=None, cutoff=0.0, skin=0.0, rebuild_every=1, blocks=bconfig)
        state = State(step=jnp.zeros((), jnp.int32), particles=None, nbrs=None, status=jnp.zeros((), jnp.int32),
                      blocks=bstate)
        return Scene(config=config, params=params, state=state, meta=SceneMeta.from_dict(meta))

    dx = _positive(f"{name}: dx", dx)
    if not moving:
        coupling = Coupling.NONE
    coupling = Coupling(coupling)
    scheme = as_scheme(scheme)
    if c0 is None:
        raise ValueError(f"{name}: c0 (speed of sound) is required for a scene with water")
    res = Resolution(dx, h_factor)
    scheme.check_resolution(res.h_factor)
    params = water_params(res, c0=c0, alpha=alpha, nu=nu, delta=delta, wall_viscosity=wall_viscosity)
    params = params.replace(blocks=bparams)
    layers = res.wall_layers
    wall_x = np.zeros((0, 3)) if wall_x is None else np.asarray(wall_x, float)
    body = np.full(len(wall_x), -1)
    x_body = np.zeros((len(wall_x), 3))
    if coupling == Coupling.BOUNDARY_PARTICLES:
        from ..blocks.rotation import quat_matrix

        R = np.asarray(quat_matrix(jnp.asarray(bstate.q)))
        X = np.asarray(bstate.x)
        extra, bodies, xb, vb = [], [], [], []
        for b in moving:
            pts, v = sample_block_particles(polyhedra[b], dx, layers, volumes=True)
            extra.append(pts @ R[b].T + X[b])
            bodies.append(np.full(len(pts), b))
            xb.append(pts)
            vb.append(v)
        n_fixed_walls = len(wall_x)
        wall_x = np.concatenate([wall_x] + extra)
        body = np.concatenate([body] + bodies)
        x_body = np.concatenate([x_body] + xb)
    if coupling != Coupling.NONE:
        params = params.replace(coupling=coupling_params(dx=dx, c0=c0, coupling=coupling))
    L = particle_layout(res, fluid_x=fluid_x, wall_x=wall_x, domain_lo=domain_lo, domain_hi=domain_hi,
                        periodic=periodic, surface_z=still_level, c0=c0, scheme=scheme, skin_factor=skin_factor)
    vol = L.vol
    if coupling == Coupling.BOUNDARY_PARTICLES:  # each block particle: its share of the block's shell
        vol = vol.copy()
        vol[len(fluid_x) + n_fixed_walls:] = np.concatenate(vb)
    body_pair_capacity = n_block_particles = 0
    if coupling == Coupling.BOUNDARY_PARTICLES:
        # the pairs each block has fully under still water, +25 % for compressed or disordered
        # water (the driver grows the sub-list if a scene needs more)
        pairs_b = sum(submerged_pair_count(polyhedra[b], pts_b, dx, L.cutoff + L.skin) for b, pts_b in zip(moving, xb))
        body_pair_capacity = min(_ceil8(1.25 * pairs_b), L.wall_pair_capacity)
        n_block_particles = len(wall_x) - n_fixed_walls  # the walls' tail (sorted apart at each list build)
    dt = stable_dt(params, scheme=scheme, cfl=cfl)
    n_sub = block_substeps
    ratio = dt / (ACOUSTIC_STEP * dx / c0)
    if coupling == Coupling.PENALTY and ratio > 2.0:
        raise ValueError(f"{name}: coupling = penalty needs the acoustic time step (seed Eq 22's spring stops water "
                         f"within dx/2 only at dt ~ 0.3 dx / c0); scheme {scheme.name!r} steps {ratio:.0f}x longer: "
                         "use coupling=Coupling.BOUNDARY_PARTICLES (command line: --coupling boundary_particles)")
    if n_sub is None:  # more than twice WCSPH's step: the block steps that make its step
        n_sub = math.ceil(ratio - 1e-3) if ratio > 2.0 else 1
    dt_blocks = float(blocks.stable_dt(bconfig, bparams, bstate))
    if dt_blocks < dt / n_sub and "normal_stiffness" not in (block_kwargs or {}):
        # The rock penalty stiffness only has to keep block overlaps small; soften it so the blocks
        # do not force a smaller block step than dt / block_substeps (dt ~ 1/sqrt(k)).
        k_rock = float(bparams.normal_stiffness) * (dt_blocks * n_sub / dt) ** 2 * 0.98
        bconfig, bparams, bstate = blocks.make_blocks(
            list(polyhedra), positions=np.asarray(positions, float), motion=tuple(motion), velocities=velocities,
            density=density, friction_angle_deg=friction_angle_deg, normal_stiffness=k_rock,
            **(block_kwargs or {}))
        params = params.replace(blocks=bparams)
        dt_blocks = float(blocks.stable_dt(bconfig, bparams, bstate))
    dt = min(dt, n_sub * dt_blocks)
    meta["block_normal_stiffness"] = float(bparams.normal_stiffness)
    if coupling != Coupling.NONE and float(params.coupling.penalty_stiffness) * dt**2 > 1.5 * 0.65**2:
        # a fluid step longer than the acoustic one (DFSPH): the seed Eq 22 penalty (or the guard)
        # is integrated with the fluid's dt, so its oscillation sqrt(K_S) dt is held at 0.65
        params = params.replace(coupling=coupling_params(dx=dx, c0=c0, coupling=coupling, stiffness=(0.65 / dt) ** 2))
    config = Config(n_fluid=len(fluid_x), n_wall=len(wall_x), dt=dt, grid=L.grid, cutoff=L.cutoff, skin=L.skin,
                    rebuild_every=rebuild_every,
                    capacities=Capacities(neighbours=L.neighbour_capacity, cells=L.cell_capacity,
                                          wall_pairs=L.wall_pair_capacity, body_pairs=body_pair_capacity),
                    n_block_particles=n_block_particles, scheme=scheme, cfl=cfl, blocks=bconfig, coupling=coupling,
                    block_substeps=n_sub,
                    coupling_guard=bool(coupling_guard), guard_fixed=bool(guard_fixed))
    state = make_state(config=config, x=L.x, kind=L.kind, vol=vol, rho=L.rho)
    if coupling == Coupling.BOUNDARY_PARTICLES:
        body_all = np.concatenate([np.full(len(fluid_x), -1), body]).astype(np.int32)
        xb_all = np.concatenate([np.zeros((len(fluid_x), 3)), x_body])
        state = state.replace(particles=state.particles.replace(body=jnp.asarray(body_all),
                                                                x_body=jnp.asarray(xb_all, float_dtype())))
    if coupling != Coupling.NONE:
        from ..types import CouplingState

        zero = jnp.zeros((B, 3), float_dtype())
        state = state.replace(coupling=CouplingState(force=zero, torque=zero))
    state = state.replace(blocks=bstate)
    return Scene(config=config, params=params, state=state, meta=SceneMeta.from_dict(meta))


def _flume_walls_and_water(*, dx, layers, halfspaces, water_halfspaces, lo, hi):
    """Water where all ``water_halfspaces`` hold; walls in the shell of the container."""
    pad = layers * dx
    water = fill(lo, hi, dx, water_halfspaces)
    walls = shell(np.asarray(lo) - pad, np.asarray(hi) + pad, dx, halfspaces, layers)
    return water, walls


def _check_slide_flume(name, *, dx, slope_angle_deg, far_slope_deg, water_depth, flume_width, width) -> None:
    """Refuse what ``_slide_flume`` cannot build (ValueError naming ``name``'s option): slopes outside
    [5, 60] degrees, a slide ``width = (option, value, what)`` leaving < 1 dx beside it in the flume,
    a depth of fewer than 4 particles or not a whole number of dx (``base.whole_layers``)."""
    for key, angle in (("slope_angle_deg", slope_angle_deg), ("far_slope_deg", far_slope_deg)):
        if not 5.0 <= angle <= 60.0:
            raise ValueError(f"{name}: {key} must be in [5, 60] degrees (got {angle})")
    key, value, what = width
    if value > flume_width - 2 * dx + 1e-9:
        raise ValueError(f"{name}: {key} ({value} m) must leave >= 1 dx on each side in the flume "
                         f"(flume_width {flume_width} m); make the flume wider or the {what} narrower")
    if water_depth < 4 * dx:
        raise ValueError(f"{name}: water_depth must hold >= 4 particles; use dx <= {water_depth / 4:.4g} m")
    whole_layers(name, "water_depth", water_depth, dx, "the still level (gauges, run-up)")


def _slide_flume(*, dx, slope_angle_deg, water_depth, flat_length, far_slope_deg, flume_width, up, reach, z_top,
                 h_factor) -> dict:
    """The flume of a slide into water (``sliding_wedge``, ``rock_slope``): the slide slope's
    surface through the origin descending along +x, its FIXED slope block spanning ``up`` [m]
    above the shoreline (along the slope) to past the toe (+ 2 ``reach``), the floor z =
    -water_depth, the far beach after ``flat_length``, side walls at y = 0 and ``flume_width``,
    open up to ``z_top``. Returns the slope and floor blocks with their positions, the water and
    wall particles, the domain, ``x_toe``, ``x_beach`` and the observers' meta (three gauges on the
    flat, run-up on the beach)."""
    blocks = _blocks_api()
    geo = blocks.geometry
    th = math.radians(slope_angle_deg)
    be = math.radians(far_slope_deg)
    t_ = math.tan(th)
    s_dir = np.array([math.cos(th), 0.0, -math.sin(th)])  # down-slope
    x_toe = water_depth / t_
    x_beach = x_toe + flat_length
    thick = max(0.2, 4 * dx)
    # the slope block's top face passes through the origin; slide it along the slope so that it
    # spans from above the slide's start down past the toe
    down = water_depth / math.sin(th)
    slope_len = up + down + 2 * reach
    slope_blk = geo.slope(slope_len, flume_width, thick, slope_angle_deg)
    slope_pos = slope_blk.centroid_world + np.array([0.0, 0.5 * flume_width, 0.0]) + 0.5 * (down - up) * s_dir
    floor_len = flat_length + 2 * x_toe
    floor = geo.slab(floor_len, flume_width, thick)
    floor_pos = floor.centroid_world + np.array([x_toe + 0.5 * flat_length, 0.5 * flume_width, -water_depth])
    n_slope = np.array([math.sin(th), 0.0, math.cos(th)])
    n_beach = np.array([-math.sin(be), 0.0, math.cos(be)])
    x_left = -(z_top / t_) - 2 * dx
    x_right = x_beach + (z_top + water_depth) / math.tan(be) + 2 * dx
    container = [
        plane(-n_slope, [0.0, 0.0, 0.0]), plane(-n_beach, [x_beach, 0.0, -water_depth]),
        plane([0, 0, -1], [0, 0, -water_depth]), plane([0, -1, 0], [0, 0, 0]), plane([0, 1, 0], [0, flume_width, 0]),
        plane([1, 0, 0], [x_right, 0, 0]), plane([-1, 0, 0], [x_left, 0, 0]),
    ]
    water_hs = container + [plane([0, 0, 1], [0, 0, 0])]
    layers = Resolution(dx, h_factor).wall_layers
    # lattice aligned so that the floor (z = -depth) and the side walls fall on cell faces
    lo = np.array([x_left, 0.0, -water_depth])
    n_up = math.ceil((z_top + water_depth) / dx)
    hi = np.array([x_left + math.ceil((x_right - x_left) / dx) * dx, flume_width, -water_depth + n_up * dx])
    water, walls = _flume_walls_and_water(dx=dx, layers=layers, halfspaces=container, water_halfspaces=water_hs,
                                          lo=lo, hi=hi)
    pad = layers * dx
    observers = dict(runup_slope=dict(point=[x_beach, 0.5 * flume_width, -water_depth], normal=n_beach.tolist(),
                                      x_min=x_beach),
                     gauges=dict(names=["near", "middle", "far"],
                                 xy=[[x_toe + 0.2 * flat_length, 0.5 * flume_width],
                                     [x_toe + 0.5 * flat_length, 0.5 * flume_width],
                                     [x_toe + 0.8 * flat_length, 0.5 * flume_width]],
                                 bottom_z=[-water_depth] * 3))
    return dict(slope=slope_blk, slope_pos=slope_pos, floor=floor, floor_pos=floor_pos, water=water, walls=walls,
                domain_lo=lo - pad, domain_hi=hi + pad + np.array([0, 0, 2 * z_top]), x_toe=x_toe, x_beach=x_beach,
                observers=observers)


def sliding_wedge(*, dx: float = 0.02, slope_angle_deg: float = 25.0, block_density: float = 2500.0,
                  friction_angle_deg: float = 15.0, block_length: float = 0.4, block_width: float = 0.2,
                  water_depth: float = 0.4, flat_length: float = 1.0, far_slope_deg: float = 30.0,
                  flume_width: float = 0.4, start_distance: float = 0.1, coupling: Coupling = Coupling.PENALTY,
                  h_factor: float | None = None, c0: float | None = None, rebuild_every: int = 8,
                  joint_water: bool = True, scheme: FluidScheme | str = WCSPH(), cfl: float | None = None,
                  skin_factor: float | None = None, block_substeps: int | None = None, guided: bool = False) -> Scene:
    """The seed's second example: a rigid wedge sliding down a 25 degree plane into water.

    The wedge has a horizontal top of ``block_length`` [m], a vertical front face and its
    hypotenuse on the slope (height ``block_length tan(slope)``), and starts with its front
    ``start_distance`` [m] up-slope from the shoreline (x = 0, z = 0). The slope and the floor are
    FIXED blocks (for the rock contact) and wall particles (for the water).

    Args:
        dx: particle spacing [m]. slope_angle_deg: slide plane angle. block_density kg/m^3.
        friction_angle_deg: wedge-slope friction angle. water_depth, flat_length, flume_width m.
        far_slope_deg: the beach on which run-up is measured. coupling: PENALTY (seed Eq 22) or
            BOUNDARY_PARTICLES.
        joint_water: the wedge's face on the slope carries the hydrostatic pressure of the still
            water (``blocks.joint_water``; without it the water presses the wedge into the slope
            and friction stops it there, see tests/coupling/test_wedge_run.py).
        scheme: the fluid scheme (an object or a name); ``h_factor`` / ``cfl`` None: the scheme's
            (``scheme_resolution``); ``skin_factor`` None: 0.6 dx whatever the scheme (the block
            particles move within a step before the water's sums: with DFSPH's step they move
            up to ~0.3 dx). block_substeps: block steps per fluid step (``coupled_scene``).
        guided: the wedge moves only in the flume's vertical (x-z) plane, as a slide on rails
            does in a laboratory flume: its sideways translation and its rotations about x and z
            are locked (``make_blocks(locked="y rx rz")``). Off, the water's side walls (wall
            particles, no contact) are all that keeps it in the flume.
    """
    dx = _positive("sliding_wedge: dx", dx)
    scheme = as_scheme(scheme)
    h_factor, cfl, _ = scheme_resolution(scheme, h_factor, cfl)
    skin_factor = 0.6 if skin_factor is None else skin_factor
    block_density = _density("sliding_wedge: block_density", block_density)
    for nm, v in (("block_length", block_length), ("block_width", block_width), ("water_depth", water_depth),
                  ("flat_length", flat_length), ("flume_width", flume_width)):
        _positive(f"sliding_wedge: {nm}", v)
    _check_slide_flume("sliding_wedge", dx=dx, slope_angle_deg=slope_angle_deg, far_slope_deg=far_slope_deg,
                       water_depth=water_depth, flume_width=flume_width, width=("block_width", block_width, "block"))
    blocks = _blocks_api()
    geo = blocks.geometry
    th = math.radians(slope_angle_deg)
    t_, c_ = math.tan(th), math.cos(th)
    H = block_length * t_
    # the wedge: front-bottom corner on the slope start_distance up from the shoreline
    s_dir = np.array([math.cos(th), 0.0, -math.sin(th)])  # down-slope
    front_bottom = -start_distance * s_dir
    y0 = 0.5 * (flume_width - block_width)
    fx, fz = front_bottom[0], front_bottom[2]
    tri = [(fx, fz), (fx, fz + H), (fx - block_length, fz + H)]
    pts = np.array([[x, y, z] for y in (y0, y0 + block_width) for (x, z) in tri])
    wedge = geo.ConvexPolyhedron.from_vertices(pts)
    up = start_distance + block_length / c_ + block_length
    z_top = max(H + start_distance * math.sin(th) + 0.1, 0.5 * water_depth)
    f = _slide_flume(dx=dx, slope_angle_deg=slope_angle_deg, water_depth=water_depth, flat_length=flat_length,
                     far_slope_deg=far_slope_deg, flume_width=flume_width, up=up, reach=block_length, z_top=z_top,
                     h_factor=h_factor)
    slope_blk, slope_pos, floor, floor_pos = f["slope"], f["slope_pos"], f["floor"], f["floor_pos"]
    water, walls, dom_lo, dom_hi = f["water"], f["walls"], f["domain_lo"], f["domain_hi"]
    c0 = 10.0 * math.sqrt(GRAVITY * (water_depth + z_top)) if c0 is None else _positive("sliding_wedge: c0", c0)
    motion = (blocks.Motion.DYNAMIC, blocks.Motion.FIXED, blocks.Motion.FIXED)
    meta = dict(slope_angle_deg=slope_angle_deg, water_depth=water_depth, flat_length=flat_length,
                far_slope_deg=far_slope_deg, flume_width=flume_width, still_level=0.0, x_toe=f["x_toe"],
                x_beach=f["x_beach"], block_height=H, **f["observers"])
    return coupled_scene(name="sliding_wedge", dx=dx, polyhedra=[wedge, slope_blk, floor],
                         positions=[wedge.centroid_world, slope_pos, floor_pos], motion=motion,
                         block_density=[block_density, 2500.0, 2500.0], friction_angle_deg=friction_angle_deg,
                         fluid_x=water, wall_x=walls, domain_lo=dom_lo, domain_hi=dom_hi, still_level=0.0,
                         coupling=coupling, c0=c0, h_factor=h_factor, rebuild_every=rebuild_every,
                         joint_water=joint_water, meta=meta, scheme=scheme, cfl=cfl, skin_factor=skin_factor,
                         block_substeps=block_substeps,
                         block_kwargs={"locked": ["y rx rz", None, None]} if guided else None)


def rock_slope(*, dx: float = 0.02, failure: str = "planar", slope_angle_deg: float | None = None,
               friction_angle_deg: float | None = None, rock_length: float = 0.6, rock_thickness: float | None = None,
               rock_width: float = 0.3, column_spacing: float | None = None, bed_spacing: float | None = None,
               lateral_spacing: float = 0.1, jitter: float = 0.0, seed: int = 0, block_density: float = 2600.0,
               water_depth: float = 0.3, flat_length: float = 1.2, far_slope_deg: float = 20.0,
               flume_width: float = 0.4, start_distance: float = 0.05, coupling: Coupling = Coupling.PENALTY,
               h_factor: float = 1.3, c0: float | None = None) -> Scene:
    """A jointed rock mass cut from joint sets fails from a slope into a reservoir and makes a wave.

    The blocks are cut by ``blocks.cutting``; gauges on the flat, run-up on the far beach.

    The rock mass is a slab of ``rock_thickness`` on the slide plane (``slope_angle_deg``), from
    ``start_distance`` to ``start_distance + rock_length`` up-slope of the shoreline [m] along the
    slope, ``rock_width`` across, cut by cross joints normal to the slope (``column_spacing``),
    bedding parallel to it (``bed_spacing``; None: none) and vertical joints along it
    (``lateral_spacing``), all persistent, with an optional seeded spacing ``jitter``. One friction
    angle holds on every contact; faces pressed together under water carry the still water's
    hydrostatic pressure (``blocks.joint_water``, as in ``sliding_wedge``). ``failure`` picks the defaults of the Hoek & Bray regime it is
    built for (``validation.hoek_bray_regime`` of the plane's dip, the friction angle and a block's
    base / height, in ``meta["hoek_bray_regime"]``):

    * ``"planar"``: a 35 degree plane, 25 degree friction, blocks 0.06 m along the slope on 0.04 m
      beds of a 0.12 m slab (base / height 1.5 > tan 35): the mass slides (90 blocks).
    * ``"toppling"``: a 20 degree plane, 40 degree friction, columns 0.04 m wide and 0.2 m tall
      (base / height 0.2 < tan 20; no bedding): the columns topple, none slides.

    The flume is ``sliding_wedge``'s (same conventions). Args in SI units; the others as there.
    """
    if failure not in ("planar", "toppling"):
        raise ValueError(f"rock_slope: failure must be 'planar' or 'toppling' (got {failure!r})")
    planar = failure == "planar"
    slope_angle_deg = (35.0 if planar else 20.0) if slope_angle_deg is None else slope_angle_deg
    friction_angle_deg = (25.0 if planar else 40.0) if friction_angle_deg is None else friction_angle_deg
    rock_thickness = (0.12 if planar else 0.2) if rock_thickness is None else rock_thickness
    column_spacing = (0.06 if planar else 0.04) if column_spacing is None else column_spacing
    if bed_spacing is None and planar:
        bed_spacing = 0.04
    dx = _positive("rock_slope: dx", dx)
    block_density = _density("rock_slope: block_density", block_density)
    for nm, v in (("rock_length", rock_length), ("rock_thickness", rock_thickness), ("rock_width", rock_width),
                  ("column_spacing", column_spacing), ("lateral_spacing", lateral_spacing),
                  ("water_depth", water_depth), ("flat_length", flat_length), ("flume_width", flume_width),
                  ("start_distance", start_distance)):
        _positive(f"rock_slope: {nm}", v)
    if bed_spacing is not None:
        _positive("rock_slope: bed_spacing", bed_spacing)
    if not 0.0 <= friction_angle_deg < 90.0:
        raise ValueError(f"rock_slope: friction_angle_deg must be in [0, 90) degrees (got {friction_angle_deg})")
    _check_slide_flume("rock_slope", dx=dx, slope_angle_deg=slope_angle_deg, far_slope_deg=far_slope_deg,
                       water_depth=water_depth, flume_width=flume_width, width=("rock_width", rock_width, "rock mass"))
    from ..blocks import cutting
    from ..validation import hoek_bray_regime

    blocks = _blocks_api()
    th = math.radians(slope_angle_deg)
    s_dir = np.array([math.cos(th), 0.0, -math.sin(th)])  # down-slope
    n_slope = np.array([math.sin(th), 0.0, math.cos(th)])
    gap = 1e-3  # the mass starts 1 mm above the plane
    y0 = 0.5 * (flume_width - rock_width)
    back = start_distance + rock_length
    top = rock_thickness + gap
    z_top = back * math.sin(th) + top * math.cos(th) + 0.1
    reach = 2.0 * max(rock_length, rock_thickness)
    domain = cutting.region(
        [-back * math.cos(th) - top, y0, -rock_length - top], [top + rock_length, y0 + rock_width, z_top],
        [(gap * n_slope, -n_slope), (top * n_slope, n_slope), (-start_distance * s_dir, s_dir),
         (-back * s_dir, -s_dir)])
    sets = [cutting.JointSet(90.0 - slope_angle_deg, 270.0, column_spacing, offset=start_distance, jitter=jitter,
                             seed=seed),
            cutting.JointSet(90.0, 0.0, lateral_spacing, offset=y0, jitter=jitter, seed=seed + 1)]
    if bed_spacing is not None:
        sets.append(cutting.JointSet(slope_angle_deg, 90.0, bed_spacing, offset=gap, jitter=jitter, seed=seed + 2))
    rock = cutting.cut(domain, sets)
    f = _slide_flume(dx=dx, slope_angle_deg=slope_angle_deg, water_depth=water_depth, flat_length=flat_length,
                     far_slope_deg=far_slope_deg, flume_width=flume_width, up=back + reach, reach=reach,
                     z_top=z_top, h_factor=h_factor)
    c0 = 10.0 * math.sqrt(GRAVITY * (water_depth + z_top)) if c0 is None else _positive("rock_slope: c0", c0)
    B = rock.n_blocks
    # Contact stiffness: small blocks falling into the reservoir hit the floor and each other at up
    # to the free-fall speed from the mass's top; a penalty spring stops a block of mass m at speed
    # v within v sqrt(m / k), so k is chosen to keep that under half the depth at which a step
    # stops on BLOCK_PENETRATION (penetration_limit x the smallest bounding radius). Softer, as
    # coupled_scene would make it to match the water's step, the blocks sink into one another.
    v_max = math.sqrt(2.0 * GRAVITY * (z_top + water_depth))
    m_max = block_density * float(np.max(rock.volumes))
    r_min = min(p.bounding_radius for p in rock.polyhedra)
    k_rock = m_max * v_max**2 / (0.5 * 0.1 * r_min) ** 2
    height = bed_spacing if bed_spacing is not None and bed_spacing < rock_thickness else rock_thickness
    meta = dict(failure=failure, slope_angle_deg=slope_angle_deg, friction_angle_deg=friction_angle_deg,
                hoek_bray_regime=hoek_bray_regime(plane_dip_deg=slope_angle_deg, friction_angle_deg=friction_angle_deg,
                                                  base=column_spacing, height=height),
                rock_mass=rock.size_distribution(), water_depth=water_depth, flat_length=flat_length,
                far_slope_deg=far_slope_deg, flume_width=flume_width, still_level=0.0, x_toe=f["x_toe"],
                x_beach=f["x_beach"], **f["observers"])
    return coupled_scene(name="rock_slope", dx=dx, polyhedra=list(rock.polyhedra) + [f["slope"], f["floor"]],
                         positions=np.concatenate([rock.positions, [f["slope_pos"], f["floor_pos"]]]),
                         motion=(blocks.Motion.DYNAMIC,) * B + (blocks.Motion.FIXED,) * 2,
                         block_density=[block_density] * B + [2500.0, 2500.0], friction_angle_deg=friction_angle_deg,
                         fluid_x=f["water"], wall_x=f["walls"], domain_lo=f["domain_lo"], domain_hi=f["domain_hi"],
                         still_level=0.0, coupling=coupling, c0=c0, h_factor=h_factor, meta=meta,
                         joint_water=True, block_kwargs=dict(normal_stiffness=k_rock))


def _box_tank(*, dx, length, width, depth, height, layers):
    lo = np.array([0.0, 0.0, 0.0])
    container = [plane([0, 0, -1], lo), plane([-1, 0, 0], lo), plane([0, -1, 0], lo),
                 plane([1, 0, 0], [length, 0, 0]), plane([0, 1, 0], [0, width, 0])]
    water_hs = container + [plane([0, 0, 1], [0, 0, depth])]
    hi = np.array([length, width, height])
    return _flume_walls_and_water(dx=dx, layers=layers, halfspaces=container, water_halfspaces=water_hs, lo=lo,
                                  hi=hi)


def floating_box(*, dx: float = 0.02, box_size=(0.2, 0.2, 0.1), box_density: float = 500.0,
                 tank_size=(0.6, 0.6), water_depth: float = 0.3, coupling: Coupling = Coupling.PENALTY,
                 initial_draft: float | None = None, h_factor: float = 1.3, c0: float | None = None) -> Scene:
    """A box of density ``box_density`` [kg/m^3] released at the surface of still water in a tank.

    Archimedes: it settles with a draft ``box_density / 1000 * box height``. It starts at
    ``initial_draft`` (default: half the equilibrium draft) so it sinks, oscillates and settles.
    """
    dx = _positive("floating_box: dx", dx)
    lx, ly, lz = _lengths("floating_box: box_size", box_size, 3, "(lx, ly, lz)")
    L, W = _lengths("floating_box: tank_size", tank_size, 2, "(length, width)")
    water_depth = _positive("floating_box: water_depth", water_depth)
    if _density("floating_box: box_density", box_density) >= 1000.0:
        raise ValueError(f"floating_box: box_density must be in (0, 1000) kg/m^3 to float (got {box_density})")
    if lx > L - 6 * dx or ly > W - 6 * dx:
        raise ValueError("floating_box: the box must leave >= 3 dx of water on each side; enlarge tank_size")
    blocks = _blocks_api()
    layers = Resolution(dx, h_factor).wall_layers
    draft_eq = box_density / 1000.0 * lz
    draft0 = 0.5 * draft_eq if initial_draft is None else float(initial_draft)
    box = blocks.geometry.box(lx, ly, lz)
    pos = np.array([0.5 * L, 0.5 * W, water_depth - draft0 + 0.5 * lz])
    height = water_depth + 2 * lz
    water, walls = _box_tank(dx=dx, length=L, width=W, depth=water_depth, height=height, layers=layers)
    # remove water inside (and within r0 of) the box
    lo_b, hi_b = pos - 0.5 * np.array([lx, ly, lz]) - 0.25 * dx, pos + 0.5 * np.array([lx, ly, lz]) + 0.25 * dx
    water = water[~np.all((water > lo_b) & (water < hi_b), axis=1)]
    pad = layers * dx
    c0 = 10.0 * math.sqrt(2 * GRAVITY * water_depth) if c0 is None else c0
    meta = dict(box_size=[lx, ly, lz], box_density=box_density, water_depth=water_depth, still_level=water_depth,
                equilibrium_draft=draft_eq, tank_size=[L, W])
    return coupled_scene(name="floating_box", dx=dx, polyhedra=[box], positions=[pos], motion=(blocks.Motion.DYNAMIC,),
                         block_density=box_density, friction_angle_deg=30.0, fluid_x=water, wall_x=walls,
                         domain_lo=[-pad, -pad, -pad], domain_hi=[L + pad, W + pad, height + 2 * lz],
                         still_level=water_depth, coupling=coupling, c0=c0, h_factor=h_factor, meta=meta)


def block_drop(*, dx: float = 0.02, box_size=(0.1, 0.1, 0.1), box_density: float = 2500.0, drop_height: float = 0.2,
               tank_size=(0.5, 0.5), water_depth: float = 0.2, coupling: Coupling = Coupling.PENALTY,
               h_factor: float = 1.3, c0: float | None = None, joint_water: bool = True) -> Scene:
    """A box released ``drop_height`` [m] (its bottom above the still water) into a tank; a
    fixed floor block stops it at the bottom (z = 0); with ``joint_water`` the face it rests on
    carries the hydrostatic pressure of the water level the tank has with the box under water
    (``blocks.joint_water``; ``meta["joint_water_level"]``)."""
    dx = _positive("block_drop: dx", dx)
    lx, ly, lz = _lengths("block_drop: box_size", box_size, 3, "(lx, ly, lz)")
    L, W = _lengths("block_drop: tank_size", tank_size, 2, "(length, width)")
    water_depth = _positive("block_drop: water_depth", water_depth)
    box_density = _density("block_drop: box_density", box_density)
    if not (drop_height >= 0 and math.isfinite(drop_height)):
        raise ValueError(f"block_drop: drop_height must be a finite height >= 0 in m (got {drop_height})")
    if lx > L - 2 * dx or ly > W - 2 * dx:
        raise ValueError(f"block_drop: the box ({lx} x {ly} m) must leave >= 1 dx on each side in the tank "
                         f"({L} x {W} m); enlarge tank_size or shrink box_size")
    blocks = _blocks_api()
    layers = Resolution(dx, h_factor).wall_layers
    box = blocks.geometry.box(lx, ly, lz)
    pos = np.array([0.5 * L, 0.5 * W, water_depth + drop_height + 0.5 * lz])
    floor = blocks.geometry.slab(L, W, 0.1)
    floor_pos = floor.centroid_world + np.array([0.5 * L, 0.5 * W, 0.0])
    height = water_depth + drop_height + lz + 2 * dx
    water, walls = _box_tank(dx=dx, length=L, width=W, depth=water_depth, height=height, layers=layers)
    pad = layers * dx
    v_impact = math.sqrt(2 * GRAVITY * drop_height)
    c0 = 10.0 * max(math.sqrt(2 * GRAVITY * water_depth), v_impact) if c0 is None else c0
    # the joint's water level: the still level raised by the box once it is under water
    level = water_depth + min(lz, water_depth) * lx * ly / (L * W)
    meta = dict(box_size=[lx, ly, lz], box_density=box_density, water_depth=water_depth, still_level=water_depth,
                drop_height=drop_height, tank_size=[L, W], joint_water_level=level)
    return coupled_scene(name="block_drop", dx=dx, polyhedra=[box, floor], positions=[pos, floor_pos],
                         motion=(blocks.Motion.DYNAMIC, blocks.Motion.FIXED), block_density=[box_density, 2500.0],
                         friction_angle_deg=30.0, fluid_x=water, wall_x=walls, domain_lo=[-pad, -pad, -pad],
                         domain_hi=[L + pad, W + pad, height + water_depth], still_level=water_depth,
                         coupling=coupling, c0=c0, h_factor=h_factor, joint_water=joint_water,
                         block_kwargs=dict(joint_water_level=level) if joint_water else None, meta=meta)


def piston_wavemaker(*, dx: float = 0.025, stroke: float = 0.05, period: float = 1.0, water_depth: float = 0.3,
                     flat_length: float = 2.0, beach_slope: float = 0.04, beach_length: float | None = None,
                     flume_width: float | None = None, periodic_y: bool = True, coupling: Coupling = Coupling.PENALTY,
                     gauge_x=None, h_factor: float = 1.5, c0: float | None = None, alpha: float = 0.02,
                     wall_viscosity: float = 1.0, ramp_periods: float = 0.0, signal=None,
                     sponge_length: float = 0.0, sponge_strength: float = 10.0,
                     scheme: FluidScheme | str = WCSPH()) -> Scene:
    """The seed's first example: a piston wave maker, a flat section and a sloping beach.

    The piston is a PRESCRIBED block, ``x(t) = x0 + S/2 r(t) sin(2 pi t / T)`` (stroke S, period T
    in ``Params.blocks``); its face is at x = 0 at rest. ``ramp_periods``: soft start, the
    amplitude factor r(t) rises as a half cosine from 0 to 1 over ``ramp_periods * period``
    seconds (fixed in the Config when the scene is built; 0 = full stroke from t = 0, an impulsive
    start). Wave flumes ramp up over a few periods: the paddle starts without a velocity jump,
    which spares the weakly compressible fluid the pressure shock of an impulsive start. The flat
    runs to x = ``flat_length``, then the beach rises at ``beach_slope`` (rise/run; the seed's is
    4 %) for ``beach_length`` (default: up to 0.5 water depths above the still level). Wave gauges at ``gauge_x`` [m]
    (default 0.3 and 0.6 of the flat). ``periodic_y`` makes the flume a
    thin periodic slab (a 2D flume experiment; ``flume_width`` defaults then to the narrowest
    period the neighbour search allows, 2 (2 h + 0.6 dx) rounded up to whole dx: 8 dx at the default
    h = 1.5 dx, 7 dx at 1.3; else to 0.1 m). ``h_factor`` defaults to 1.5 (not the 1.3 of the other
    scenes): at 1.3 a resting cubic lattice rearranges (``experiments/hydrostatic_rest.py``) and
    the generated waves came out 11 % low and 3 % long at dx = 0.03 m, at 1.5 within 4 % and 0.4 %
    (``experiments/piston_decay.py``, RESULTS.md). The paper's scale (70 m flat, ~65k particles) is
    ``dx`` ~0.1 with ``flat_length=70``; the default is a small flume for tests. ``alpha``: artificial
    viscosity; ``wall_viscosity``: its factor towards the bed, walls and paddle (0 = free slip; see
    ``FluidParams``). ``water_depth`` must be a whole number of ``dx`` (the water is filled in whole
    lattice layers: 0.3 m at dx 0.04 would be 0.28 m of water; a ValueError says so).

    ``signal``: a ``blocks.paths.PaddleSignal`` (``paths.regular``, ``solitary``, ``focused_group``,
    ``jonswap``, ``read_csv``) drives the paddle instead of the sine (``stroke``, ``period`` and
    ``ramp_periods`` are then unused; ``Params.blocks.stroke`` scales the signal): a piston
    translates along +x; a flap (``kind="flap"``) turns about its face's bottom edge on the bed
    (x = 0, z = 0). Its ``water_depth`` must be the flume's. ``sponge_length`` > 0 puts a damping
    zone (``sph.Sponge``, ``sponge_strength`` 1/s) over the last ``sponge_length`` metres of the
    flat, before the beach: waves are absorbed instead of running up and reflecting. ``scheme``:
    the fluid scheme (an object or a name; ``WCSPH(viscosity=Laminar())`` keeps the waves' height
    along the flume, see ``wave_flume``).
    """
    dx = _positive("piston_wavemaker: dx", dx)
    paddle = "piston"
    if signal is not None:
        from ..blocks.paths import PaddleSignal

        if not isinstance(signal, PaddleSignal):
            raise ValueError(f"piston_wavemaker: signal must be a rockjax.blocks.paths.PaddleSignal (from paths.regular, "
                             f"solitary, focused_group, jonswap or read_csv), got {type(signal).__name__}")
        if abs(signal.water_depth - water_depth) > 1e-9 * water_depth:
            raise ValueError(f"piston_wavemaker: the signal was designed for water_depth {signal.water_depth} m, the "
                             f"flume has {water_depth} m: give the generator the flume's depth")
        paddle = signal.kind
        stroke = signal.stroke
    if not (math.isfinite(sponge_length) and 0.0 <= sponge_length < flat_length):
        raise ValueError(f"piston_wavemaker: sponge_length must be >= 0 and shorter than flat_length = {flat_length} m "
                         f"(got {sponge_length})")
    if not (math.isfinite(sponge_strength) and sponge_strength > 0):
        raise ValueError(f"piston_wavemaker: sponge_strength must be a damping rate > 0 in 1/s (got {sponge_strength})")
    if flume_width is None:
        flume_width = Resolution(dx, h_factor).narrowest_period(skin_factor=0.6) if periodic_y else 0.1
    for nm, v in (("stroke", stroke), ("period", period), ("water_depth", water_depth),
                  ("flat_length", flat_length), ("beach_slope", beach_slope), ("flume_width", flume_width)):
        _positive(f"piston_wavemaker: {nm}", v)
    whole_layers("piston_wavemaker", "water_depth", water_depth, dx, "the gauges and the wave generators")
    if not (math.isfinite(ramp_periods) and ramp_periods >= 0):
        raise ValueError(f"piston_wavemaker: ramp_periods must be a finite number >= 0 (got {ramp_periods})")
    blocks = _blocks_api()
    layers = Resolution(dx, h_factor).wall_layers
    rise = 1.5 * water_depth
    beach_length = rise / beach_slope if beach_length is None else _positive("beach_length", beach_length)
    x_end = flat_length + beach_length
    piston_t = max(4 * dx, 0.1)
    z_top = water_depth + max(0.5 * water_depth, 2 * stroke)
    piston = blocks.geometry.box(piston_t, flume_width, z_top + 0.1)
    pos = np.array([-0.5 * piston_t, 0.5 * flume_width, 0.5 * (z_top + 0.1)])
    n_beach = np.array([-beach_slope, 0.0, 1.0])
    back = 0.5 * stroke
    if signal is not None:  # the paddle's furthest excursion behind x = 0 (a flap's top and back)
        back = max(0.0, -float(np.min(signal.displacement)))
        if paddle == "flap":
            back = back * (z_top + 0.1) / water_depth + piston_t * float(np.max(np.abs(signal.displacement))) / water_depth
    x_min = -math.ceil((back + 3 * dx) / dx) * dx
    container = [plane([0, 0, -1], [0, 0, 0]), plane(-n_beach, [flat_length, 0, 0]),
                 plane([1, 0, 0], [x_end, 0, 0]), plane([-1, 0, 0], [x_min, 0, 0])]
    if not periodic_y:
        container += [plane([0, -1, 0], [0, 0, 0]), plane([0, 1, 0], [0, flume_width, 0])]
    # water starts half a spacing off the piston face (the penalty's interaction distance)
    water_hs = [h for h in container if not np.allclose(h[0], [-1, 0, 0])] + [plane([0, 0, 1], [0, 0, water_depth]),
                                                                          plane([-1, 0, 0], [0.2 * dx, 0, 0])]
    lo = np.array([x_min, 0.0, 0.0])
    hi = np.array([x_min + math.ceil((x_end - x_min) / dx) * dx, flume_width, math.ceil(z_top / dx) * dx])
    water = fill(lo, hi, dx, water_hs)
    pad = layers * dx
    wlo = lo - np.array([pad, 0 if periodic_y else pad, pad])
    whi = hi + np.array([pad, 0 if periodic_y else pad, 0])
    walls = shell(wlo, whi, dx, container, layers)
    c0 = 10.0 * math.sqrt(GRAVITY * water_depth) * 1.5 if c0 is None else c0
    periodic = (False, bool(periodic_y), False)
    dom_lo = [x_min - pad, 0.0 if periodic_y else -pad, -pad]
    dom_hi = [hi[0] + pad, flume_width if periodic_y else flume_width + pad, z_top + water_depth]
    gauge_x = [0.3 * flat_length, 0.6 * flat_length] if gauge_x is None else [float(g) for g in gauge_x]
    meta = dict(stroke=stroke, period=period, ramp_periods=ramp_periods, water_depth=water_depth,
                flat_length=flat_length, beach_slope=beach_slope, still_level=water_depth,
                runup_slope=dict(point=[flat_length, 0.5 * flume_width, 0.0],
                                 normal=(n_beach / np.linalg.norm(n_beach)).tolist(), x_min=flat_length),
                gauges=dict(names=[f"x={gx:g}" for gx in gauge_x], xy=[[gx, 0.5 * flume_width] for gx in gauge_x],
                            bottom_z=[0.0] * len(gauge_x)))
    if signal is None:
        motion_kwargs = dict(stroke=stroke, period=period, prescribed_direction=[(1.0, 0.0, 0.0)],
                             prescribed_ramp=ramp_periods * period)
    else:
        path = signal.piston() if paddle == "piston" else signal.flap(hinge=(0.0, 0.5 * flume_width, 0.0))
        motion_kwargs = dict(paths=path, period=period)
        meta.update(paddle=paddle, signal={k: v for k, v in signal.info.items() if np.ndim(v) == 0},
                    signal_end=float(signal.times[-1]))
    if sponge_length > 0:
        meta.update(sponge=dict(start=flat_length - sponge_length, end=flat_length, strength=sponge_strength))
    scene = coupled_scene(name="piston_wavemaker", dx=dx, polyhedra=[piston], positions=[pos],
                          motion=(blocks.Motion.PRESCRIBED,), block_density=2500.0, friction_angle_deg=30.0,
                          fluid_x=water, wall_x=walls, domain_lo=dom_lo, domain_hi=dom_hi, periodic=periodic,
                          still_level=water_depth, coupling=coupling, c0=c0, h_factor=h_factor, alpha=alpha,
                          wall_viscosity=wall_viscosity, meta=meta, block_kwargs=motion_kwargs, scheme=scheme)
    if sponge_length > 0:
        from ..sph.absorbers import Sponge

        sponge = Sponge(start=(flat_length - sponge_length, 0.0, 0.0), end=(flat_length, 0.0, 0.0),
                        strength=sponge_strength)
        scene = scene.replace(config=scene.config.replace(absorbers=(sponge,)))
    return scene


def wave_flume(*, dx: float = 0.03, water_depth: float = 0.3, wave: str = "regular", paddle: str = "piston",
               wave_height: float = 0.02, period: float = 1.26, duration: float | None = None, seed: int = 0,
               focus_x: float | None = None, focus_t: float | None = None, wave_times: list | None = None,
               wave_displacement: list | None = None, wave_file: str = "", flat_length: float = 4.0,
               beach_slope: float = 0.1, sponge_length: float = 0.0, sponge_strength: float = 10.0, gauge_x=None,
               coupling: Coupling = Coupling.BOUNDARY_PARTICLES, h_factor: float = 1.5, alpha: float = 0.02,
               periodic_y: bool = True, scheme: FluidScheme | str = WCSPH(viscosity=Laminar())) -> Scene:
    """A wave flume driven by a paddle of any motion: ``piston_wavemaker`` with its ``signal``
    made from scalar options (so scene files and the CLI reach every generator of
    ``blocks.paths``).

    ``wave``: "regular" (height ``wave_height``, ``period``, ramped over 2 periods, lasting
    ``duration``, default 12 periods), "solitary" (Goring's piston path for a solitary wave of
    height ``wave_height``), "focused" (a focused group of crest amplitude ``wave_height`` at
    ``focus_x`` m, default the middle of the flat, and ``focus_t`` s, default 8 periods; its
    frequencies span 0.7-1.4 / ``period``), "jonswap" (significant height ``wave_height``, peak
    period ``period``, ``seed``, ``duration`` default 30 periods), "table" (``wave_times`` s and
    ``wave_displacement`` m, inline arrays), "csv" (a paddle record ``wave_file``: columns t, x).
    ``paddle``: "piston" or "flap" (hinged on the bed; not for "solitary"). The flume is
    ``piston_wavemaker``'s: a flat of ``flat_length`` then a beach of ``beach_slope``; a sponge of
    ``sponge_length`` (m, 0 = none) ends the flat. Gauges at ``gauge_x`` (default 1, 2, 4 and 6
    depths from the paddle, those on the flat).

    ``scheme`` defaults to WCSPH with the water's laminar viscosity (``sph.Laminar``, nu 1e-6
    m^2/s) instead of Monaghan's artificial one: with alpha = 0.02 the artificial viscosity acts
    like nu = alpha h c0 / 10 ~ 2e-3 m^2/s at dx = 0.03 m, which damps a wave by Lamb's
    e^{-2 nu k^2 t} (5-8 % per wavelength at kh = 1, ~30 % at kh = 2; RESULTS.md, waves); with
    the laminar term the measured height stays level along the flume. ``alpha`` is then unused.
    """
    from ..blocks import paths

    d = _positive("wave_flume: water_depth", water_depth)
    T = _positive("wave_flume: period", period)
    if paddle not in ("piston", "flap"):
        raise ValueError(f"wave_flume: paddle must be 'piston' or 'flap' (got {paddle!r})")
    if wave == "regular":
        sig = paths.regular(period=T, water_depth=d, duration=12 * T if duration is None else duration,
                            wave_height=wave_height, ramp_periods=2.0, kind=paddle)
    elif wave == "solitary":
        sig = paths.solitary(wave_height=wave_height, water_depth=d, kind=paddle)
    elif wave == "focused":
        sig = paths.focused_group(amplitude=wave_height, water_depth=d, f_min=0.7 / T, f_max=1.4 / T,
                                  x_focus=0.5 * flat_length if focus_x is None else focus_x,
                                  t_focus=8 * T if focus_t is None else focus_t, kind=paddle)
    elif wave == "jonswap":
        sig = paths.jonswap(hs=wave_height, tp=T, water_depth=d, duration=30 * T if duration is None else duration,
                            seed=seed, kind=paddle)
    elif wave == "table":
        if wave_times is None or wave_displacement is None:
            raise ValueError("wave_flume: wave = 'table' needs wave_times (s) and wave_displacement (m) arrays")
        sig = paths.PaddleSignal(np.asarray(wave_times, float), np.asarray(wave_displacement, float), d, paddle,
                                 dict(generator="table"))  # checked where its path is made (Table / Flap)
    elif wave == "csv":
        if not wave_file:
            raise ValueError("wave_flume: wave = 'csv' needs wave_file, a CSV of t [s], displacement [m]")
        sig = paths.read_csv(wave_file, water_depth=d, kind=paddle)
    else:
        raise ValueError(f"wave_flume: wave must be one of regular, solitary, focused, jonswap, table, csv (got {wave!r})")
    if gauge_x is None:
        gauge_x = [g * d for g in (1, 2, 4, 6) if g * d < flat_length - sponge_length]
    scene = piston_wavemaker(dx=dx, water_depth=d, flat_length=flat_length, beach_slope=beach_slope, signal=sig,
                             sponge_length=sponge_length, sponge_strength=sponge_strength, gauge_x=gauge_x,
                             coupling=coupling, h_factor=h_factor, alpha=alpha, periodic_y=periodic_y, period=T,
                             scheme=scheme)
    return scene.replace(meta=scene.meta.with_items(name="wave_flume", wave=wave))


def block_on_incline(*, angle_deg: float = 30.0, friction_angle_deg: float = 20.0, block_size=(0.2, 0.2, 0.1),
                     block_density: float = 2500.0, block_kwargs: dict | None = None) -> Scene:
    """Blocks only: a box resting on a fixed incline (no water; no SPH is traced).

    ``block_kwargs`` go to ``blocks.make_blocks`` (e.g. ``penalty_modulus=1e7`` for a softer
    contact and a 10x larger stable step)."""
    lx, ly, lz = _lengths("block_on_incline: block_size", block_size, 3, "(lx, ly, lz)")
    block_density = _density("block_on_incline: block_density", block_density)
    if not 0.0 <= angle_deg < 90.0:
        raise ValueError(f"block_on_incline: angle_deg must be in [0, 90) degrees (got {angle_deg})")
    blocks = _blocks_api()
    geo = blocks.geometry
    slope = geo.slope(20 * lx, 10 * ly, 0.2, angle_deg)
    th = math.radians(angle_deg)
    n = np.array([math.sin(th), 0.0, math.cos(th)])
    box = geo.box(lx, ly, lz)
    c, s = math.cos(th), math.sin(th)
    rot_pts = (box.vertices) @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]).T
    tilted = geo.ConvexPolyhedron.from_vertices(rot_pts + 0.5 * lz * n)
    meta = dict(angle_deg=angle_deg, friction_angle_deg=friction_angle_deg)
    return coupled_scene(name="block_on_incline", dx=None, polyhedra=[tilted, slope],
                         positions=[tilted.centroid_world, slope.centroid_world],
                         motion=(blocks.Motion.DYNAMIC, blocks.Motion.FIXED), block_density=block_density,
                         friction_angle_deg=friction_angle_deg, block_kwargs=block_kwargs, meta=meta)
