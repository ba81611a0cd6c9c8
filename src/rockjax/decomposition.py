"""One scene over many devices: slabs along x, halo exchange and migration with ``shard_map``.

This module owns the domain decomposition of a scene's particles over a 1-D device ``Mesh``
(axis ``AXIS``). It knows nothing of the physics: each device runs the unchanged
``step.advance`` on a *local* scene (``Decomposition.local``, a ``Config`` whose fluid segment is
the device's own particles plus two halo layers) and this module keeps the local scenes consistent,
as jax-md's ``partition`` keeps a neighbour list: ``decompose`` allocates on the host,
``make_sharded_rollout`` updates in jit, and overflow sets a status bit.

Layout of a device's fluid segment (``owned + 2 halo`` slots, sorted by cell at each rebuild, so
the three kinds are mixed; ``Slab.owned`` marks the device's own rows):

* **owned**: fluid particles whose x lies in the device's slab ``[lo, hi)`` at the last rebuild
  (``lo = -inf`` on the first device, ``hi = +inf`` on the last);
* **halo**: copies of the neighbouring devices' owned particles within ``halo_width`` of the slab,
  ``halo_layers (cutoff + skin)``: a row's momentum sum reads its neighbours' new pressures, a
  wall neighbour's Adami pressure reads the fluid around that wall, and their new densities come
  from the step's continuity sum over *their* neighbours: three chained pair passes, so three
  layers for ``WCSPH`` with Adami walls (with two layers the trajectories of particles on a slab
  bound differ from one device's by ~1e-11 of their acceleration per step). Their full records
  (position, velocity, density, acceleration, ...) are copied from the owner with
  ``lax.ppermute`` at the start of **every** step, into the slots fixed at the last rebuild, so
  the local Verlet list stays valid between rebuilds; the local step's results on halo rows are
  discarded (overwritten at the next exchange).
* padding (``Kind.PAD``): free slots.

At a rebuild (at the start of each block of ``Config.rebuild_every`` steps, and when any device's
displacement trigger fires, ``rollout.needs_rebuild`` reduced with ``lax.pmax``), all devices
together: send the owned particles that left the slab to the neighbour (*migration*), compact
the owned rows, choose and send the halo layers, sort the local fluid segment by cell, and build
the local list (``step.refresh``). Walls are static: each device holds the walls within
``halo_width + cutoff + 2 skin`` of its slab, chosen once on the host.

Slab bounds are chosen on the host from the fluid's x quantiles (equal particle counts) or given;
they stay fixed within a compiled rollout. Buffers have fixed sizes (``owned``, ``halo``,
``migrate``); an overflow sets ``Status.SLAB_OVERFLOW``. The host driver ``run_sharded`` runs in
chunks and re-decomposes between them: with larger buffers after an overflow (rerunning the
chunk), at equal counts when the slabs drift apart (load balance).

Blocks are few: every device holds all of them (and all the particles they carry, the tail of
its wall segment) and advances them identically; each device's fluid loads count its owned rows
only (``Particles.owned``, read by the couplings' reductions) and are summed over the devices
(``lax.psum``) after each fluid step, so every device applies the same loads.

An implicit scheme (``DFSPH``) updates pressures and velocities in sweeps that the neighbours read:
while a device's step is traced, its exchange is current (``sph.halo``), through which every
sweep refreshes its halo rows and the solve's mean residual is summed over the devices (every
device runs the same sweeps).

Many hosts (one process per GPU; written for JAX's multi-process runtime, tested here only with
one process and forced CPU devices)::

    # launched once per GPU, e.g. `srun -n 16 python run.py` (SLURM), or by hand on each host
    import jax
    jax.distributed.initialize()          # from the cluster's environment, or pass
                                          # coordinator_address="host0:1234", num_processes, process_id
    from rockjax import decomposition as D, scenes
    scene = scenes.dam_break(dx=...)      # every process builds the same scene (deterministic)
    mesh = D.make_mesh(jax.device_count())             # all processes' devices, in process order
    dec, ss = D.decompose(scene, jax.device_count())
    ss = D.place(ss, mesh)                 # each process puts only its own devices' slabs
    ss = D.sharded_prime(dec, ss, scene.params, mesh=mesh)
    ss = jax.jit(D.make_sharded_rollout(dec, 800, mesh=mesh, checkpoint=False))(ss, scene.params)
    out = D.gather_fluid(dec, ss)          # on every process (process_allgather)
    # or all of it: D.run_sharded(scene, jax.device_count(), n_steps, mesh=mesh, out="run.h5")
    # (process 0 writes the one run file)
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, NamedTuple, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec as PSpec

from .rollout import n_blocks_for, needs_rebuild
from .sph import halo
from .sph.neighbours import cell_order
from .step import advance, refresh
from .types import Config, Kind, Params, State, Status, _pytree_dataclass

__all__ = ["AXIS", "Decomposition", "Slab", "ShardedState", "decompose", "make_mesh", "make_sharded_rollout",
           "sharded_prime", "place", "gather_fluid", "gather_state", "run_sharded", "ShardedRun", "slab_status"]

AXIS = "slabs"  #: name of the device mesh axis the slabs are laid along


@_pytree_dataclass
class Slab:
    """A device's bookkeeping (leaves per device; stacked along a leading device axis outside
    ``shard_map``).

    Attributes:
        owned: [n_local] bool, rows of the local fluid segment this device owns.
        send_l, send_r: [halo] int32, local rows sent each step to the left / right neighbour.
        recv_l, recv_r: [halo] int32, local rows the left / right neighbour's rows are written to
            (``n_local`` = none: dropped).
        lo, hi: the slab's bounds along x [m] (-inf / +inf at the ends).
        status: ``Status.SLAB_OVERFLOW`` when a buffer overflowed (int32).
        migrated: particles this device sent to a neighbour since the start (int32).
        halo_sent: rows sent at the last rebuild (both sides; int32).
        owned_count: owned particles at the last rebuild (int32).
    """

    owned: jax.Array
    send_l: jax.Array
    send_r: jax.Array
    recv_l: jax.Array
    recv_r: jax.Array
    lo: jax.Array
    hi: jax.Array
    status: jax.Array
    migrated: jax.Array
    halo_sent: jax.Array
    owned_count: jax.Array


@_pytree_dataclass
class ShardedState:
    """The local ``State`` and ``Slab`` of every device, stacked along a leading axis of length
    ``Decomposition.n_slabs`` (the mesh axis)."""

    state: State
    slab: Slab


@dataclasses.dataclass(frozen=True)
class Decomposition:
    """Static description of a decomposed scene (hashable).

    Attributes:
        config: the scene's own ``Config`` (one device).
        local: each device's ``Config``: fluid segment ``owned + 2 halo`` slots, its wall window.
        n_slabs: devices along x.
        owned, halo, migrate: per-device buffer sizes (rows): owned particles, one halo layer,
            migrants to one side per rebuild.
        halo_width: the halo layer's width [m] (``halo_layers (cutoff + skin)``).
        bounds: the interior slab bounds along x [m] (``n_slabs - 1`` values).
        n_water: the scene's water particles (all devices together).
    """

    config: Config
    local: Config
    n_slabs: int
    owned: int
    halo: int
    migrate: int
    halo_width: float
    bounds: tuple
    n_water: int

    @property
    def n_local(self) -> int:
        return self.local.n_fluid


def _ceil8(v: float) -> int:
    return max(8, int(math.ceil(v / 8.0)) * 8)


def make_mesh(n_slabs: int, devices: Optional[Sequence] = None) -> Mesh:
    """A 1-D ``Mesh`` of the first ``n_slabs`` devices (axis ``AXIS``); ValueError if fewer exist."""
    devs = list(jax.devices() if devices is None else devices)
    if len(devs) < n_slabs:
        raise ValueError(f"make_mesh: n_slabs = {n_slabs} needs as many devices, {len(devs)} available "
                         "(on the CPU: XLA_FLAGS=--xla_force_host_platform_device_count=N before JAX starts)")
    return Mesh(np.asarray(devs[:n_slabs]), (AXIS,))


def decompose(scene, n_slabs: int, *, bounds: Optional[Sequence[float]] = None, capacity_factor: float = 1.5,
              halo_layers: int = 3):
    """Split a scene's particles into ``n_slabs`` slabs along x (host side).

    Args:
        scene: a ``Scene`` with water (and walls, blocks), an explicit fluid scheme and x not
            periodic.
        n_slabs: devices along x (>= 1).
        bounds: the ``n_slabs - 1`` interior bounds along x [m], increasing; default: the fluid's
            x quantiles (equal counts). Each interior slab must be at least ``halo_width`` wide.
        capacity_factor: buffer sizes as a multiple of what the initial state needs (>= 1): the
            owned buffer must also hold the particles that flow into the slab during the run.
        halo_layers: the halo's width in list radii ``cutoff + skin``: the depth of the step's
            chained pair passes (module docstring; 3 for WCSPH with Adami walls).

    Returns:
        ``(Decomposition, ShardedState)``: the static description and the stacked initial states
        (unprimed; ``sharded_prime`` builds the lists and fills the accelerations).
    """
    from .scenes.base import empty_neighbours
    config, state = scene.config, scene.state
    n_slabs = int(n_slabs)
    if n_slabs < 1:
        raise ValueError(f"decompose: n_slabs must be >= 1 (got {n_slabs})")
    if not capacity_factor >= 1.0:
        raise ValueError(f"decompose: capacity_factor must be >= 1 (got {capacity_factor})")
    if config.n_fluid == 0:
        raise ValueError("decompose: the scene has no water to decompose")
    if config.grid.periodic[0]:
        raise ValueError("decompose: the grid is periodic along x; slabs are cut along a non-periodic x")

    P = jax.tree_util.tree_map(np.asarray, state.particles)
    nf = config.n_fluid
    fluid = P.kind[:nf] == Kind.FLUID
    xf = P.x[:nf][fluid, 0]
    if not (isinstance(halo_layers, int) and halo_layers >= 1):
        raise ValueError(f"decompose: halo_layers must be an integer >= 1 (got {halo_layers!r})")
    W = halo_layers * (config.cutoff + config.skin)
    if bounds is None:
        b = np.quantile(xf, np.arange(1, n_slabs) / n_slabs) if n_slabs > 1 else np.zeros(0)
    else:
        b = np.asarray(bounds, float).reshape(-1)
        if b.size != n_slabs - 1 or np.any(np.diff(b) <= 0):
            raise ValueError(f"decompose: bounds must be n_slabs - 1 = {n_slabs - 1} increasing x values (got {list(b)})")
    widths = np.diff(b)
    if np.any(widths < W):
        k = int(np.argmin(widths))
        raise ValueError(f"decompose: slab {k + 1} is {widths[k]:.4g} m wide, under the halo width "
                         f"{halo_layers} (cutoff + skin) = {W:.4g} m; use fewer slabs or pass wider bounds=")
    lo = np.concatenate([[-np.inf], b])
    hi = np.concatenate([b, [np.inf]])

    def in_slab(x, k, pad=0.0):
        return (x >= lo[k] - pad) & (x < hi[k] + pad)

    owned_n = [int(in_slab(xf, k).sum()) for k in range(n_slabs)]
    halo_n = [max(int((in_slab(xf, k) & (xf >= hi[k] - W)).sum()), int((in_slab(xf, k) & (xf < lo[k] + W)).sum()))
              for k in range(n_slabs)]
    C = min(_ceil8(capacity_factor * max(owned_n)), _ceil8(len(xf)))
    H = _ceil8(capacity_factor * max(max(halo_n), 1))
    M = H

    nb = config.n_block_particles  # carried by blocks: on every device, at the wall segment's end
    wall_x = P.x[nf:config.n_particles - nb, 0]
    Ww = W + config.cutoff + 2.0 * config.skin
    windows = [np.nonzero(in_slab(wall_x, k, Ww))[0] for k in range(n_slabs)]
    n_fixed = max(len(w) for w in windows) if len(wall_x) else 0
    n_wall = n_fixed + nb
    n_local = C + 2 * H
    local = config.replace(n_fluid=n_local, n_wall=n_wall)

    fluid_idx = np.nonzero(fluid)[0]
    stacked = []
    for k in range(n_slabs):
        mine = fluid_idx[in_slab(xf, k)]
        rows = np.concatenate([mine, np.full(n_local - len(mine), fluid_idx[0])])
        wrows = nf + windows[k]
        wrows = np.concatenate([wrows, np.full(n_fixed - len(wrows), wrows[0] if len(wrows) else nf)]).astype(int)
        take = np.concatenate([rows, wrows, np.arange(config.n_particles - nb, config.n_particles)]).astype(int)
        Pk = jax.tree_util.tree_map(lambda a: np.asarray(a)[take], P)
        kind = Pk.kind.copy()
        kind[len(mine):n_local] = Kind.PAD
        kind[n_local + len(windows[k]):n_local + n_fixed] = Kind.PAD
        pid = Pk.pid.copy()
        pid[kind == Kind.PAD] = -1
        owned = np.zeros(n_local, bool)
        owned[:len(mine)] = True
        Pk = Pk.replace(kind=kind, pid=pid)
        if config.has_blocks:  # the rows whose reactions on the blocks this device counts
            Pk = Pk.replace(owned=np.concatenate([owned, np.zeros(n_wall, bool)]))
        Pk = jax.tree_util.tree_map(jnp.asarray, Pk)
        st = State(step=jnp.asarray(state.step), particles=Pk, nbrs=empty_neighbours(local, Pk.x),
                   status=jnp.zeros((), jnp.int32), blocks=state.blocks, coupling=state.coupling)
        i32 = lambda v: jnp.asarray(v, jnp.int32)
        none = jnp.full((H,), n_local, jnp.int32)
        sl = Slab(owned=jnp.asarray(owned), send_l=jnp.zeros((H,), jnp.int32), send_r=jnp.zeros((H,), jnp.int32),
                  recv_l=none, recv_r=none, lo=jnp.asarray(lo[k], Pk.x.dtype), hi=jnp.asarray(hi[k], Pk.x.dtype),
                  status=i32(0), migrated=i32(0), halo_sent=i32(0), owned_count=i32(len(mine)))
        stacked.append(ShardedState(state=st, slab=sl))
    ss = jax.tree_util.tree_map(lambda *a: jnp.stack(a), *stacked)
    dec = Decomposition(config=config, local=local, n_slabs=n_slabs, owned=C, halo=H, migrate=M, halo_width=W,
                        bounds=tuple(float(v) for v in b), n_water=int(len(xf)))
    return dec, ss


# ------------------------------------------------------------------------------------------------
# In-jit pieces (per device, inside shard_map)
# ------------------------------------------------------------------------------------------------


def _rows(tree, idx):
    return jax.tree_util.tree_map(lambda a: a[idx], tree)


def _concat(*trees):
    return jax.tree_util.tree_map(lambda *a: jnp.concatenate(a), *trees)


def _compact(mask, size: int):
    """The first ``size`` indices where ``mask`` holds (0 past them), their validity, the count."""
    idx = jnp.nonzero(mask, size=size, fill_value=0)[0].astype(jnp.int32)
    count = jnp.sum(mask, dtype=jnp.int32)
    return idx, jnp.arange(size) < count, count


def _shift(tree, n: int, to_right: bool):
    """Send ``tree`` to the right (device d -> d + 1) or left neighbour; the end device receives zeros."""
    perm = [(d, d + 1) for d in range(n - 1)] if to_right else [(d + 1, d) for d in range(n - 1)]
    if not perm:
        return jax.tree_util.tree_map(jnp.zeros_like, tree)
    return jax.tree_util.tree_map(lambda a: jax.lax.ppermute(a, AXIS, perm), tree)


def _padded(rows, valid):
    """``rows`` with the invalid ones turned into padding: ``Kind.PAD``, pid -1 and density 1 (a
    row received from beyond the end device is zeros, and a masked ``2 / (rho_i + rho_j)`` of two
    zero densities is inf, whose zero cotangent is NaN)."""
    return rows.replace(kind=jnp.where(valid, rows.kind, Kind.PAD), pid=jnp.where(valid, rows.pid, -1),
                        rho=jnp.where(valid, rows.rho, 1.0))


def _split(P, nf: int):
    return _rows(P, slice(0, nf)), _rows(P, slice(nf, None))


def _rebuild(st: State, sl: Slab, dec: Decomposition):
    """Migrate, choose and send the halo layers, sort by cell and rebuild the local list."""
    cfg, n = dec.local, dec.n_slabs
    C, H, M, W = dec.owned, dec.halo, dec.migrate, dec.halo_width
    nf = cfg.n_fluid
    F, walls = _split(st.particles, nf)
    x0 = jax.lax.stop_gradient(F.x[:, 0])
    own = sl.owned & (F.kind != Kind.PAD)
    go_l, go_r = own & (x0 < sl.lo), own & (x0 >= sl.hi)
    stay = own & ~go_l & ~go_r
    il, vl, nl = _compact(go_l, M)
    ir, vr, nr = _compact(go_r, M)
    from_r, from_r_ok = _shift((_rows(F, il), vl), n, to_right=False)
    from_l, from_l_ok = _shift((_rows(F, ir), vr), n, to_right=True)
    i_s, v_s, _ = _compact(stay, C)
    cand = _concat(_rows(F, i_s), from_l, from_r)
    cand_ok = jnp.concatenate([v_s, from_l_ok, from_r_ok])
    io, vo, n_own = _compact(cand_ok, C)
    O = _padded(_rows(cand, io), vo)

    xo = jax.lax.stop_gradient(O.x[:, 0])
    isr, vsr, nsr = _compact(vo & (xo >= sl.hi - W), H)
    isl, vsl, nsl = _compact(vo & (xo < sl.lo + W), H)
    hl, hl_ok = _shift((_rows(O, isr), vsr), n, to_right=True)  # my left halo: the left neighbour's right layer
    hr, hr_ok = _shift((_rows(O, isl), vsl), n, to_right=False)
    L = _concat(O, _padded(hl, hl_ok), _padded(hr, hr_ok))
    owned = jnp.concatenate([vo, jnp.zeros((2 * H,), bool)])

    order = cell_order(jax.lax.stop_gradient(L.x), L.kind, cfg.grid)
    inv = jnp.zeros((nf,), jnp.int32).at[order].set(jnp.arange(nf, dtype=jnp.int32))
    L, owned = _rows(L, order), owned[order]
    slots = jnp.arange(H, dtype=jnp.int32)
    recv_l = jnp.where(hl_ok, inv[C + slots], nf)
    recv_r = jnp.where(hr_ok, inv[C + H + slots], nf)
    over = (nl > M) | (nr > M) | (n_own > C) | (nsr > H) | (nsl > H)
    sl = sl.replace(owned=owned, send_l=inv[isl], send_r=inv[isr], recv_l=recv_l, recv_r=recv_r,
                    status=sl.status | jnp.where(over, Status.SLAB_OVERFLOW, 0).astype(jnp.int32),
                    migrated=sl.migrated + jnp.minimum(nl, M) + jnp.minimum(nr, M),
                    halo_sent=jnp.minimum(nsr, H) + jnp.minimum(nsl, H), owned_count=n_own)
    P = _concat(L, walls)
    if cfg.has_blocks:  # the rows whose reactions on the blocks this device counts
        P = P.replace(owned=jnp.concatenate([owned, jnp.zeros((cfg.n_wall,), bool)]))
    st = refresh(st.replace(particles=P), cfg)  # the fluid segment is sorted: its order stays
    return st, sl


def _sync_rows(tree, sl: Slab, dec: Decomposition):
    """``tree`` (leaves [n_local, ...], the fluid segment) with the halo rows replaced by their
    owners' current rows (``lax.ppermute`` from both neighbours)."""
    n = dec.n_slabs
    hl = _shift(_rows(tree, sl.send_r), n, to_right=True)
    hr = _shift(_rows(tree, sl.send_l), n, to_right=False)
    return jax.tree_util.tree_map(lambda a, b, c: a.at[sl.recv_l].set(b, mode="drop").at[sl.recv_r].set(c, mode="drop"),
                                  tree, hl, hr)


