"""``make_step(config)``: one pure ``step(state, params) -> state`` composed of the stages the
config switches on, plus the two stages the rollout uses directly (``refresh`` and ``advance``).

Stages decided at trace time from the static ``Config`` (a Python ``if``, so a stage that is off
is never traced):

* ``refresh``: re-sort particles by cell and rebuild the Verlet list (every ``rebuild_every``
  steps) -- only when the scene has particles;
* blocks (``config.blocks``): contacts and one central-difference step of the rock blocks
  (``rockjax.blocks``), with the fluid loads of the previous step as external forces;
* the coupling method (``config.coupling_method``, ``coupling.base``): ``place`` puts what the
  blocks carry for the fluid at their new poses (boundary particles), ``fluid_step`` advances the
  fluid (``config.scheme``, ``sph.schemes``) and exchanges momentum with the blocks (the penalty of
  seed Eq 22, the boundary particles' pair forces, the wall term), storing the loads for the
  blocks' next step; with no coupling, the scheme's step alone;
* absorbers (``config.absorbers``, ``sph.absorbers``): damping zones applied to the water after
  the fluid step;
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
from .types import Config, Kind, Params, State, Status

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


def max_displacement2(x, x_ref, active, config: Config) -> jax.Array:
    """The largest squared distance [m^2] of an ``active`` particle at ``x`` [N, 3] from its list
    build position ``x_ref`` (nearest image on periodic axes): the list holds while it stays
    below ``(skin / 2)^2`` (``check``, ``rollout.needs_rebuild``).

    The fixed walls ``[n_fluid, n_particles - n_block_particles)`` never move (the list build keeps
    them sorted on that ground) and are skipped: in a tank they outnumber the water several times,
    and this runs every step."""
    nf, nb, n = config.n_fluid, config.n_block_particles, config.n_particles
    if x.shape[0] == n and n - nb > nf:
        moving = lambda a: jnp.concatenate([a[:nf], a[n - nb:]])  # noqa: E731
        x, x_ref, active = moving(x), moving(x_ref), moving(active)
    g = config.grid
    disp = x - x_ref
    if any(g.periodic):
        L = jnp.asarray(g.lengths, disp.dtype)
        disp = jnp.where(jnp.asarray(g.periodic), disp - L * jnp.round(disp / L), disp)
    return jnp.max(jnp.where(active, jnp.sum(disp * disp, -1), 0.0))


def _stale(x, x_ref, active, config: Config) -> jax.Array:
    """``Status.NEIGHBOUR_STALE`` where an ``active`` particle at ``x`` [N, 3] is more than
    ``skin / 2`` from the list's build position ``x_ref`` (integer scalar)."""
    return jnp.where(max_displacement2(x, x_ref, active, config) > (0.5 * config.skin) ** 2, Status.NEIGHBOUR_STALE, 0)


def check(state: State, params: Params, config: Config, *, stale=None) -> jax.Array:
    """Status bits [int32] for the particles just produced: finiteness, domain, list staleness, dt.

    ``stale``: the staleness bits of the positions the step's sums used, when the step computed
    them (a scheme whose sums use the step's start: ``advance``); else they are those of ``state``."""
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

    status |= _stale(P.x, state.nbrs.x_ref, active, config) if stale is None else stale

    f = params.fluid
    if f is None or config.n_fluid == 0:
        return status.astype(jnp.int32)
    fluid = P.kind == Kind.FLUID
    vmax = jnp.sqrt(jnp.max(jnp.where(fluid, jnp.sum(P.v * P.v, -1), 0.0)))
    unstable = config.scheme.unstable_dt(config.dt, params, vmax)
    status |= jnp.where(unstable, Status.UNSTABLE_DT, 0)
    solver_bits = config.scheme.solver_status(P)
    if solver_bits is not None:
        status |= solver_bits
    return status.astype(jnp.int32)


def _advance_blocks(state: State, params: Params, config: Config) -> State:
    from . import blocks

    force = torque = None
    if state.coupling is not None:
        force, torque = state.coupling.force, state.coupling.torque
    t = state.step * config.dt
    n = config.block_substeps
    if n == 1:
        B, status = blocks.advance_blocks(state.blocks, params.blocks, config.blocks, dt=config.dt, t=t,
                                          gravity=params.gravity, external_force=force, external_torque=torque)
        return state.replace(blocks=B, status=state.status | status)
    dt = config.block_dt

    def sub(k, carry):  # a fixed count of block steps under the step's fluid load
        B, status = carry
        B, bits = blocks.advance_blocks(B, params.blocks, config.blocks, dt=dt, t=t + k * dt, gravity=params.gravity,
                                        external_force=force, external_torque=torque)
        return B, status | bits

    B, status = jax.lax.fori_loop(0, n, sub, (state.blocks, jnp.zeros((), jnp.int32)))
    return state.replace(blocks=B, status=state.status | status)


def advance(state: State, params: Params, config: Config) -> State:
    """One time step with the current neighbour list (no rebuild): blocks, then the coupling
    method's ``place`` and ``fluid_step`` (``coupling.base``), then the checks."""
    coupling = config.coupling_method
    if config.has_blocks:
        state = _advance_blocks(state, params, config)
    state = coupling.place(state, params, config)
    stale = None
    if config.scheme.sums_at_start and config.has_particles:  # the positions its sums use: these
        P = jax.lax.stop_gradient(state.particles)
        stale = _stale(P.x, state.nbrs.x_ref, P.kind != Kind.PAD, config)
    if config.n_fluid > 0:
        state = coupling.fluid_step(state, params, config)
    for absorber in config.absorbers:
        state = state.replace(particles=absorber.apply(state.particles, config.dt))
    state = state.replace(step=state.step + 1)
    return state.replace(status=state.status | check(state, params, config, stale=stale))


@functools.partial(jax.jit, static_argnames=("config",))
def prime(state: State, params: Params, config: Config) -> State:
    """Rebuild the list and fill accelerations / density rates (and the fluid load on the blocks)
    for the initial positions.

    Compiled once per static ``config`` (``jax.jit``; inside another trace it is inlined): op by op
    it took ~30 s on 2 CPU cores for a small coupled scene."""
    coupling = config.coupling_method
    state = refresh(coupling.place(state, params, config), config)
    if config.n_fluid > 0:
        state = coupling.prime(state, params, config)
    return state


def make_step(config: Config, *, tuning=None):
    """Return the pure ``step(state, params) -> state`` for this static config (with ``tuning``,
    speed settings replacing ``config.tuning``: ``rockjax.Tuning``).

    The step rebuilds the neighbour list when ``state.step % config.rebuild_every == 0`` and then
    advances by ``config.dt``. It is jittable, differentiable and vmappable. For long runs prefer
    ``rollout``, which rebuilds at block starts without a ``lax.cond``.
    """
    if tuning is not None:
        config = config.replace(tuning=tuning)

    def step(state: State, params: Params) -> State:
        due = state.step % config.rebuild_every == 0
        state = jax.lax.cond(due, lambda s: refresh(s, config), lambda s: s, state)
        return advance(state, params, config)

    return step


def kernel_support(params: Params) -> jax.Array:
    """Kernel support radius 2h [m] for these params."""
    return SUPPORT_FACTOR * params.fluid.h

