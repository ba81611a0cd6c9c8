"""A field-scale scene: a rock slide from the flank of a fjord-like valley into its water.

``fjord`` builds it (at its default resolution, dx = 0.5 m, ~8.8 M water particles: a scene for
many devices, ``rockjax.decomposition``); ``fjord_estimate`` tells what a run of it costs without
building it (counts from the geometry's volumes and areas, memory per device for a decomposition
over ``n_devices`` slabs, run time at stated throughputs), which ``rockjax run fjord --dry-run``
prints for any ``--dx``.
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from ..sph.schemes import WCSPH, FluidScheme
from ..types import Coupling
from .base import (GRAVITY, Resolution, _density, _positive, as_scheme, check_lattice_size, scheme_resolution,
                   stable_dt, water_params)
from .shapes import fill, plane, shell

__all__ = ["fjord", "fjord_estimate"]

#: WCSPH throughputs the estimate uses [water particle-steps/s]: one H200 at 1M water particles (f32),
#: two CPU cores at 80k (RESULTS.md "GPU" and "SPH throughput"); per device, before decomposition
THROUGHPUT = {"h200": 116e6, "cpu_2_cores": 1.3e6}

#: ``fjord``'s options that shape the valley and the slide (``_check``'s keywords besides dx)
_GEOMETRY = ("length", "depth", "bottom_width", "flank_angle_deg", "freeboard", "slide_length", "slide_width",
             "slide_thickness", "slide_x", "slide_start")


def _geometry(*, length, depth, bottom_width, flank_angle_deg, freeboard):
    """The valley's cross-section (y, z) and the half-spaces of its water and container."""
    a = math.radians(flank_angle_deg)
    ta, sa, ca = math.tan(a), math.sin(a), math.cos(a)
    y0 = freeboard / ta  # left shoreline (the left flank meets z = freeboard at y = 0)
    y_fl = y0 + depth / ta  # floor's left edge
    y_fr = y_fl + bottom_width
    y_top = y_fr + (depth + freeboard) / ta  # right flank at z = freeboard
    container = [plane([0.0, -sa, -ca], [0.0, y0, 0.0]), plane([0.0, sa, -ca], [0.0, y_fr, -depth]),
                 plane([0, 0, -1], [0, 0, -depth]), plane([-1, 0, 0], [0, 0, 0]), plane([1, 0, 0], [length, 0, 0])]
    return dict(a=a, y0=y0, y_fl=y_fl, y_fr=y_fr, y_top=y_top, container=container,
                water=container + [plane([0, 0, 1], [0, 0, 0])],
                n_left=np.array([0.0, sa, ca]), s_left=np.array([0.0, ca, -sa]), n_right=np.array([0.0, -sa, ca]))


def _check(name, *, dx, length, depth, bottom_width, flank_angle_deg, freeboard, slide_length, slide_width,
           slide_thickness, slide_x, slide_start):
    for key, v in (("dx", dx), ("length", length), ("depth", depth), ("bottom_width", bottom_width),
                   ("freeboard", freeboard), ("slide_length", slide_length), ("slide_width", slide_width),
                   ("slide_thickness", slide_thickness)):
        _positive(f"{name}: {key}", v)
    if not 15.0 <= flank_angle_deg <= 60.0:
        raise ValueError(f"{name}: flank_angle_deg must be in [15, 60] degrees (got {flank_angle_deg})")
    if not 0.5 * slide_width + 2 * dx <= slide_x <= length - 0.5 * slide_width - 2 * dx:
        raise ValueError(f"{name}: slide_x ({slide_x} m) must keep the slide ({slide_width} m wide) inside the valley "
                         f"[0, {length}] m")
    a = math.radians(flank_angle_deg)
    top = (slide_start + slide_length) * math.sin(a) + slide_thickness * math.cos(a)
    if slide_start < 0 or top > freeboard:
        raise ValueError(f"{name}: the slide (slide_start {slide_start} m + slide_length {slide_length} m along the "
                         f"flank, {slide_thickness} m thick) reaches {top:.3g} m above the water, over the freeboard "
                         f"{freeboard} m; raise freeboard or shorten the slide")
    if depth < 4 * dx:
        raise ValueError(f"{name}: depth must hold >= 4 particles; use dx <= {depth / 4:.4g} m")