def _exchange(st: State, sl: Slab, dec: Decomposition) -> State:
    """Copy the neighbours' current records of this device's halo rows (every step)."""
    F, walls = _split(st.particles, dec.local.n_fluid)
    F = _sync_rows(F, sl, dec)
    if F.owned is not None:  # copies stay copies here
        F = F.replace(owned=sl.owned)
    return st.replace(particles=_concat(F, walls))


@dataclasses.dataclass(frozen=True)
class _SlabExchange:
    """``sph.halo.Exchange`` of one device while its step is traced: an implicit scheme's sweeps
    refresh their halo rows and sum their residuals over the devices."""

    slab: Slab
    dec: Decomposition

    def sync(self, values):
        nf = self.dec.local.n_fluid
        rows = _sync_rows(values[:nf], self.slab, self.dec)
        return rows if values.shape[0] == nf else jnp.concatenate([rows, values[nf:]])

    def total(self, value):
        return jax.lax.psum(value, AXIS)

    def owned(self, n: int):
        return self.slab.owned[:n]


def _advance(st: State, sl: Slab, params: Params, dec: Decomposition) -> State:
    """``step.advance`` of the local scene with this device's exchange current, the loads summed."""
    with halo.exchanging(_SlabExchange(slab=sl, dec=dec)):
        return _total_loads(advance(st, params, dec.local))


