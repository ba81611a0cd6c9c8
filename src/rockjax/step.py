"""``make_step(config)``: one pure ``step(state, params) -> state`` composed of the stages the
config switches on, plus the two stages the rollout uses directly (``refresh`` and ``advance``).

Stages decided at trace time from the static ``Config`` (a Python ``if``, so a stage that is off
is never traced):

* ``refresh``: re-sort particles by cell and rebuild the Verlet list (every ``rebuild_every``
  steps) -- only when the scene has particles;
* blocks (``config.blocks``): contacts and one central-difference step of the rock blocks
  (``rockjax.blocks``), with the fluid loads of the previous step as external forces;
* boundary particles (``Coupling.BOUNDARY_PARTICLES``): particles carried by blocks are placed at
  the new block poses before the fluid sees them;
* fluid (``config.n_fluid > 0``): ``config.scheme`` (``sph.schemes``: ``WCSPH`` or ``SeedScheme``);
* coupling: ``Coupling.PENALTY``, seed Eq 22 on the fluid at the end of the step, the reaction
  stored for the blocks' next step (``coupling.penalty``); ``Coupling.BOUNDARY_PARTICLES``, the
  loads of the block particles from the WCSPH momentum pass's pair terms, over the list's short
  sub-list of (fluid, block particle) pairs (``NeighbourList.body_row``; ``coupling.boundary_particles``),
  plus, with ``config.coupling_guard``, the penalty within dx/4 of a face as a guard against
  water pressed into a block between its particles (and, with ``config.guard_fixed``, into a fixed
  block between the walls' particles);
* checks: non-finite values, particles off the grid, stale neighbour list, time step beyond the
  stability limit; each sets a ``Status`` bit for the host driver.

Order within a step (time t -> t + dt): blocks advance with contact forces at t and the fluid
load computed at the end of the previous step (the state at t); block particles move to the new
poses; the fluid advances (kick-drift-kick); the penalty force at t + dt kicks the fluid and is
stored for the blocks. Every exchange of momentum is equal and opposite.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp

from .sph.neighbours import rebuild
from .sph.kernels import SUPPORT_FACTOR
from .types import Config, Coupling, Kind, Params, State, Status

__all__ = ["make_step", "refresh", "advance", "prime", "check"]


@functools.partial(jax.jit, static_argnames=("config",))
def refresh(state: State, config: Config) -> State:
    """Sort particles by cell and rebuild the neighbour list; OR its status bits into the state.

    A no-op in a scene without particles. Compiled once per static ``config`` (``jax.jit``, as
    ``prime``; inside another trace it is inlined).
    """
    if not config.has_particles:
        return state
    particles, nbrs, status = rebuild(state.particles, config)
    nbrs = nbrs.replace(
        max_count=jnp.maximum(nbrs.max_count, state.nbrs.max_count),
        max_run=jnp.maximum(nbrs.max_run, state.nbrs.max_run),
        max_wall_count=jnp.maximum(nbrs.max_wall_count, state.nbrs.max_wall_count),
        max_body_count=jnp.maximum(nbrs.max_body_count, state.nbrs.max_body_count),
    )
    return state.replace(particles=particles, nbrs=nbrs, status=state.status | status)


def check(state: State, params: Params, config: Config) -> jax.Array:
    """Status bits [int32] for the particles just produced: finiteness, domain, list staleness, dt."""
    if not config.has_particles:
        return jnp.zeros((), jnp.int32)
    P = state.particles
    active = P.kind != Kind.PAD
    finite = jnp.isfinite(P.x).all(-1) & jnp.isfinite(P.v).all(-1) & jnp.isfinite(P.rho)
    status = jnp.where(jnp.all(finite | ~active), 0, Status.NON_FINITE)

    g = config.grid
    lo = jnp.asarray(g.origin, P.x.dtype)
    hi = jnp.asarray(g.upper, P.x.dtype)
    out = ((P.x < lo) | (P.x >= hi)) & ~jnp.asarray(g.periodic)
    status |= jnp.where(jnp.any(out.any(-1) & active), Status.OUT_OF_DOMAIN, 0)

    disp = P.x - state.nbrs.x_ref
    if any(g.periodic):
        L = jnp.asarray(g.lengths, P.x.dtype)
        disp = jnp.where(jnp.asarray(g.periodic), disp - L * jnp.round(disp / L), disp)
    max_disp2 = jnp.max(jnp.where(active, jnp.sum(disp * disp, -1), 0.0))
    status |= jnp.where(max_disp2 > (0.5 * config.skin) ** 2, Status.NEIGHBOUR_STALE, 0)

    f = params.fluid
    if f is None or config.n_fluid == 0:
        return status.astype(jnp.int32)
    fluid = P.kind == Kind.FLUID
    vmax = jnp.sqrt(jnp.max(jnp.where(fluid, jnp.sum(P.v * P.v, -1), 0.0)))
    unstable = config.scheme.unstable_dt(config.dt, params, vmax)
    status |= jnp.where(unstable, Status.UNSTABLE_DT, 0)
    return status.astype(jnp.int32)


def _advance_blocks(state: State, params: Params, config: Config) -> State:
    from . import blocks

    force = torque = None
    if state.coupling is not None:
        force, torque = state.coupling.force, state.coupling.torque
    t = state.step * config.dt
    B, status = blocks.advance_blocks(state.blocks, params.blocks, config.blocks, dt=config.dt, t=t,
                                      gravity=params.gravity, external_force=force, external_torque=torque)
    return state.replace(blocks=B, status=state.status | status)


def _place_block_particles(state: State, config: Config) -> State:
    """Move the particles carried by blocks to the blocks' poses (boundary-particle coupling)."""
    if config.coupling != Coupling.BOUNDARY_PARTICLES:
        return state
    from .coupling import boundary_particles

    return state.replace(particles=boundary_particles.place(state.particles, state.blocks, config))