def fjord(*, dx: float = 0.5, length: float = 400.0, depth: float = 30.0, bottom_width: float = 40.0,
          flank_angle_deg: float = 30.0, freeboard: float = 40.0, slide_length: float = 60.0, slide_width: float = 80.0,
          slide_thickness: float = 10.0, slide_x: float = 100.0, slide_start: float = 0.0,
          block_density: float = 2600.0, friction_angle_deg: float = 20.0,
          coupling: Coupling = Coupling.BOUNDARY_PARTICLES, scheme: FluidScheme | str = WCSPH(),
          h_factor: float | None = None, cfl: float | None = None, c0: float | None = None, rebuild_every: int = 8):
    """A rock slab slides from the left flank of a straight valley into the water it holds.

    The valley runs along x over ``[0, length]`` (closed at both ends): a floor ``bottom_width``
    wide at z = -``depth``, flanks at ``flank_angle_deg`` rising to ``freeboard`` above the still
    water (z = 0). The slide is a ``slide_length`` (along the flank) x ``slide_width`` (along x) x
    ``slide_thickness`` box lying on the left flank, centred at x = ``slide_x``, its lower edge
    ``slide_start`` up the flank from the shoreline; it meets the flank and the floor as FIXED
    blocks (friction ``friction_angle_deg``). The wave crosses to the far flank (run-up there) and
    runs along the valley (gauges on its axis at 50, 150 and 250 m from the slide). SI units.

    Defaults: ~8.8 M water particles at dx = 0.5 m (``fjord_estimate`` for counts, memory and
    time); a laptop runs ``dx=4`` (~17k). Decompose it along x over devices with
    ``rockjax.decomposition.run_sharded``.
    """
    from .coupled import _blocks_api, coupled_scene

    name = "fjord"
    _check(name, dx=dx, length=length, depth=depth, bottom_width=bottom_width, flank_angle_deg=flank_angle_deg,
           freeboard=freeboard, slide_length=slide_length, slide_width=slide_width, slide_thickness=slide_thickness,
           slide_x=slide_x, slide_start=slide_start)
    block_density = _density(f"{name}: block_density", block_density)
    scheme = as_scheme(scheme)
    h_factor, cfl, _ = scheme_resolution(scheme, h_factor, cfl)
    geo = _blocks_api().geometry
    g = _geometry(length=length, depth=depth, bottom_width=bottom_width, flank_angle_deg=flank_angle_deg,
                  freeboard=freeboard)
    layers = Resolution(dx, h_factor).wall_layers
    pad = layers * dx
    lo = np.array([0.0, 0.0, -depth])
    hi = np.array([length, g["y_top"], freeboard])
    check_lattice_size(np.prod((hi - lo + 2 * pad) / dx), dx, f"{name} (fjord_estimate gives its counts)")
    water = fill(lo, hi, dx, g["water"])
    walls = shell(lo - pad, hi + pad, dx, g["container"], layers)

    n, s = g["n_left"], g["s_left"]
    ex = np.array([1.0, 0.0, 0.0])
    front = np.array([slide_x, g["y0"], 0.0]) - slide_start * s  # lower edge, on the flank, mid-width
    corners = [front + u * 0.5 * slide_width * ex - v * slide_length * s + w * slide_thickness * n
               for u in (-1, 1) for v in (0, 1) for w in (0, 1)]
    slide = geo.ConvexPolyhedron.from_vertices(np.array(corners))
    thick = max(4 * dx, 2.0)
    span = 2.0 * slide_width
    up = (freeboard / math.sin(g["a"])) + 2 * dx  # along the flank from the shoreline to the top
    down = depth / math.sin(g["a"])
    shore = np.array([slide_x, g["y0"], 0.0])
    flank_pts = [shore + u * 0.5 * span * ex + v * s - w * thick * n
                 for u in (-1, 1) for v in (-up, down) for w in (0, 1)]
    flank = geo.ConvexPolyhedron.from_vertices(np.array(flank_pts))
    floor = geo.slab(span, bottom_width + 2 * thick, thick)
    floor_pos = floor.centroid_world + np.array([slide_x, 0.5 * (g["y_fl"] + g["y_fr"]), -depth])
    blocks = _blocks_api()
    c0 = 10.0 * math.sqrt(GRAVITY * (depth + freeboard)) if c0 is None else _positive(f"{name}: c0", c0)
    y_axis = 0.5 * (g["y_fl"] + g["y_fr"])
    gx = [min(slide_x + d, length - dx) for d in (50.0, 150.0, 250.0)]
    meta = dict(still_level=0.0, depth=depth, length=length, flank_angle_deg=flank_angle_deg,
                runup_slope=dict(point=[slide_x, g["y_fr"], -depth], normal=g["n_right"].tolist(), x_min=None),
                gauges=dict(names=["50 m", "150 m", "250 m"], xy=[[x, y_axis] for x in gx], bottom_z=[-depth] * 3))
    return coupled_scene(name=name, dx=dx, polyhedra=[slide, flank, floor],
                         positions=[slide.centroid_world, flank.centroid_world, floor_pos],
                         motion=(blocks.Motion.DYNAMIC, blocks.Motion.FIXED, blocks.Motion.FIXED),
                         block_density=[block_density, 2600.0, 2600.0], friction_angle_deg=friction_angle_deg,
                         fluid_x=water, wall_x=walls, domain_lo=np.minimum(lo - pad, walls.min(0) - dx),
                         domain_hi=np.maximum(hi + pad, walls.max(0) + dx) + np.array([0, 0, freeboard]),
                         still_level=0.0, coupling=coupling, c0=c0, h_factor=h_factor, rebuild_every=rebuild_every,
                         joint_water=True, meta=meta, scheme=scheme, cfl=cfl)