def _total_loads(st: State) -> State:
    """The fluid loads on the blocks summed over the devices (each counted its owned rows)."""
    if st.coupling is None:
        return st
    c = st.coupling
    return st.replace(coupling=c.replace(force=jax.lax.psum(c.force, AXIS), torque=jax.lax.psum(c.torque, AXIS)))


def _local_prime(st: State, sl: Slab, params: Params, dec: Decomposition):
    """``step.prime`` of one device: the carried particles placed at their blocks' poses and point
    velocities (as the one-device prime does: a state whose blocks were set after the scene was built,
    e.g. a launched block, carries stale particles until then), the list rebuilt, the halo filled,
    the accelerations and the loads (summed over the devices)."""
    cfg = dec.local
    st = cfg.coupling_method.place(st, params, cfg)
    st, sl = _rebuild(st, sl, dec)
    st = _exchange(st, sl, dec)
    with halo.exchanging(_SlabExchange(slab=sl, dec=dec)):
        return _total_loads(cfg.coupling_method.prime(st, params, cfg)), sl


def _on_mesh(fn, dec: Decomposition, mesh: Optional[Mesh], out_specs):
    """``fn(local ShardedState, params)`` run per device by ``shard_map`` over the stacked state."""
    mesh = make_mesh(dec.n_slabs) if mesh is None else mesh

    def per_device(ss, params):
        local = jax.tree_util.tree_map(lambda a: a[0], ss)
        out = fn(local, params)
        return jax.tree_util.tree_map(lambda a: a[None], out)

    return jax.shard_map(per_device, mesh=mesh, in_specs=(PSpec(AXIS), PSpec()), out_specs=out_specs,
                         check_vma=False)


