"""Ensembles: many scenarios of one scene at once, with ``jax.vmap`` and across devices.

This module owns the batching helpers. All members share one static ``Config`` (same array
shapes); they differ in ``Params`` leaves (density, friction angle, speed of sound, ...) and,
optionally, in the initial ``State`` (e.g. the initial velocity of a block, or block poses with
the same shapes).

* ``broadcast(tree, n)`` / ``batch(tree, n, {path: values[n]})``: a batched pytree (leading axis
  n) from one member, with chosen leaves swept (``"blocks.density[0]"``,
  ``"blocks.friction_angle"``, ``"blocks.v[0]"``: paths as in ``rockjax.calibrate.get_leaf``);
  ``stack`` / ``unstack`` / ``member`` convert between lists and batches;
* ``ensemble(fn, in_axes=..., batch_size=...)``: ``fn`` over every member, ``batch_size`` members
  at a time under ``jax.vmap`` and the batches one after another (``jax.lax.map``); by default all
  members at once on an accelerator and one at a time on the CPU, where a vmapped batch runs slower
  than its members one by one and the ``lax.map`` as fast (RESULTS.md "Gradients ... ensembles";
  ``experiments/bench_grad.py --skip-grad``). With ``shard=True`` (or a ``mesh``) the batch is split
  over devices with ``jax.shard_map`` (each device maps ``fn`` over its slice the same way, no
  communication, so the results equal the unsharded run); a batch that does not divide evenly is
  padded with copies of its last member and trimmed;
* ``run_ensemble(scene, params_batch, n_steps, observable)``: the final observable of every
  member (e.g. a run-up distribution over 64 sampled slides);
* ``jax.vmap(jax.grad(loss))`` is ``ensemble(jax.grad(loss), batch_size=None)`` on an accelerator;
* ``perturbed(state, key, n, sigma={path: std})`` and ``smoothed_value_and_grad(loss, params,
  states)``: the gradient of a smoothed objective, the mean of ``loss(params, state)`` over an
  ensemble of slightly perturbed initial states, with its standard error (below).

When to smooth the objective. A long coupled run (the impact, a breaking wave) is piecewise
smooth in its parameters: every contact or stick-slip event is a kink of the loss, and over a
whole event they lie closer together than the step a calibration takes (``rockjax.gradcheck``
says "rough"). The exact gradient is then local. First remove the jumps with the smooth physics
settings (``blocks.laws.SmoothPenaltyCoulomb``, ``coupling.Penalty(onset=, face_blend=)``): the
ensemble mean of exact member gradients is the gradient of the smoothed objective only where the
loss is continuous (a kink is averaged correctly; a jump is not seen by any member's gradient).
Then, where the kinks remain dense, average over perturbations of the initial state whose size
is below what the observations resolve (e.g. 0.1 mm of the block's release point): the smoothed
gradient describes the loss over a distance ~ the perturbation, and ``grad_sem`` says how many
members it needs (it falls as 1/sqrt(n)).

Several hosts (``jax.distributed``). Start one process per host and call
``jax.distributed.initialize(coordinator_address="host0:1234", num_processes=P, process_id=i)``
(on SLURM / TPU pods / Kubernetes with the usual environment the arguments may be omitted)
before any other JAX call. ``jax.devices()`` then lists the devices of every host, so
``ensemble(fn, shard=True)`` builds a mesh over all of them. Each process holds only its own
rows: build the global batch with ``jax.make_array_from_process_local_data(
NamedSharding(mesh, P("members")), local_rows)`` for every leaf (``shard_batch`` does this when
``jax.process_count() > 1``), call the sharded function (the global batch must then divide evenly
over the devices: no padding across hosts), and read results with
``jax.experimental.multihost_utils.process_allgather`` or per process from
``out.addressable_shards``. Every process must run the same program in the same order.
"""

from __future__ import annotations

from typing import Callable, Mapping, NamedTuple, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec as P

from .calibrate import _parse, get_leaf, observed, set_leaf
from .types import Params, State

__all__ = ["AXIS", "stack", "unstack", "member", "broadcast", "batch", "make_mesh", "shard_batch", "ensemble",
           "default_batch_size", "run_ensemble", "perturbed", "SmoothedGradient", "smoothed_value_and_grad"]

AXIS = "members"  #: the mesh axis name the ensemble is split over


def stack(trees: Sequence):
    """A batched pytree (new leading axis) from a list of pytrees with identical structure and shapes."""
    if not trees:
        raise ValueError("stack: need at least one member")
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *trees)