def fjord_estimate(*, n_devices: int = 1, t_end: float = 60.0, capacity_factor: float = 1.5, halo_layers: int = 3,
                   **options) -> dict:
    """What a run of ``fjord(**options)`` costs, without building it (an estimate).

    Counts from the geometry: water = its volume / dx^3; fixed walls = the wetted and dry surface
    of the valley (floor, flanks, ends) x ``wall_layers`` / dx^2; the slide's particles = the volume
    of its shell ``wall_layers`` dx deep / dx^3 (boundary particles). Built scenes agree within
    3 % (water), 10 % (walls) and 0 % (slide) at dx = 2 m (``tests/scale/test_fjord.py``). Per device of a decomposition along x into
    ``n_devices`` equal slabs: owned water, the two halo layers (``halo_layers`` list radii each),
    times ``capacity_factor`` (``decomposition.decompose``; 1 on one device), ~60 bytes per particle record and the
    neighbour rows (K int32 each, K ~ 120 at h = 1.3 dx), x4 for a step's temporaries. Time: steps
    (t_end / dt, dt as ``fjord`` sets it) x particles per device / ``THROUGHPUT``, with the halo rows
    counted as work (no communication time).
    """
    known = inspect.signature(fjord).parameters
    unknown = set(options) - set(known)
    if unknown:
        raise ValueError(f"fjord_estimate: unknown options {sorted(unknown)}")
    values = {k: options.get(k, p.default) for k, p in known.items()}  # fjord's defaults where not given
    dx = float(values["dx"])
    opts = {k: values[k] for k in _GEOMETRY}
    _check("fjord_estimate", dx=dx, **opts)
    if int(n_devices) < 1:
        raise ValueError(f"fjord_estimate: n_devices must be >= 1 (got {n_devices})")
    scheme = as_scheme(values["scheme"])
    h_factor, cfl, _ = scheme_resolution(scheme, values["h_factor"], values["cfl"])
    res = Resolution(dx, h_factor)
    L, d, b, f = opts["length"], opts["depth"], opts["bottom_width"], opts["freeboard"]
    a = math.radians(opts["flank_angle_deg"])
    area_water = d * (b + d / math.tan(a))
    n_water = L * area_water / dx ** 3
    flank = (d + f) / math.sin(a)
    section_perimeter = b + 2 * flank
    section_area = (d + f) * (b + (d + f) / math.tan(a))  # an end wall
    wall_area = L * section_perimeter + 2 * section_area
    n_wall = wall_area * res.wall_layers / dx ** 2
    sl, sw, st = opts["slide_length"], opts["slide_width"], opts["slide_thickness"]
    shell_depth = res.wall_layers * dx  # boundary particles fill the block to this depth inside its faces
    core = np.prod([max(0.0, e - 2 * shell_depth) for e in (sl, sw, st)])
    n_slide = (sl * sw * st - core) / dx ** 3
    c0 = values["c0"] or 10.0 * math.sqrt(GRAVITY * (d + f))
    dt = stable_dt(water_params(res, c0=c0), scheme=scheme, cfl=cfl)
    steps = int(math.ceil(t_end / dt))
    radius = res.support + 0.6 * dx  # the list radius: coupled scenes' skin is 0.6 dx
    halo_rows = 2 * halo_layers * radius * area_water / dx ** 3 if n_devices > 1 else 0.0
    per_device_water = n_water / n_devices
    rows = (capacity_factor if n_devices > 1 else 1.0) * (per_device_water + halo_rows)
    walls_per_device = n_wall / n_devices + n_slide
    k = 120
    mem = 4 * ((rows + walls_per_device) * 60 + rows * k * 4)
    out = dict(scene="fjord", dx=dx, water=int(n_water), walls=int(n_wall), slide_particles=int(n_slide), dt_s=dt,
               steps=steps, t_end_s=t_end, n_devices=int(n_devices), water_per_device=int(per_device_water),
               halo_rows_per_device=int(halo_rows), rows_per_device=int(rows), memory_GB_per_device=mem / 1e9)
    for name, rate in THROUGHPUT.items():
        out[f"hours_{name}"] = steps * rows / rate / 3600.0
    out["note"] = "estimate from the geometry and measured throughputs; not a run"
    return out