def sharded_prime(dec: Decomposition, ss: ShardedState, params: Params, *, mesh: Optional[Mesh] = None) -> ShardedState:
    """Rebuild every device's slab and list and fill the initial accelerations (``step.prime``'s
    job, per device)."""

    def fn(local, p):
        st, sl = _local_prime(local.state, local.slab, p, dec)
        return ShardedState(state=st, slab=sl)

    return jax.jit(_on_mesh(fn, dec, mesh, PSpec(AXIS)))(ss, params)


def make_sharded_rollout(dec: Decomposition, n_steps: int, *, mesh: Optional[Mesh] = None, checkpoint: bool = True,
                         reduce: Optional[Callable] = None, rebuild_on_displacement: bool = True):
    """Build ``run(sharded_state, params)``: ``n_steps`` steps of every slab (``n_steps`` a multiple
    of ``Config.rebuild_every``), the rollout's schedule (a rebuild at each block's start and, with
    ``rebuild_on_displacement``, when any device's trigger fires).

    ``reduce``: optional ``reduce(state, owned, params) -> scalar`` evaluated on each device's final
    local ``State`` with its owned mask ([n_local] bool); the per-device values are summed
    (``psum``) and ``run`` returns ``(sharded_state, total)`` (a differentiable scalar:
    ``jax.grad`` goes through the sharded rollout). Without it ``run`` returns the sharded state.
    ``checkpoint``: ``jax.checkpoint`` around each step (reverse-mode memory one State per step).
    """
    cfg = dec.local
    n_blocks = n_blocks_for(dec.config, n_steps)
    k = cfg.rebuild_every

    def one_step(carry, params):
        st, sl = carry
        if rebuild_on_displacement:
            go = jax.lax.pmax(needs_rebuild(st, cfg).astype(jnp.int32), AXIS) > 0
            st, sl = jax.lax.cond(go, lambda a: _rebuild(*a, dec), lambda a: a, (st, sl))
        st = _exchange(st, sl, dec)
        return _advance(st, sl, params, dec), sl

    if checkpoint:
        one_step = jax.checkpoint(one_step, prevent_cse=False)

    def fn(local, params):
        def block(carry, _):
            carry = _rebuild(*carry, dec)
            carry, _ = jax.lax.scan(lambda c, _: (one_step(c, params), None), carry, None, length=k)
            return carry, None

        (st, sl), _ = jax.lax.scan(block, (local.state, local.slab), None, length=n_blocks)
        out = ShardedState(state=st, slab=sl)
        if reduce is None:
            return out
        return out, jax.lax.psum(reduce(st, sl.owned, params), AXIS)

    specs = PSpec(AXIS) if reduce is None else (PSpec(AXIS), PSpec())
    mapped = _on_mesh(fn, dec, mesh, specs)
    if reduce is None:
        return mapped

    def run(ss, params):
        out, total = mapped(ss, params)
        return out, total[0]

    return run