def _fluid_load(state: State, params: Params, config: Config, *, kick: bool) -> State:
    """The fluid's load on the blocks for the current particles; with ``kick`` the penalty
    coupling also kicks the fluid by dt times its acceleration (in a step, not at priming)."""
    if config.coupling == Coupling.BOUNDARY_PARTICLES:
        from .coupling import boundary_particles

        state = state.replace(coupling=boundary_particles.load(state.particles, state.nbrs, state.blocks, params,
                                                               config))
        return _guard(state, params, config, kick=kick)
    if config.coupling in (Coupling.PENALTY, Coupling.BOUNDARY_INTEGRAL):  # the wall term: penalty.accelerations
        from .coupling import penalty

        if kick:
            P, load = penalty.apply(state.particles, state.blocks, params, config)
            return state.replace(particles=P, coupling=load)
        return state.replace(coupling=penalty.load(state.particles, state.blocks, params, config))
    return state


def _guard(state: State, params: Params, config: Config, *, kick: bool) -> State:
    """Boundary particles with ``config.coupling_guard``: the seed Eq 22 penalty on the fluid within
    ``params.coupling.interaction_distance`` of a block face (dx/4 by default, where no particle
    sits at rest: the first layer stays ~dx/2 from the face), so that water pressed between a
    block's particles cannot enter it; the equal and opposite reaction is added to the loads.
    With ``kick`` the fluid is kicked by dt times it (in a step), else only the load is added;
    with ``config.guard_fixed`` the FIXED blocks' faces too (``penalty.guard_fixed``: a kick, no load)."""
    if config.coupling != Coupling.BOUNDARY_PARTICLES or not config.coupling_guard:
        return state
    from .coupling import penalty

    if kick:
        P, g = penalty.apply(state.particles, state.blocks, params, config)
        if config.guard_fixed:
            P = penalty.guard_fixed(P, state.blocks, params, config)
    else:
        P, g = state.particles, penalty.load(state.particles, state.blocks, params, config)
    c = state.coupling
    return state.replace(particles=P, coupling=c.replace(force=c.force + g.force, torque=c.torque + g.torque))


def _load_bodies(config: Config) -> tuple[int, ...]:
    """Blocks whose boundary-particle loads a step takes from its own force pass (else ())."""
    if config.coupling != Coupling.BOUNDARY_PARTICLES:
        return ()
    from .coupling.penalty import coupled_blocks

    return coupled_blocks(config)


def advance(state: State, params: Params, config: Config) -> State:
    """One time step with the current neighbour list (no rebuild)."""
    if config.has_blocks:
        state = _advance_blocks(state, params, config)
    state = _place_block_particles(state, config)
    if config.n_fluid > 0:
        bodies = _load_bodies(config)
        if bodies:
            # the loads come out of the momentum pass (the reaction of exactly what the fluid gets)
            from .coupling import boundary_particles
            from .sph.schemes import SeedScheme

            if not isinstance(config.scheme, SeedScheme):
                P, pair_forces = config.scheme.advance(state.particles, state.nbrs, params, config, bodies=bodies)
                load = boundary_particles.from_pair_forces(P, pair_forces, bodies, state.blocks)
            else:  # the seed scheme's forces at the start of the step (symplectic Euler), per block
                P, acc_bodies = config.scheme.advance(state.particles, state.nbrs, params, config, bodies=bodies)
                # lever arms from the positions the forces acted at (before the drift)
                load = boundary_particles.from_accelerations(state.particles, acc_bodies, bodies, state.blocks, params,
                                                             config)
            state = _guard(state.replace(particles=P, coupling=load), params, config, kick=True)
        else:
            P = config.scheme.advance(state.particles, state.nbrs, params, config)
            state = _fluid_load(state.replace(particles=P), params, config, kick=True)
    state = state.replace(step=state.step + 1)
    return state.replace(status=state.status | check(state, params, config))


@functools.partial(jax.jit, static_argnames=("config",))
def prime(state: State, params: Params, config: Config) -> State:
    """Rebuild the list and fill accelerations / density rates (and the fluid load on the blocks)
    for the initial positions.

    Compiled once per static ``config`` (``jax.jit``; inside another trace it is inlined): op by op
    it took ~30 s on 2 CPU cores for a small coupled scene."""
    state = refresh(_place_block_particles(state, config), config)
    if config.n_fluid > 0:
        P = config.scheme.prime(state.particles, state.nbrs, params, config)
        state = _fluid_load(state.replace(particles=P), params, config, kick=False)
    return state


def make_step(config: Config):
    """Return the pure ``step(state, params) -> state`` for this static config.

    The step rebuilds the neighbour list when ``state.step % config.rebuild_every == 0`` and then
    advances by ``config.dt``. It is jittable, differentiable and vmappable. For long runs prefer
    ``rollout``, which rebuilds at block starts without a ``lax.cond``.
    """

    def step(state: State, params: Params) -> State:
        due = state.step % config.rebuild_every == 0
        state = jax.lax.cond(due, lambda s: refresh(s, config), lambda s: s, state)
        return advance(state, params, config)

    return step


def kernel_support(params: Params) -> jax.Array:
    """Kernel support radius 2h [m] for these params."""
    return SUPPORT_FACTOR * params.fluid.h

