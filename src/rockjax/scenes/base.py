"""What every scene builder shares: the ``Scene`` bundle, the ``Resolution`` (dx and h), particle
lattices, tank walls, water parameters, the host-side time step, and the host-side checks of params
against config.

Everything here runs on the host with numpy; the arrays become ``jax.Array`` only in
``make_state``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import jax.numpy as jnp
import numpy as np

from ..sph.kernels import SUPPORT_FACTOR
from ..sph.schemes import FluidScheme, from_names
from ..types import Capacities, Config, FluidParams, GridSpec, Kind, NeighbourList, Params, Particles, State, float_dtype
from .meta import SceneMeta

__all__ = [
    "Scene", "Resolution", "lattice", "tank_walls", "water_params", "stable_dt", "check_params", "check_param_values", "make_state",
    "fluid_scene", "particle_layout", "ParticleLayout", "GRAVITY", "empty_neighbours", "as_scheme",
]

GRAVITY = 9.81


@dataclasses.dataclass(frozen=True)
class Scene:
    """A runnable scene: static config, calibratable params, initial state and metadata.

    ``meta`` is a ``SceneMeta``: ``name``, ``dx``, what the observers read (``still_level``,
    ``gauges``, ``runup_slope``) and scene-specific geometry (e.g. the dam-break column size) in
    ``extra``, SI units; it reads as the mapping it replaced (``meta["dx"]``). A dict given here is
    converted (``SceneMeta.from_dict``).
    """

    config: Config
    params: Params
    state: State
    meta: SceneMeta

    def __post_init__(self):
        if not isinstance(self.meta, SceneMeta):
            object.__setattr__(self, "meta", SceneMeta.from_dict(self.meta))

    @property
    def name(self) -> str:
        return str(self.meta.name)

    def replace(self, **changes) -> "Scene":
        return dataclasses.replace(self, **changes)

    def counts(self) -> dict[str, int]:
        kind = np.asarray(self.state.particles.kind)
        return {"fluid": int((kind == Kind.FLUID).sum()), "wall": int((kind == Kind.WALL).sum()),
                "pad": int((kind == Kind.PAD).sum())}


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive finite number in SI units (got {value})")
    return value


def _lengths(name: str, value, n: int, what: str) -> tuple:
    """``value`` as ``n`` positive finite lengths [m] (a builder's size option), or a ValueError
    naming ``name`` and the ``what`` it must hold (e.g. ``"(lx, ly, lz)"``)."""
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        out = ()
    if len(out) != n or not all(v > 0 and math.isfinite(v) for v in out):
        raise ValueError(f"{name} must be {n} positive lengths in m {what} (got {value!r})")
    return out


def _density(name: str, value) -> float:
    """A block density [kg/m^3] within ``blocks.model.DENSITY_RANGE``, or a ValueError naming ``name``."""
    from ..blocks.model import DENSITY_RANGE

    value = _positive(name, value)
    lo, hi = DENSITY_RANGE
    if not lo <= value <= hi:
        raise ValueError(f"{name} must be in [{lo:g}, {hi:g}] kg/m^3 (rock is ~2000-3000; got {value:g})")
    return value


@dataclasses.dataclass(frozen=True)
class Resolution:
    """The particle spacing ``dx`` [m] and the smoothing length ``h = h_factor dx`` [m] of a scene.

    The one place a scene decides h and what follows from it: ``FluidParams.h`` (``water_params``),
    the kernel support ``Config.cutoff`` (``particle_layout``) and the number of wall particle
    layers (enough to fill the support behind a wall face). Builders make one from their ``dx`` and
    ``h_factor`` arguments and read the rest from it.

    Raises ValueError naming ``dx`` or ``h_factor`` when either is not a positive finite number.
    """

    dx: float
    h_factor: float = 1.3

    def __post_init__(self):
        for name in ("dx", "h_factor"):
            value = getattr(self, name)
            ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
            if not (ok and float(value) > 0 and math.isfinite(float(value))):
                raise ValueError(f"{name} must be a positive finite number (got {value!r})")
            object.__setattr__(self, name, float(value))

    @property
    def h(self) -> float:
        """Smoothing length [m]: ``h_factor dx``."""
        return self.h_factor * self.dx

    @property
    def support(self) -> float:
        """Kernel support radius [m]: ``SUPPORT_FACTOR h`` (every kernel vanishes beyond it); the
        scenes' ``Config.cutoff``."""
        return SUPPORT_FACTOR * self.h_factor * self.dx

    @property
    def wall_layers(self) -> int:
        """Wall particle layers behind a wall face: ``ceil(SUPPORT_FACTOR h_factor)``, so that a
        fluid particle at the face has its whole kernel support filled."""
        return int(math.ceil(SUPPORT_FACTOR * self.h_factor))

    def narrowest_period(self, skin_factor: float) -> float:
        """The narrowest periodic length [m] the neighbour search allows with a Verlet skin of
        ``skin_factor`` dx: twice the search radius ``support + skin``, rounded up to whole dx."""
        return math.ceil(2 * (SUPPORT_FACTOR * self.h_factor + skin_factor) - 1e-9) * self.dx


#: host bytes a scene needs per lattice point while it is built (positions, clearances, masks,
#: neighbour-search temporaries): the basis of ``check_lattice_size``'s estimate
HOST_BYTES_PER_POINT = 400


def host_memory_bytes() -> int:
    """This machine's physical memory in bytes (``os.sysconf``), or 64 GiB where it cannot tell."""
    import os

    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return 64 * 2**30


def check_lattice_size(n_points: float, dx: float, what: str = "the scene") -> None:
    """Refuse a lattice of ``n_points`` at spacing ``dx`` [m] whose estimated host memory
    (``HOST_BYTES_PER_POINT`` each) exceeds this machine's: a ValueError naming ``dx`` with the
    estimate, before anything is allocated."""
    need = float(n_points) * HOST_BYTES_PER_POINT
    have = host_memory_bytes()
    if need > have:
        raise ValueError(f"dx = {dx:g} m is too fine for {what}: about {float(n_points):.3g} lattice points, "
                         f"~{need / 2**30:.3g} GiB of host memory to build (this machine has {have / 2**30:.3g} GiB); "
                         "use a larger dx")


def lattice(lo, hi, dx: float) -> np.ndarray:
    """Cell-centred cubic lattice filling the box [lo, hi] (m): points ``lo + (i + 1/2) dx``.

    The box sizes are rounded to whole numbers of dx. Returns [n, 3] float64. Raises ValueError
    naming ``dx`` when the lattice would not fit in this machine's memory (``check_lattice_size``).
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    sizes = np.maximum(np.round((hi - lo) / dx), 0)
    check_lattice_size(float(np.prod(sizes)), dx)
    n = sizes.astype(int)
    axes = [lo[a] + (np.arange(n[a]) + 0.5) * dx for a in range(3)]
    g = np.meshgrid(*axes, indexing="ij")
    return np.stack([c.ravel() for c in g], axis=1)


def tank_walls(lo, hi, dx: float, layers: int, *, periodic=(False, False, False), open_top: bool = True) -> np.ndarray:
    """Wall particles around the box [lo, hi]: ``layers`` lattice layers outside each closed face.

    The lattice continues the fluid lattice (first layer centred dx/2 outside the wall). Faces
    normal to a periodic axis get no wall; with ``open_top`` the top (+z) face has none either.
    Returns [n, 3] float64.
    """
    lo = np.asarray(lo, float)
    hi = np.asarray(hi, float)
    ext_lo = np.array([lo[a] if periodic[a] else lo[a] - layers * dx for a in range(3)])
    ext_hi = np.array([hi[a] if (periodic[a] or (a == 2 and open_top)) else hi[a] + layers * dx for a in range(3)])
    pts = lattice(ext_lo, ext_hi, dx)
    inside = np.all((pts > lo) & (pts < hi), axis=1)
    if open_top:
        inside |= np.all((pts[:, :2] > lo[:2]) & (pts[:, :2] < hi[:2]), axis=1) & (pts[:, 2] > lo[2])
    return pts[~inside]


def water_params(resolution: Resolution, *, c0: float, alpha: float = 0.02, nu: float = 1e-6,
                 delta: float = 0.1, rho0: float = 1000.0, gravity: float = GRAVITY,
                 wall_viscosity: float = 1.0) -> Params:
    """Params for water at ``resolution``: ``FluidParams.h = resolution.h`` [m], speed of sound c0 [m/s]."""
    dt = float_dtype()
    fluid = FluidParams(
        rho0=jnp.asarray(rho0, dt), c0=jnp.asarray(c0, dt), h=jnp.asarray(resolution.h, dt),
        alpha=jnp.asarray(alpha, dt), nu=jnp.asarray(nu, dt), delta=jnp.asarray(delta, dt),
        wall_viscosity=jnp.asarray(wall_viscosity, dt),
    )
    return Params(gravity=jnp.asarray([0.0, 0.0, -gravity], dt), fluid=fluid)


def stable_dt(params: Params, *, scheme: FluidScheme, cfl: float = 0.25) -> float:
    """Largest stable time step [s] for these params (host side, from concrete values):
    ``scheme.stable_dt`` (``min(cfl h / c0, 0.125 h^2 / nu [viscous terms], 0.25 sqrt(h / |g|))``)."""
    return scheme.stable_dt(params, cfl=cfl)


def whole_layers(name: str, field: str, depth: float, dx: float, users: str) -> None:
    """Refuse a water ``depth`` (option ``field``) that is not a whole number of ``dx`` (ValueError
    naming both): water is filled in whole lattice layers from its bed, so 0.3 m at dx 0.04 would be
    0.28 m of water under a still level (gauges, run-up, wave generators: ``users``) that takes 0.3 m."""
    layers = depth / dx
    if abs(layers - round(layers)) > 1e-6 * max(1.0, layers):
        filled = math.floor(layers + 1e-9) * dx
        raise ValueError(f"{name}: {field} = {depth} m is not a whole number of dx = {dx} m "
                         f"({field} / dx = {layers:.4g}): the water is filled in whole lattice layers, "
                         f"{filled:.4g} m deep, while {users} take {depth} m; "
                         f"choose dx = {field} / n (e.g. dx = {depth / max(1, round(layers)):.4g} m)")


def scheme_resolution(scheme: FluidScheme, h_factor: float | None, cfl: float | None,
                      skin_factor: float | None = None) -> tuple[float, float, float]:
    """``(h_factor, cfl, skin_factor)``: the given values, or the scheme's own where None
    (``FluidScheme.default_h_factor``, ``default_cfl``, ``default_skin_factor``: WCSPH 1.3, 0.25
    and 0.3; DFSPH its kernel's h / dx, 0.4 and 0.05), after ``scheme.check_resolution`` of the h / dx."""
    h_factor = scheme.default_h_factor if h_factor is None else h_factor
    scheme.check_resolution(h_factor)
    return (h_factor, scheme.default_cfl if cfl is None else cfl,
            scheme.default_skin_factor if skin_factor is None else skin_factor)


def as_scheme(scheme) -> FluidScheme:
    """A fluid scheme object from an object or a scheme name (``"wcsph"``, ``"seed"``: its default terms)."""
    return from_names(scheme) if isinstance(scheme, str) else scheme


def _concrete(value) -> bool:
    import jax

    return not isinstance(value, jax.core.Tracer)


def check_param_values(params: Params) -> None:
    """Refuse Params values no run can use (host side; traced fields are skipped): a non-finite
    gravity, fluid constants that are not finite (``rho0``, ``c0``, ``h`` not positive; ``alpha``,
    ``nu``, ``delta``, ``wall_viscosity`` negative), coupling constants that are not finite
    (``penalty_stiffness``, ``interaction_distance`` not positive, ``penalty_damping``
    negative) and the block constants of ``blocks.check_block_params``. The ValueError names
    the field (``Params.fluid.c0``) and the range expected; nothing is compiled first."""
    if _concrete(params.gravity) and not np.all(np.isfinite(np.asarray(params.gravity))):
        raise ValueError(f"Params.gravity must be three finite numbers in m/s^2 (got {np.asarray(params.gravity)})")
    rules = []
    if params.fluid is not None:
        rules += [("fluid", params.fluid, ("rho0", "c0", "h"), ("alpha", "nu", "delta", "wall_viscosity"))]
    if params.coupling is not None:
        rules += [("coupling", params.coupling, ("penalty_stiffness", "interaction_distance"), ("penalty_damping",))]
    for part, values, positive, non_negative in rules:
        for name in positive + non_negative:
            value = getattr(values, name)
            if not _concrete(value):
                continue
            x = np.asarray(value, dtype=np.float64)
            if not np.all(np.isfinite(x)) or np.any(x <= 0 if name in positive else x < 0):
                want = "positive" if name in positive else ">= 0"
                raise ValueError(f"Params.{part}.{name} must be finite and {want} (got {x}); set it with "
                                 f"params.replace({part}=params.{part}.replace({name}=...))")
    if params.blocks is not None:
        from ..blocks.model import check_block_params

        check_block_params(params.blocks)


def check_params(config: Config, params: Params) -> None:
    """Refuse params that the static config cannot run safely (host side, concrete values only):
    ``check_param_values``, then the fluid's kernel support against ``Config.cutoff`` and
    ``Config.dt`` against the stability limit."""
    check_param_values(params)
    f = params.fluid
    if f is None:
        return
    support = SUPPORT_FACTOR * float(np.max(np.asarray(f.h)))
    if support > config.cutoff * (1 + 1e-6):
        raise ValueError(
            f"Params.fluid.h = {float(np.max(np.asarray(f.h))):.4g} m gives a kernel support of {support:.4g} m, "
            f"beyond Config.cutoff = {config.cutoff:.4g} m; rebuild the scene with this h (or a larger cutoff)."
        )
    config.scheme.check_params(params)
    limit = stable_dt(params, scheme=config.scheme, cfl=2 * config.cfl)
    if config.dt > limit * (1 + 1e-6):
        raise ValueError(
            f"Config.dt = {config.dt:.4g} s exceeds the stability limit {limit:.4g} s for these Params "
            f"(h = {float(f.h):.4g} m, c0 = {float(f.c0):.4g} m/s, nu = {float(f.nu):.3g} m^2/s); "
            "use a smaller dt (Config.replace(dt=...)) or rebuild the scene."
        )


def make_state(*, config: Config, x: np.ndarray, kind: np.ndarray, vol: np.ndarray, rho: np.ndarray,
               v: np.ndarray | None = None) -> State:
    """Initial ``State`` from host arrays (neighbour list empty; the first step rebuilds it)."""
    n = x.shape[0]
    dt = float_dtype()
    v = np.zeros_like(x) if v is None else v
    particles = Particles(
        x=jnp.asarray(x, dt), v=jnp.asarray(v, dt), a=jnp.zeros((n, 3), dt), rho=jnp.asarray(rho, dt),
        drho_dt=jnp.zeros((n,), dt), p=jnp.zeros((n,), dt), vol=jnp.asarray(vol, dt),
        kind=jnp.asarray(kind, jnp.int32), pid=jnp.arange(n, dtype=jnp.int32),
        solver=config.scheme.initial_solver(n, dt),
    )
    nbrs = empty_neighbours(config, particles.x)
    return State(step=jnp.zeros((), jnp.int32), particles=particles, nbrs=nbrs, status=jnp.zeros((), jnp.int32))


def empty_neighbours(config: Config, x) -> NeighbourList:
    """A neighbour list of the config's shapes holding no pairs (every slot is the row itself)."""
    nf = config.n_fluid
    zero = jnp.zeros((), jnp.int32)
    none = jnp.zeros((config.wall_pair_capacity,), jnp.int32)
    no_body = jnp.zeros((config.body_pair_capacity,), jnp.int32)
    return NeighbourList(
        idx=jnp.tile(jnp.arange(nf, dtype=jnp.int32)[:, None], (1, config.neighbour_capacity)),
        x_ref=jnp.asarray(x), max_count=zero, max_run=zero, wall_row=none, wall_col=none, wall_count=zero,
        max_wall_count=zero, wall_start=jnp.zeros((config.n_wall + 1,), jnp.int32),
        body_row=no_body, body_col=no_body, body_count=zero, max_body_count=zero,
    )


def wall_pair_capacity(fluid_x: np.ndarray, wall_x: np.ndarray, radius: float) -> int:
    """Initial ``Config.wall_pair_capacity``: twice the (fluid, wall) pairs closer than ``radius``
    [m] in the initial positions, plus one per fluid particle (water that spreads over a floor
    meets more wall; the driver grows the list if it must)."""
    from scipy.spatial import cKDTree

    if len(fluid_x) == 0 or len(wall_x) == 0:
        return 0
    count = int(cKDTree(fluid_x).count_neighbors(cKDTree(wall_x), radius))
    return int(math.ceil((2 * count + len(fluid_x)) / 8.0) * 8)


def _ceil8(v: float) -> int:
    return int(math.ceil(v / 8.0) * 8)


def initial_list_sizes(fluid_x: np.ndarray, x: np.ndarray, grid: GridSpec, radius: float) -> tuple[int, int]:
    """``(neighbours, cell run)`` the first list build needs for these positions (host, numpy).

    ``neighbours``: the most particles (fluid and wall) within ``radius`` [m] of a fluid particle;
    ``cell run``: the largest candidate range a fluid particle searches (``sph.neighbours``: a run
    of 5 search sub-cells along x, or one sub-cell), in ``Config.cell_capacity`` units. The lattice
    estimate of ``_capacities`` misses walls whose layers are offset from the water's lattice
    (a 0.2 m tank at skin 0.3 dx needed 154 where it gave 96), so scenes take the larger of the two.
    """
    from scipy.spatial import cKDTree

    from ..sph.neighbours import _run_mode, range_ratio, search_grid

    if len(fluid_x) == 0:
        return 0, 0
    periodic = np.asarray(grid.periodic)
    lengths = np.asarray(grid.lengths, float)
    origin = np.asarray(grid.origin, float)
    x_q = np.where(periodic, origin + np.mod(np.asarray(x, float) - origin, lengths), np.asarray(x, float))
    fluid_q = x_q[: len(fluid_x)]
    images = x_q
    for ax in np.nonzero(periodic)[0]:  # periodic images, one period either side
        shift = np.zeros(3)
        shift[ax] = lengths[ax]
        images = np.concatenate([images, images + shift, images - shift])
    counts = cKDTree(images).query_ball_point(fluid_q, radius, return_length=True)
    k_need = int(np.max(counts)) - 1  # not the particle itself
    sg = search_grid(grid)
    shape = np.asarray(sg.shape)
    c = np.floor((x_q - origin) / np.asarray(sg.cell_size)).astype(int)  # as sph.neighbours.cell_coords
    c = np.where(periodic, np.mod(c, shape), np.clip(c, 0, shape - 1))
    hist = np.zeros(tuple(shape), np.int64)
    np.add.at(hist, (c[:, 0], c[:, 1], c[:, 2]), 1)
    run_mode = _run_mode(sg)
    if run_mode:  # windows [cx - 2, cx + 2] along x (clipped: x is not periodic in run mode)
        cs = np.concatenate([np.zeros((1,) + hist.shape[1:], np.int64), np.cumsum(hist, axis=0)])
        lo = np.clip(np.arange(shape[0]) - 2, 0, None)
        hi = np.clip(np.arange(shape[0]) + 3, None, shape[0])
        win = cs[hi] - cs[lo]
    else:
        win = hist
    cf = np.unique(c[: len(fluid_x)], axis=0)
    best = 0
    for dy in range(-2, 3):
        for dz in range(-2, 3):
            yz = cf[:, 1:] + [dy, dz]
            ok = np.ones(len(cf), bool)
            for a, ax in ((0, 1), (1, 2)):
                if periodic[ax]:
                    yz[:, a] = np.mod(yz[:, a], shape[ax])
                else:
                    ok &= (yz[:, a] >= 0) & (yz[:, a] < shape[ax])
            if ok.any():
                if run_mode:
                    best = max(best, int(win[cf[ok, 0], yz[ok, 0], yz[ok, 1]].max()))
                else:
                    for dx_ in range(-2, 3):
                        xs = cf[ok, 0] + dx_
                        xs = np.mod(xs, shape[0]) if periodic[0] else xs
                        inb = (xs >= 0) & (xs < shape[0])
                        if inb.any():
                            best = max(best, int(win[xs[inb], yz[ok][inb, 0], yz[ok][inb, 1]].max()))
    return k_need, int(math.ceil(best / range_ratio(sg)))


def _capacities(list_radius_dx: float, run_length: int) -> tuple[int, int]:
    """Neighbour, wall-row and cell-run capacities for a regular lattice (the driver regrows)."""
    n_sphere = 4.0 / 3.0 * math.pi * list_radius_dx**3
    k = int(math.ceil(1.15 * n_sphere / 8.0) * 8)
    side = math.ceil(list_radius_dx - 1e-9)  # most lattice planes a cell can cut
    run = math.ceil(run_length * list_radius_dx - 1e-9)
    c = int(math.ceil(1.1 * side * side * run / 8.0) * 8)
    return k, c


@dataclasses.dataclass(frozen=True, eq=False)
class ParticleLayout:
    """Host arrays and static sizes of a scene's water + wall particles (``particle_layout``).

    ``x`` [N, 3] m (water first, then walls), ``kind`` [N] int32 (``Kind``), ``vol`` [N] m^3 (dx^3),
    ``rho`` [N] kg/m^3; ``grid`` (``GridSpec``), ``cutoff`` (the kernel support) and ``skin`` [m];
    the initial list capacities ``neighbour_capacity``, ``cell_capacity`` and
    ``wall_pair_capacity`` (the driver grows them when a run needs more). The fields go into
    ``Config`` and ``make_state`` under the same names.
    """

    grid: GridSpec
    cutoff: float
    skin: float
    neighbour_capacity: int
    cell_capacity: int
    wall_pair_capacity: int
    x: np.ndarray
    kind: np.ndarray
    vol: np.ndarray
    rho: np.ndarray


def particle_layout(resolution: Resolution, *, fluid_x: np.ndarray, wall_x: np.ndarray, domain_lo, domain_hi, periodic,
                    surface_z: float | None, c0: float, scheme: FluidScheme, skin_factor: float) -> ParticleLayout:
    """Host arrays and static sizes for water + wall particles at ``resolution`` (spacing dx [m],
    kernel support = the cutoff).

    Returns a ``ParticleLayout``: ``grid``, ``cutoff`` and ``skin`` [m], ``neighbour_capacity``,
    ``cell_capacity`` and ``wall_pair_capacity``, and the particle arrays ``x`` [N, 3], ``kind``, ``vol`` (dx^3) and ``rho``
    (hydrostatic below ``surface_z`` where the scheme integrates its density, ``scheme.initial_density``; else rho0).
    """
    dx = resolution.dx
    cutoff = resolution.support
    skin = skin_factor * dx
    grid = GridSpec.covering(domain_lo, domain_hi, min_cell=cutoff + skin, periodic=periodic)
    x = np.concatenate([fluid_x, wall_x], axis=0)
    kind = np.concatenate([np.full(len(fluid_x), Kind.FLUID), np.full(len(wall_x), Kind.WALL)]).astype(np.int32)
    vol = np.full(len(x), dx**3)
    rho = np.full(len(x), 1000.0)
    if surface_z is not None:
        depth = np.clip(surface_z - x[:, 2], 0.0, None)
        still = scheme.initial_density(1000.0 * GRAVITY * depth, rho0=1000.0, c0=c0)
        rho = rho if still is None else still
    run_length = 1 if (periodic[0] or grid.shape[0] < 3) else 3
    k, cell_cap = _capacities((cutoff + skin) / dx, run_length)
    k_now, cell_now = initial_list_sizes(fluid_x, x, grid, cutoff + skin)
    k = max(k, _ceil8(1.05 * k_now))
    cell_cap = max(cell_cap, _ceil8(1.05 * cell_now))
    return ParticleLayout(grid=grid, cutoff=cutoff, skin=skin, neighbour_capacity=k, cell_capacity=cell_cap,
                          wall_pair_capacity=wall_pair_capacity(fluid_x, wall_x, cutoff + skin), x=x, kind=kind,
                          vol=vol, rho=rho)


def fluid_scene(*, name: str, dx: float, fluid_x: np.ndarray, wall_x: np.ndarray, domain_lo, domain_hi,
                periodic, surface_z: float | None, c0: float, scheme: FluidScheme, h_factor: float, alpha: float, nu: float, delta: float, skin_factor: float,
                rebuild_every: int, cfl: float, meta: dict, wall_viscosity: float = 1.0) -> Scene:
    """Assemble a fluid-only scene from host point sets (used by the built-in builders);
    ``dx`` [m] and ``h_factor`` make its ``Resolution``."""
    res = Resolution(dx, h_factor)
    params = water_params(res, c0=c0, alpha=alpha, nu=nu, delta=delta, wall_viscosity=wall_viscosity)
    L = particle_layout(res, fluid_x=fluid_x, wall_x=wall_x, domain_lo=domain_lo, domain_hi=domain_hi,
                        periodic=periodic, surface_z=surface_z, c0=c0, scheme=scheme, skin_factor=skin_factor)
    dt = stable_dt(params, scheme=scheme, cfl=cfl)
    config = Config(
        n_fluid=len(fluid_x), n_wall=len(wall_x), dt=dt, grid=L.grid, cutoff=L.cutoff, skin=L.skin,
        rebuild_every=rebuild_every, capacities=Capacities(neighbours=L.neighbour_capacity, cells=L.cell_capacity,
                                                           wall_pairs=L.wall_pair_capacity), scheme=scheme, cfl=cfl,
    )
    state = make_state(config=config, x=L.x, kind=L.kind, vol=L.vol, rho=L.rho)
    return Scene(config=config, params=params, state=state, meta=SceneMeta.from_dict(dict(meta, name=name, dx=dx)))