def place(ss: ShardedState, mesh: Mesh) -> ShardedState:
    """Put the stacked state on ``mesh`` (one slab per device, ``NamedSharding`` along ``AXIS``).
    Each process reads only the slabs of its own devices from ``ss`` (``jax.make_array_from_callback``),
    so with several processes every process passes the same host ``ss`` (``decompose`` is
    deterministic); with one process it is a plain ``device_put``."""
    sharding = jax.sharding.NamedSharding(mesh, PSpec(AXIS))

    def put(a):
        host = np.asarray(a)
        return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])

    return jax.tree_util.tree_map(put, ss)


def _host(a) -> np.ndarray:
    """``a`` as a host array; with several processes, gathered from all of them first."""
    if jax.process_count() > 1 and isinstance(a, jax.Array) and not a.is_fully_addressable:
        from jax.experimental import multihost_utils

        return np.asarray(multihost_utils.process_allgather(a, tiled=True))
    return np.asarray(a)


def slab_status(ss: ShardedState) -> int:
    """The OR of every device's ``State.status`` and ``Slab.status`` bits (host int)."""
    bits = np.bitwise_or.reduce(_host(ss.state.status)) | np.bitwise_or.reduce(_host(ss.slab.status))
    return int(bits)


def _owned_water(dec: Decomposition, ss: ShardedState, who: str):
    """``take(a)``: the owned water rows of a stacked per-particle array ``a`` [D, N, ...] on the
    host, in the scene's particle order (``pid``); ValueError naming ``who`` if a particle is
    missing or owned twice (the decomposition lost track of it)."""
    nf = dec.n_local
    owned = _host(ss.slab.owned)
    pid = _host(ss.state.particles.pid)[:, :nf][owned]
    if len(np.unique(pid)) != len(pid) or len(pid) != dec.n_water:
        raise ValueError(f"{who}: {len(pid)} owned rows ({len(np.unique(pid))} distinct) for "
                         f"{dec.n_water} water particles: the decomposition lost track of some")
    order = np.argsort(pid, kind="stable")
    return lambda a: _host(a)[:, :nf][owned][order]


