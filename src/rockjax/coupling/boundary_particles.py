"""Boundary particles carried by blocks (as DualSPHysics does for floating bodies).

Layers of particles sampled inside each moving block (``scenes.block_sampling``: dx/2, 3dx/2,
... inside its faces) sit in the wall segment with ``Particles.body = b`` and their body-frame
position ``x_body``. Every step they are placed at the block's new pose with the block's point
velocity (``place``); the fluid meets them as wall particles (Adami pressure, no-slip through the
viscous term). The load on block b is minus the sum of the forces its particles exert on the
fluid (``load``; in a WCSPH step ``from_pair_forces``, from the momentum pass's own pair terms):
``F_b = -sum_i m_i a_i^(b)`` where ``a_i^(b)`` is the SPH acceleration of
fluid particle i from the particles of block b alone, and the torque
``T_b = -sum_i (x_i - X_b) x m_i a_i^(b)`` -- exact for central pair forces (pressure and
artificial viscosity act along x_i - x_j), so momentum and angular momentum are exchanged
exactly. Adami's extrapolation uses gravity, not ``g - a_block`` (the block's acceleration is
neglected in the wall pressure, an O(a_block / g) error while the block accelerates).
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp

from ..sph import seed, wcsph
from ..sph.neighbours import pairs, take
from ..types import Config, CouplingState, Kind, NeighbourList, Params, Particles
from ..blocks.rotation import quat_matrix
from . import penalty
from .base import CouplingMethod
from .penalty import coupled_blocks

__all__ = ["BoundaryParticles", "place", "load", "from_accelerations", "from_pair_forces"]


@dataclasses.dataclass(frozen=True)
class BoundaryParticles(CouplingMethod):
    """Particles carried by the moving blocks take part in the SPH sums (``Coupling.BOUNDARY_PARTICLES``;
    module docstring); the loads come out of the scheme's own momentum pass over the list's
    (fluid, block particle) pairs, so the exchange is the reaction of exactly what the fluid gets.

    ``guard``: also the seed Eq 22 penalty within ``CouplingParams.interaction_distance`` of a face
    (dx/4 by default, where no particle sits at rest: the first layer stays ~dx/2 from the face), so
    that no water pressed between a block's particles enters it; the reaction is added to the loads
    (``Config.coupling_guard``). ``guard_fixed``: guard the FIXED blocks' faces too, which the water
    meets as wall particles (``penalty.guard_fixed``: a kick, no load; ``Config.guard_fixed``).
    """

    name = "boundary_particles"
    body_pairs = True
    guard: bool = True
    guard_fixed: bool = False

    def place(self, state, params, config):
        return state.replace(particles=place(state.particles, state.blocks, config))

    def exchange(self, state, params, config, *, kick: bool):
        loads = load(state.particles, state.nbrs, state.blocks, params, config)
        return self._guarded(state.replace(coupling=loads), params, config, kick=kick)

    def fluid_step(self, state, params, config):
        from ..sph.schemes import SeedScheme

        bodies = coupled_blocks(config)
        if not bodies:
            return super().fluid_step(state, params, config)
        # the loads come out of the momentum pass (the reaction of exactly what the fluid gets)
        P, out = config.scheme.advance(state.particles, state.nbrs, params, config, bodies=bodies)
        if isinstance(config.scheme, SeedScheme):  # its forces at the start of the step (symplectic
            # Euler), per block, with the lever arms from the positions they acted at (before the drift)
            loads = from_accelerations(state.particles, out, bodies, state.blocks, params, config)
        else:  # WCSPH: the momentum pass's pair forces on the (fluid, block particle) pairs
            loads = from_pair_forces(P, out, bodies, state.blocks)
        return self._guarded(state.replace(particles=P, coupling=loads), params, config, kick=True)

    def _guarded(self, state, params, config, *, kick: bool):
        """With ``guard``: the penalty within dx/4 of a face added to the loads; with ``kick`` the
        fluid is kicked by dt times it (in a step), else only the load is added (at priming)."""
        if not self.guard:
            return state
        if kick:
            P, g = penalty.apply(state.particles, state.blocks, params, config)
            if self.guard_fixed:
                P = penalty.guard_fixed(P, state.blocks, params, config)
        else:
            P, g = state.particles, penalty.load(state.particles, state.blocks, params, config)
        c = state.coupling
        return state.replace(particles=P, coupling=c.replace(force=c.force + g.force, torque=c.torque + g.torque))


def place(P: Particles, blocks, config: Config) -> Particles:
    """Particles of the blocks moved to the blocks' poses, with the blocks' point velocities.

    With ``config.n_block_particles`` only that tail of the arrays is touched (every particle a
    block carries is there); the rotation is written as multiply-adds (a batched [N, 3, 3] matvec
    went through a matmul library call on CPU)."""
    start = P.x.shape[0] - config.n_block_particles if config.n_block_particles else 0
    body, x_body = P.body[start:], P.x_body[start:]
    on = body >= 0
    b = jnp.where(on, body, 0)
    r = jnp.sum(quat_matrix(blocks.q)[b] * x_body[:, None, :], axis=-1)  # R x_body, [n, 3]
    x = jnp.where(on[:, None], blocks.x[b] + r, P.x[start:])
    v = jnp.where(on[:, None], blocks.v[b] + jnp.cross(blocks.omega[b], r), P.v[start:])
    return P.replace(x=jnp.concatenate([P.x[:start], x]), v=jnp.concatenate([P.v[:start], v]))


def load(P: Particles, nbrs: NeighbourList, blocks, params: Params, config: Config) -> CouplingState:
    """Fluid force [B, 3] N and torque [B, 3] N m on each block, for the current particles.

    A momentum sum per coupled block with the scheme's own pair forces (used at priming); a step
    gets the same pair terms from its own force pass (``wcsph.advance(..., bodies=...)`` with
    ``from_pair_forces``, ``seed.advance(..., bodies=...)`` with ``from_accelerations``). DFSPH has
    no pressure before its first solves: zero at priming (its steps give ``from_pair_forces``).
    """
    nf = config.n_fluid
    bodies = coupled_blocks(config)
    from ..sph.schemes import DFSPH, SeedScheme

    if isinstance(config.scheme, DFSPH):  # no pressure before its first solve: that step gives the loads
        zero = jnp.zeros((blocks.x.shape[0], 3), P.x.dtype)
        return CouplingState(force=zero, torque=zero)
    pr = pairs(P.x, P.kind, nbrs.idx, config)
    if isinstance(config.scheme, SeedScheme):
        return from_accelerations(P, seed.body_accelerations(pr, P, bodies, params, config), bodies, blocks, params,
                                  config)
    body_j = P.body[pr.idx]
    extra = wcsph.momentum_extra(P.x, P.v, P.rho, P.vol, P.kind, nbrs, params, config)
    v_m = wcsph.viscous_velocity(P.x, P.v, P.kind, nbrs, params, config)
    acc = []
    for b in bodies:
        only_b = pr._replace(mask=pr.mask & (body_j == b))
        acc.append(wcsph.acceleration(only_b, v_m, P.rho, P.p, P.vol, P.kind, params, config, extra=extra)[:nf]
                   - params.gravity)
    return from_accelerations(P, jnp.stack(acc, axis=1), bodies, blocks, params, config)


def from_accelerations(P: Particles, acc_bodies, bodies: tuple[int, ...], blocks, params: Params,
                       config: Config) -> CouplingState:
    """Loads on the blocks from ``acc_bodies`` [n_fluid, len(bodies), 3] m/s^2, the acceleration of
    each fluid particle due to each block's particles: ``F_b = -sum_i m_i a_i^(b)``,
    ``T_b = -sum_i (x_i - X_b) x m_i a_i^(b)``.
    """
    nf = config.n_fluid
    m = params.fluid.rho0 * P.vol[:nf]
    fluid = P.kind[:nf] == Kind.FLUID
    if P.owned is not None:  # a decomposed scene: halo copies' reactions are counted by their owners
        fluid = fluid & P.owned[:nf]
    n_blocks = blocks.x.shape[0]
    force = jnp.zeros((n_blocks, 3), P.x.dtype)
    torque = jnp.zeros((n_blocks, 3), P.x.dtype)
    for k, b in enumerate(bodies):
        f = jnp.where(fluid[:, None], m[:, None] * acc_bodies[:, k], 0.0)  # force of block b's particles on the fluid
        r = P.x[:nf] - blocks.x[b]
        force = force.at[b].set(-jnp.sum(f, 0))
        torque = torque.at[b].set(-jnp.sum(jnp.cross(r, f), 0))
    return CouplingState(force=force, torque=torque)


def from_pair_forces(P: Particles, pair_forces, bodies: tuple[int, ...], blocks) -> CouplingState:
    """Loads on the blocks ``bodies`` from ``pair_forces = (row [M], col [M], (fx, fy, fz) [M] N)``,
    the force on fluid particle ``row`` from block particle ``col`` (``wcsph.advance(...,
    bodies=...)``; zero for the pairs that do not count), optionally fourth the positions [N, 3]
    the rows had when it acted (``dfsph.advance``; default ``P.x``): ``F_b = -sum f``,
    ``T_b = -sum (x_row - X_b) x f`` over the pairs whose ``col`` is carried by block b (masked
    sums per block, component by component)."""
    row, col, f = pair_forces[:3]
    x_rows = pair_forces[3] if len(pair_forces) > 3 else P.x  # where the forces acted, if not P.x
    body = take(P.body, col)
    if P.owned is not None:  # a decomposed scene: halo copies' reactions are counted by their owners
        body = jnp.where(take(P.owned, row), body, -1)
    x = [take(x_rows[:, a], row) for a in range(3)]
    n_blocks = blocks.x.shape[0]
    force = jnp.zeros((n_blocks, 3), P.x.dtype)
    torque = jnp.zeros((n_blocks, 3), P.x.dtype)
    for b in bodies:
        on = body == b
        fb = [jnp.where(on, f[a], 0.0) for a in range(3)]
        r = [x[a] - blocks.x[b, a] for a in range(3)]
        t = [r[1] * fb[2] - r[2] * fb[1], r[2] * fb[0] - r[0] * fb[2], r[0] * fb[1] - r[1] * fb[0]]
        force = force.at[b].set(-jnp.stack([jnp.sum(c) for c in fb]))
        torque = torque.at[b].set(-jnp.stack([jnp.sum(c) for c in t]))
    return CouplingState(force=force, torque=torque)