def member(tree, i: int):
    """Member ``i`` of a batched pytree."""
    return jax.tree_util.tree_map(lambda a: a[i], tree)


def _size(tree) -> int:
    leaves = jax.tree_util.tree_leaves(tree)
    if not leaves:
        raise ValueError("ensemble: a batched argument has no array leaves")
    n = {int(jnp.shape(a)[0]) for a in leaves}
    if len(n) != 1:
        raise ValueError(f"ensemble: batched leaves disagree on the batch size (leading axes {sorted(n)})")
    return n.pop()


def unstack(tree) -> list:
    """The list of members of a batched pytree."""
    return [member(tree, i) for i in range(_size(tree))]


def broadcast(tree, n: int):
    """``n`` identical copies of ``tree`` stacked along a new leading axis."""
    if int(n) < 1:
        raise ValueError(f"broadcast: n must be >= 1 (got {n})")
    return jax.tree_util.tree_map(lambda a: jnp.broadcast_to(jnp.asarray(a), (int(n),) + jnp.shape(a)), tree)


def batch(tree, n: int, overrides: Optional[Mapping[str, object]] = None):
    """``n`` copies of ``tree`` (Params or State) with the leaves in ``overrides`` swept.

    Args:
        tree: one member.
        n: batch size.
        overrides: ``{path: values}`` with ``values`` of shape ``[n] + leaf shape`` (the leaf, or
            its entry ``[i]`` for a path ``"a.b[i]"``), e.g.
            ``{"blocks.density[0]": rho[n], "blocks.friction_angle": phi[n], "blocks.v[0]": v[n, 3]}``.
    """
    out = broadcast(tree, n)
    for path, values in (overrides or {}).items():
        names, index = _parse(path)
        leaf = jnp.asarray(get_leaf(tree, path))
        values = jnp.asarray(values, leaf.dtype)
        if values.shape != (int(n),) + leaf.shape:
            raise ValueError(f"batch: values for {path!r} have shape {values.shape}; expected {(int(n),) + leaf.shape} "
                             "(one entry per member)")

        def rec(node, depth):
            nm = names[depth]
            child = getattr(node, nm)
            if depth == len(names) - 1:
                new = values if index is None else child.at[:, index].set(values)
                return node.replace(**{nm: new})
            return node.replace(**{nm: rec(child, depth + 1)})

        out = rec(out, 0)
    return out


def make_mesh(devices: Optional[Sequence] = None) -> Mesh:
    """A one-axis mesh (axis ``AXIS``) over ``devices`` (default: all devices of all processes)."""
    devs = list(jax.devices() if devices is None else devices)
    return Mesh(np.asarray(devs), (AXIS,))


def shard_batch(tree, mesh: Mesh):
    """Place a batched pytree on ``mesh``, split along its leading axis.

    With one process: ``jax.device_put`` of the whole batch. With several (``jax.distributed``):
    each process passes only its own rows, assembled into one global array per leaf with
    ``jax.make_array_from_process_local_data``.
    """
    sh = NamedSharding(mesh, P(AXIS))
    if jax.process_count() > 1:
        return jax.tree_util.tree_map(lambda a: jax.make_array_from_process_local_data(sh, np.asarray(a)), tree)
    return jax.device_put(tree, sh)


def default_batch_size() -> Optional[int]:
    """Members per vmapped batch of ``ensemble`` by default: 1 on the CPU, all (None) elsewhere."""
    return 1 if jax.default_backend() == "cpu" else None


def _axes(in_axes, n_args: int) -> tuple:
    ax = in_axes if isinstance(in_axes, (tuple, list)) else (in_axes,) * n_args
    if len(ax) != n_args or any(a not in (0, None) for a in ax):
        raise ValueError(f"ensemble: in_axes must be 0 or None per argument (got {in_axes!r} for {n_args} args)")
    return tuple(ax)


def _members(args: tuple, ax: tuple) -> int:
    """The batch size the batched arguments (``ax`` 0) agree on (ValueError if none or they disagree)."""
    sizes = {_size(a) for a, x in zip(args, ax) if x == 0}
    if not sizes:
        raise ValueError("ensemble: no batched argument (in_axes all None)")
    if len(sizes) != 1:
        raise ValueError(f"ensemble: batched arguments disagree on the batch size ({sorted(sizes)})")
    return sizes.pop()