def gather_fluid(dec: Decomposition, ss: ShardedState) -> dict:
    """The owned fluid rows of every device on the host, in the scene's original particle order
    (``pid``): ``x`` [n, 3], ``v`` [n, 3], ``rho`` [n], ``p`` [n] and ``pid`` [n]; ValueError if
    a particle is missing or owned twice (the decomposition lost track of it)."""
    take = _owned_water(dec, ss, "gather_fluid")
    P = ss.state.particles
    return {name: take(getattr(P, name)) for name in ("pid", "x", "v", "rho", "p")}


def gather_state(dec: Decomposition, ss: ShardedState, scene) -> State:
    """One device's ``State`` of the decomposed scene: the owned water rows of every device (all
    their fields) in the scene's particle order, each wall's record from the device whose slab
    holds it (the others are ``scene``'s), an empty list (a rollout's first rebuild lists it). The scene's fluid
    segment must hold water only (as ``decompose`` lays it out)."""
    from .scenes.base import empty_neighbours

    cfg = dec.config
    if cfg.n_fluid != dec.n_water:
        raise ValueError("gather_state: the scene's fluid segment holds padding; gather_fluid returns its water")
    take = _owned_water(dec, ss, "gather_state")
    nf = dec.n_local
    G = scene.state.particles.replace(owned=None)
    P = ss.state.particles.replace(owned=None)

    def merge(a, g):
        return jnp.concatenate([jnp.asarray(take(a), g.dtype), g[cfg.n_fluid:]])

    Q = jax.tree_util.tree_map(merge, P, G)
    # the walls' state (the Adami density and pressure that the next step's sums read) from the device
    # whose slab holds each wall, whose fluid around it is complete
    kind, x = _host(P.kind)[:, nf:], _host(P.x)[:, nf:, 0]
    lo, hi = _host(ss.slab.lo)[:, None], _host(ss.slab.hi)[:, None]
    mine = (kind == Kind.WALL) & (x >= lo) & (x < hi)
    wpid = _host(P.pid)[:, nf:][mine]
    Q = jax.tree_util.tree_map(lambda q, a: q.at[wpid].set(jnp.asarray(_host(a)[:, nf:][mine], q.dtype)), Q, P)
    step = jnp.asarray(_host(ss.state.step)[0], jnp.int32)
    first = lambda tree: None if tree is None else jax.tree_util.tree_map(lambda a: jnp.asarray(_host(a)[0]), tree)
    return State(step=step, particles=Q, nbrs=empty_neighbours(cfg, Q.x), status=jnp.zeros((), jnp.int32),
                 blocks=first(ss.state.blocks), coupling=first(ss.state.coupling))