def _mapped(fn: Callable, in_axes, batch_size: Optional[int]) -> Callable:
    """``fn`` over the leading axis of the batched arguments, ``batch_size`` members per vmapped pass
    (None: all at once), the passes in a ``lax.map`` (a scan: one member at a time when 1)."""

    def run(*args):
        ax = _axes(in_axes, len(args))
        n = _members(args, ax)
        batched = tuple(a for a, x in zip(args, ax) if x == 0)

        def one(members):
            it = iter(members)
            return fn(*(next(it) if x == 0 else a for a, x in zip(args, ax)))

        if batch_size is None or batch_size >= n:
            return jax.vmap(one)(batched)
        if batch_size == 1:
            return jax.lax.map(one, batched)  # a scan, no vmap
        return jax.lax.map(one, batched, batch_size=batch_size)

    return run


def ensemble(fn: Callable, *, in_axes=0, batch_size="auto", shard: bool = False, mesh: Optional[Mesh] = None,
             devices: Optional[Sequence] = None) -> Callable:
    """Map ``fn`` over a leading member axis, in vmapped batches, optionally sharded; jitted.

    Args:
        fn: ``fn(*args) -> pytree`` for one member (e.g. ``lambda p, s: runup(final_state(...))``,
            or ``jax.grad(loss)``).
        in_axes: per positional argument 0 (batched along the leading axis) or None (shared by
            every member); an int or None applies to all arguments. Only 0 and None are allowed.
        batch_size: members evaluated together under ``jax.vmap`` (``jax.jit(jax.vmap(fn))`` when
            it is None or at least the batch), the batches one after another in a ``jax.lax.map``
            (1: a plain scan over the members, no vmap). ``"auto"`` (default): ``default_batch_size()``, 1 on the
            CPU (a vmapped batch measured slower there than its members one by one; module
            docstring), all members on accelerators. The results do not depend on it beyond float
            rounding.
        shard: split the batch over ``devices`` (default all) with ``jax.shard_map`` on a
            one-axis mesh; or pass ``mesh`` (axis ``AXIS``) directly. Shared arguments are
            replicated; outputs are batched along the leading axis and sharded the same way.

    Returns:
        ``batched(*args)``; with sharding, a batch size that does not divide by the number of
        devices is padded with copies of the last member (single process only) and trimmed.
    """
    if batch_size == "auto":
        batch_size = default_batch_size()
    if batch_size is not None and not (isinstance(batch_size, (int, np.integer)) and batch_size >= 1):
        raise ValueError(f"ensemble: batch_size must be a positive integer, None (all members at once) or 'auto' "
                         f"(got {batch_size!r})")
    vm = _mapped(fn, in_axes, batch_size)
    if not shard and mesh is None:
        return jax.jit(vm)
    mesh = make_mesh(devices) if mesh is None else mesh
    if mesh.axis_names != (AXIS,):
        raise ValueError(f"ensemble: the mesh must have the single axis {AXIS!r} (got {mesh.axis_names})")
    n_dev = mesh.devices.size
    cache: dict = {}

    def batched(*args):
        ax = _axes(in_axes, len(args))
        n = _members(args, ax)
        pad = (-n) % n_dev
        if pad:
            if jax.process_count() > 1:
                raise ValueError(f"ensemble: with several processes the batch ({n}) must divide by the number of "
                                 f"devices ({n_dev}); pad it on every host")
            args = tuple(
                jax.tree_util.tree_map(lambda a: jnp.concatenate([a, jnp.repeat(a[-1:], pad, axis=0)]), a)
                if x == 0 else a for a, x in zip(args, ax))
        if ax not in cache:
            specs = tuple(P(AXIS) if x == 0 else P() for x in ax)
            sm = jax.shard_map(vm, mesh=mesh, in_specs=specs, out_specs=P(AXIS), check_vma=False)
            cache[ax] = jax.jit(sm)
        out = cache[ax](*args)
        if pad:
            out = jax.tree_util.tree_map(lambda a: a[:n], out)
        return out

    return batched