class ShardedRun(NamedTuple):
    """What ``run_sharded`` returns: the last ``Decomposition`` and ``ShardedState``, and how many
    times it re-decomposed the run to grow a buffer (``regrows``) or to even out the slabs'
    counts (``rebalances``)."""

    dec: Decomposition
    state: ShardedState
    regrows: int
    rebalances: int


def run_sharded(scene, n_slabs: int, n_steps: int, *, chunk_steps: Optional[int] = None, capacity_factor: float = 1.5,
                rebalance_above: Optional[float] = 1.25, max_regrows: int = 6, mesh: Optional[Mesh] = None,
                out: Optional[str] = None, observe: Optional[Callable] = None, **decompose_kw) -> ShardedRun:
    """Host driver: decompose ``scene`` over ``n_slabs`` devices and run ``n_steps`` steps in chunks
    of ``chunk_steps`` (multiples of ``Config.rebuild_every``; default one chunk).

    After each chunk the status bits are read: a buffer overflow (``SLAB_OVERFLOW``, or a
    neighbour-list bit the one-device driver grows) re-decomposes the chunk's start state with
    larger buffers (``capacity_factor`` x 1.5; the list capacities as ``driver`` grows them) and
    reruns the chunk; any other bit raises ``driver.SimulationError`` naming the steps and the
    cause. Load balance: when the largest slab owns more than ``rebalance_above`` times the mean
    (None: never), the state after the chunk is re-decomposed with bounds at the water's x
    quantiles (equal counts). A re-decomposition starts from the same particle records (each wall's
    from the device whose slab holds it) and is not primed again, so the run stays one device's
    trajectory to rounding; its bounds are the quantiles, whatever ``bounds`` the first had.
    ``decompose_kw``: ``decompose``'s other keywords (``bounds``, ``halo_layers``).

    ``out``: an HDF5 run file written as ``simulate`` writes it (``rockjax.io.read`` reads it back;
    XDMF sidecars next to it), one frame at the start and after each chunk (so ``chunk_steps`` is
    the frame interval), from the gathered state (``gather_state``), by process 0 only;
    ``observe(state, params, config) -> dict`` (e.g. ``observables.scene_observer(scene.meta)``)
    evaluated on it and stored under ``/observed``.
    """
    from .driver import SimulationError, _grow

    config = scene.config
    k = config.rebuild_every
    n_blocks_for(config, n_steps)
    chunk = n_steps if chunk_steps is None else int(chunk_steps)
    if chunk < 1 or chunk % k:
        raise ValueError(f"run_sharded: chunk_steps must be a positive multiple of Config.rebuild_every ({k}); got {chunk_steps}")
    if rebalance_above is not None and not rebalance_above > 1.0:
        raise ValueError(f"run_sharded: rebalance_above must be > 1 or None (got {rebalance_above})")
    growable = int(Status.growable()) | int(Status.SLAB_OVERFLOW)
    mesh = make_mesh(n_slabs) if mesh is None else mesh
    dec, ss = decompose(scene, n_slabs, capacity_factor=capacity_factor, **decompose_kw)
    ss = sharded_prime(dec, place(ss, mesh), scene.params, mesh=mesh)
    later_kw = {key: v for key, v in decompose_kw.items() if key != "bounds"}
    writer = None
    if out is not None and jax.process_index() == 0:
        from .driver import check_out
        from .io.hdf5 import Writer

        check_out(out)
        writer = Writer(out, scene)
    try:
        _frame(writer, out, dec, ss, scene, observe)
        runs = {}
        done = regrows = rebalances = 0
        while done < n_steps:
            n = min(chunk, n_steps - done)
            key = (dataclasses.replace(dec, bounds=()), n)  # the bounds are data (Slab.lo / hi): no recompile
            if key not in runs:
                runs[key] = jax.jit(make_sharded_rollout(dec, n, mesh=mesh, checkpoint=False))
            res = runs[key](ss, scene.params)
            bits = slab_status(res)
            step = int(_host(ss.state.step)[0])
            if bits & ~growable:
                raise SimulationError(f"decomposed run stopped in steps {step}-{step + n}: {Status.describe(bits & ~growable)}",
                                      step=step, status=bits)
            if bits:
                regrows += 1
                if regrows > max_regrows:
                    raise SimulationError(f"run_sharded: gave up after {max_regrows} regrowths ({Status.describe(bits)})",
                                          step=step, status=bits)
                start = gather_state(dec, ss, scene)
                nb = res.state.nbrs
                probe = start.replace(nbrs=start.nbrs.replace(
                    max_count=jnp.max(nb.max_count), max_run=jnp.max(nb.max_run),
                    max_wall_count=jnp.max(nb.max_wall_count), max_body_count=jnp.max(nb.max_body_count)))
                config, _ = _grow(config, k, probe, bits & int(Status.growable()) & ~int(Status.NEIGHBOUR_STALE))
                if bits & Status.SLAB_OVERFLOW:
                    capacity_factor *= 1.5
                scene = scene.replace(config=config, state=start)
                dec, ss = decompose(scene, n_slabs, capacity_factor=capacity_factor, **later_kw)
                ss = place(ss, mesh)
                continue  # not primed again: the records carry their accelerations; the chunk's first rebuild lists them
            ss, done = res, done + n
            _frame(writer, out, dec, ss, scene, observe)
            counts = _host(ss.slab.owned_count)
            if done < n_steps and rebalance_above is not None and counts.max() > rebalance_above * counts.mean():
                rebalances += 1
                scene = scene.replace(state=gather_state(dec, ss, scene))
                dec, ss = decompose(scene, n_slabs, capacity_factor=capacity_factor, **later_kw)
                ss = place(ss, mesh)
        return ShardedRun(dec=dec, state=ss, regrows=regrows, rebalances=rebalances)
    finally:
        if writer is not None:
            writer.close()
            from .io.xdmf import write_xdmf

            write_xdmf(out)


def _frame(writer, out, dec: Decomposition, ss: ShardedState, scene, observe) -> None:
    """One frame of ``run_sharded``'s file from the gathered state (every process gathers: with
    several processes the gather is collective; process 0 writes)."""
    if out is None:
        return
    from .driver import host_frame

    s = gather_state(dec, ss, scene)
    if writer is not None:
        obs = jax.device_get(observe(s, scene.params, scene.config)) if observe is not None else None
        writer.append(float(s.step) * scene.config.dt, host_frame(s), slab_status(ss), observed=obs)