def run_ensemble(scene, params_batch: Params, n_steps: int, observable: Callable[[State, Params], object], *,
                 states: Optional[State] = None, shard: bool = False, mesh: Optional[Mesh] = None,
                 checkpoint: bool = False, batch_size="auto"):
    """``observable(final_state, params)`` for every member of an ensemble of ``scene``.

    Args:
        scene: the ``Scene`` (its ``config``; its ``state`` unless ``states`` is given).
        params_batch: batched ``Params`` (``batch``), leading axis n.
        n_steps: steps per member (a multiple of ``config.rebuild_every``).
        observable: ``observable(state, params) -> pytree`` on the final state of one member.
        states: optional batched initial ``State`` (same shapes as ``scene.state``, leading axis n).
        shard, mesh, batch_size: split the members over devices; members per vmapped batch (see
            ``ensemble``).
        checkpoint: use the checkpointed rollout (only useful under a gradient).

    Members rebuild their neighbour lists on the fixed ``rebuild_every`` schedule (a
    displacement trigger would rebuild at every step under ``vmap``); a member whose list went
    stale has ``Status.NEIGHBOUR_STALE`` in its final state's ``status``.

    Returns:
        the observable with a leading axis n.
    """
    def one(params, state):
        s = observed(scene, params, n_steps, None, state=state, checkpoint=checkpoint,
                     rebuild_on_displacement=False)[0]
        return observable(s, params)

    if states is None:
        fn = ensemble(lambda p: one(p, scene.state), in_axes=0, shard=shard, mesh=mesh, batch_size=batch_size)
        return fn(params_batch)
    return ensemble(one, in_axes=(0, 0), shard=shard, mesh=mesh, batch_size=batch_size)(params_batch, states)


def perturbed(state, key, n: int, sigma: Mapping[str, float]):
    """``n`` copies of ``state`` (batched, leading axis n) with Gaussian noise on chosen leaves.

    Args:
      state: one member (e.g. ``scene.state``) or any pytree of dataclasses.
      key: a ``jax.random`` key (the same key gives the same ensemble).
      n: members (>= 2).
      sigma: ``{path: std}`` in the leaf's units, e.g. ``{"blocks.x[0]": 1e-4}`` (block 0's
        centroid, m) or ``{"blocks.v[0]": 1e-3}``; each entry of the leaf gets independent noise.
        Member 0 is the unperturbed state when ``sigma`` is empty; otherwise all are perturbed.
    """
    if not (isinstance(n, (int, np.integer)) and n >= 2):
        raise ValueError(f"perturbed: n must be an integer >= 2 (got {n!r})")
    out = broadcast(state, n)
    for k, (path, std) in enumerate(sorted(sigma.items())):
        if not (float(std) >= 0.0 and np.isfinite(float(std))):
            raise ValueError(f"perturbed: sigma[{path!r}] must be a finite std >= 0 (got {std!r})")
        leaf = jnp.asarray(get_leaf(state, path))
        noise = float(std) * jax.random.normal(jax.random.fold_in(key, k), (n,) + leaf.shape, leaf.dtype)
        names, index = _parse(path)
        full = get_leaf(out, ".".join(names))  # [n, ...]
        new = full + noise if index is None else full.at[:, index].add(noise)
        out = set_leaf(out, ".".join(names), new)
    return out


class SmoothedGradient(NamedTuple):
    """The ensemble estimate of a smoothed objective and its gradient (``smoothed_value_and_grad``)."""

    value: jax.Array  #: mean loss over the members
    grad: object  #: mean gradient (a pytree like params)
    value_std: jax.Array  #: standard deviation of the members' losses
    grad_sem: object  #: standard error of the mean gradient (std over members / sqrt(n)), like params
    n: int  #: members


def smoothed_value_and_grad(loss: Callable, params, states, *, batch_size="auto", shard: bool = False,
                            mesh: Optional[Mesh] = None) -> SmoothedGradient:
    """Mean and standard error of ``loss(params, state)`` and its gradient over an ensemble of
    initial states (``states``: batched, e.g. ``perturbed(scene.state, key, 16, {"blocks.x[0]": 1e-4})``).

    ``loss(params, state) -> []`` must be differentiable in ``params`` (e.g. built on
    ``calibrate.observed(scene, params, n, observe, state=state)``; under ``vmap`` pass
    ``rebuild_on_displacement=False`` there). ``batch_size``, ``shard``, ``mesh``: see ``ensemble``.
    Returns :class:`SmoothedGradient`.
    """
    vg = ensemble(jax.value_and_grad(loss), in_axes=(None, 0), batch_size=batch_size, shard=shard, mesh=mesh)
    values, grads = vg(params, states)
    n = int(jnp.shape(values)[0])
    if n < 2:
        raise ValueError("smoothed_value_and_grad: need at least 2 members for a standard error")
    mean = jax.tree_util.tree_map(lambda g: jnp.mean(g, 0), grads)
    sem = jax.tree_util.tree_map(lambda g: jnp.std(g, 0, ddof=1) / np.sqrt(n), grads)
    return SmoothedGradient(jnp.mean(values), mean, jnp.std(values, ddof=1), sem, n)
