"""Differentiable objectives on whole simulations, and inverse calibration with optax.

This module owns the user-facing gradient entry points and the calibration loop:

* ``final_state(scene, params, n_steps)`` / ``observed(scene, params, n_steps, observe)``: prime
  the initial state for ``params`` and run the checkpointed rollout (``rockjax.rollout``); both
  are pure in ``params`` so ``jax.grad``, ``jax.jvp`` (with ``Adjoint.AUTODIFF``, see
  ``Tuning.adjoint``) and ``jax.vmap`` go through them;
* ``make_loss(scene, n_steps, objective, observe=...)``: ``loss(params) -> []``, e.g.

  .. code-block:: python

      loss = make_loss(scene, 400, lambda s, p: smooth_runup(s, **kw))
      g = jax.grad(loss)(scene.params)        # g.blocks.density, g.blocks.friction_angle, ...

* ``trajectory_loss(config, n_steps, observe)``: one function for sensitivities (a weighted sum
  of observations) and least-squares misfits, with the initial state as an argument, so one
  compile serves gradient checks, calibration and every initial state of the same shapes;
* leaf addressing by path strings ``"blocks.density[0]"``, ``"blocks.friction_angle"``,
  ``"fluid.c0"`` (``get_leaf`` / ``set_leaf``), used by ``calibrate`` and ``rockjax.ensembles``;
* ``smooth_config(config)``: the same scene with the smooth physics settings (the blocks'
  ``SmoothPenaltyCoulomb``; the penalty coupling's smooth onset and face blend), for losses over a
  whole event: their gradients then hold at the scale a calibration moves much longer
  (``rockjax.gradcheck``; RESULTS.md "Gradients over the full event");
* ``secant_value_and_grad(loss, fields, rel_step)``: the loss's slope at a stated scale (central
  secants, two forward runs per field) for ``calibrate(..., value_and_grad=...)`` where the exact
  gradient is local (``gradcheck`` says "rough": long coupled runs);
* ``calibrate(loss, params0, fields)``: fit the chosen scalar leaves with optax L-BFGS (default)
  or Adam, in log space (each field is ``value = start * exp(u)``, so fields of very different
  magnitudes -- a density of 2500 kg/m^3 and a friction angle of 0.3 rad -- are equally scaled
  and stay positive); returns the loss and parameter paths.

The time step lives in ``Config`` and never depends on a differentiated parameter: when a
density or stiffness is perturbed the step stays what the scene builder chose (check that it is
still stable for the values you explore: the driver and ``Status.BLOCK_UNSTABLE`` say so).
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from typing import Callable, Optional, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .rollout import make_rollout, n_blocks_for
from .step import prime as _prime
from .types import Config, Params, State

__all__ = [
    "smooth_config", "secant_value_and_grad", "get_leaf", "set_leaf", "final_state", "observed", "make_loss", "trajectory_loss", "relative_misfit",
    "CalibrationResult", "calibrate",
]

_PATH = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)(?:\[(\d+)\])?$")


def _parse(path: str):
    m = _PATH.match(path.strip())
    if not m:
        raise ValueError(f"leaf path {path!r} is not of the form 'a.b.c' or 'a.b.c[i]' (e.g. 'blocks.density[0]')")
    return m.group(1).split("."), (None if m.group(2) is None else int(m.group(2)))


def smooth_config(config: Config, *, law=None, onset: float = 0.5, face_blend: float = 0.1) -> Config:
    """``config`` with the smooth physics settings for gradients over a whole event.

    * blocks: ``law`` (default ``blocks.laws.SmoothPenaltyCoulomb()`` at its default widths)
      instead of the sharp ``PenaltyCoulomb``, and ``joint_fade_points`` (the joint-water patch's
      corners fade in and out of the aperture);
    * the seed's penalty coupling (``Coupling.PENALTY`` or a ``coupling.Penalty``):
      ``Penalty(onset=onset, face_blend=face_blend)`` (fractions of the interaction distance).
      Other couplings are kept as they are.

    The forward results stay within the closed-form checks' tolerances (tests/blocks/test_physics.py
    runs the incline, sticking and restitution with the smooth law); the compiled program is a
    new one (the choices are static).
    """
    from .blocks.laws import SmoothPenaltyCoulomb
    from .coupling.penalty import Penalty

    changes = {}
    if config.blocks is not None:
        changes["blocks"] = dataclasses.replace(config.blocks, law=SmoothPenaltyCoulomb() if law is None else law,
                                                joint_fade_points=True)
    method = config.coupling_method
    if type(method) is Penalty:  # the seed's penalty (not BoundaryIntegral, whose penalty only guards)
        changes["coupling"] = Penalty(onset=onset, face_blend=face_blend)
    return config.replace(**changes)


def get_leaf(tree, path: str):
    """The array at ``path`` in a pytree of dataclasses, e.g. ``get_leaf(params, "blocks.density[0]")``.

    The index, if any, selects along the leading axis of that leaf.
    """
    names, index = _parse(path)
    node = tree
    for i, nm in enumerate(names):
        if node is None or not hasattr(node, nm):
            raise ValueError(f"leaf path {path!r}: {type(node).__name__} has no field {nm!r}"
                             + (" (that part is None in this scene)" if node is None else ""))
        node = getattr(node, nm)
    if node is None:
        raise ValueError(f"leaf path {path!r} is None in this tree (the scene has no such part)")
    return node if index is None else node[index]


def set_leaf(tree, path: str, value):
    """A copy of ``tree`` with the array at ``path`` replaced (or its entry ``[i]`` set) to ``value``.

    Traceable: ``value`` may be a tracer (used inside ``jax.grad`` / ``vmap``).
    """
    names, index = _parse(path)
    get_leaf(tree, path)  # validates the path

    def rec(node, depth):
        nm = names[depth]
        child = getattr(node, nm)
        if depth == len(names) - 1:
            if index is None:
                new = jnp.asarray(value, dtype=jnp.asarray(child).dtype)
                if new.shape != jnp.shape(child):
                    raise ValueError(f"set_leaf {path!r}: value shape {new.shape} != leaf shape {jnp.shape(child)}")
            else:
                new = jnp.asarray(child).at[index].set(jnp.asarray(value, dtype=jnp.asarray(child).dtype))
            return node.replace(**{nm: new})
        return node.replace(**{nm: rec(child, depth + 1)})

    return rec(tree, 0)


def observed(scene, params: Params, n_steps: int, observe: Optional[Callable] = None, *,
             state: Optional[State] = None, checkpoint: bool = True, chunk: Optional[int] = None,
             prime: bool = True, rebuild_on_displacement: bool = True, checkpoint_levels: int = 2):
    """Run ``n_steps`` steps of ``scene`` with ``params``: ``(final State, observations)``.

    Args:
        scene: a ``rockjax.Scene`` (its ``config`` and, unless ``state`` is given, its ``state``),
            or a ``Config`` together with ``state``.
        params: the ``Params`` to run with (may be traced: this is the function to differentiate).
        n_steps: a multiple of ``scene.config.rebuild_every``.
        observe: ``observe(state, params) -> pytree`` after every block of ``rebuild_every``
            steps; stacked along a leading axis of ``n_steps // rebuild_every`` (None: no output).
        state: initial state (default ``scene.state``), e.g. one member of an ensemble.
        checkpoint, chunk, rebuild_on_displacement, checkpoint_levels: see
            ``rockjax.rollout.make_rollout`` (under
            ``jax.vmap`` pass ``rebuild_on_displacement=False``: the rebuild ``cond`` becomes a select
            that rebuilds at every step).
        prime: fill the initial accelerations and fluid loads for these params (``rockjax.prime``);
            turn off only if ``state`` is already primed for exactly these params.
    """
    if isinstance(scene, Config):
        if state is None:
            raise ValueError("observed: with a Config instead of a Scene, pass the initial state (state=...)")
        config, s0 = scene, state
    else:
        config, s0 = scene.config, (scene.state if state is None else state)
    nb = n_blocks_for(config, n_steps)
    if prime:
        s0 = _prime(s0, params, config)
    return make_rollout(config, nb, checkpoint=checkpoint, observe=observe, chunk=chunk,
                        rebuild_on_displacement=rebuild_on_displacement,
                        checkpoint_levels=checkpoint_levels)(s0, params)


def final_state(scene, params: Params, n_steps: int, **kwargs) -> State:
    """The state after ``n_steps`` steps (differentiable in ``params``); kwargs as ``observed``."""
    return observed(scene, params, n_steps, None, **kwargs)[0]


def make_loss(scene, n_steps: int, objective: Callable, *, observe: Optional[Callable] = None, **kwargs):
    """``loss(params) -> []`` for ``jax.grad``.

    Without ``observe``: ``objective(final_state, params)``. With ``observe``:
    ``objective(observations, params)`` where observations are stacked over the blocks (see
    ``observed``). Other keywords go to ``observed`` (``state``, ``checkpoint``, ``chunk``).
    """

    def loss(params):
        s, obs = observed(scene, params, n_steps, observe, **kwargs)
        return objective(s, params) if observe is None else objective(obs, params)

    return loss


def trajectory_loss(config: Config, n_steps: int, observe: Callable, **kwargs):
    """``L(params, state, target, w_lin, w_quad) -> (value, (observations, status))``.

    ``observations = observed(config, params, n_steps, observe, state=state)[1]`` (stacked over
    the blocks of ``rebuild_every`` steps) and
    ``value = sum(w_lin * obs) + sum(w_quad * (obs - target)^2)``: with a one-hot ``w_lin`` it is
    one observation (a gradient test, a sensitivity), with ``w_quad`` a weighted least-squares
    misfit (calibration). ``target``, ``w_lin`` and ``w_quad`` have the observations' shape
    (a single array). One ``jax.jit(jax.value_and_grad(L, has_aux=True))`` serves all uses and
    all initial states of the same shapes. Keywords go to ``observed``.
    """

    def L(params, state, target, w_lin, w_quad):
        final, obs = observed(config, params, n_steps, observe, state=state, **kwargs)
        value = jnp.sum(w_lin * obs) + jnp.sum(w_quad * (obs - target) ** 2)
        return value, (obs, final.status)

    return L


def relative_misfit(pred, target, scale=None):
    """``mean(((pred - target) / scale)^2)`` over all leaves of matching pytrees (dimensionless).

    ``scale`` (pytree of scalars or arrays like ``target``): the size of each observable; default
    the RMS of the target leaf (plus 1e-12 so that a zero target does not divide by zero).
    """
    lp, treedef = jax.tree_util.tree_flatten(pred)
    lt = treedef.flatten_up_to(target)
    ls = [None] * len(lp) if scale is None else treedef.flatten_up_to(scale)
    total, count = 0.0, 0
    for p, t, s in zip(lp, lt, ls):
        t = jnp.asarray(t)
        s = jnp.sqrt(jnp.mean(t * t)) + 1e-12 if s is None else jnp.asarray(s)
        total = total + jnp.sum(((p - t) / s) ** 2)
        count += int(np.prod(jnp.shape(p)))
    return total / max(count, 1)


def secant_value_and_grad(loss: Callable[[Params], jax.Array], fields: Sequence[str], *, rel_step: float = 1e-2,
                          abs_step: float = 1e-4) -> Callable:
    """``params -> (loss, grads)`` with the gradient's ``fields`` entries replaced by central
    secants ``(L(x + h) - L(x - h)) / 2h``, ``h = rel_step |x|`` (``abs_step`` where x = 0); every
    other leaf of ``grads`` is 0. For ``calibrate(None, ..., value_and_grad=...)``.

    Why: over a whole coupled event the loss is piecewise smooth with kinks closer together than
    a calibration's steps, so the exact gradient describes an interval too small to matter
    (``rockjax.gradcheck`` says "rough"), while the secant over ``rel_step`` is the slope over the
    distance the optimiser moves (RESULTS.md "Gradients over the full event").
    Costs ``1 + 2 len(fields)`` forward runs (no backward pass); ``loss`` is jitted once here.
    """
    fields = list(fields)
    if not fields:
        raise ValueError("secant_value_and_grad: fields must name at least one scalar leaf")
    if not (rel_step > 0 and math.isfinite(rel_step)):
        raise ValueError(f"secant_value_and_grad: rel_step must be a positive number (got {rel_step})")
    f = jax.jit(loss)

    def vg(params):
        value = f(params)
        grads = jax.tree_util.tree_map(jnp.zeros_like, params)
        for path in fields:
            x0 = float(get_leaf(params, path))
            h = rel_step * abs(x0) if x0 != 0.0 else abs_step
            d = (f(set_leaf(params, path, x0 + h)) - f(set_leaf(params, path, x0 - h))) / (2.0 * h)
            grads = set_leaf(grads, path, d)
        return value, grads

    return vg


@dataclasses.dataclass(frozen=True)
class CalibrationResult:
    """What ``calibrate`` returns.

    Attributes:
        params: the fitted ``Params``.
        values: {field: fitted value} (Python floats).
        loss_path: [n_iter + 1] loss at the start and after every iteration.
        param_paths: {field: [n_iter + 1] values}.
        n_iter: optimizer iterations taken (accepted steps). n_evals: loss-and-gradient evaluations,
            line-search trials included.
        converged: whether a stopping test (``tol_loss`` / ``tol_step``, or a line search that
            finds no decrease) ended the loop before ``max_iter``.
        seconds: wall time of the loop (compile included).
    """

    params: Params
    values: dict
    loss_path: list
    param_paths: dict
    n_iter: int
    n_evals: int
    converged: bool
    seconds: float

    def to_json(self) -> dict:
        return dict(values=self.values, loss_path=self.loss_path, param_paths=self.param_paths,
                    n_iter=self.n_iter, n_evals=self.n_evals, converged=self.converged, seconds=self.seconds)


def calibrate(loss: Optional[Callable[[Params], jax.Array]], params0: Params, fields: Sequence[str], *,
              value_and_grad: Optional[Callable] = None, method: str = "lbfgs", max_iter: int = 50,
              learning_rate: float = 0.05, first_step: float = 0.2, tol_loss: float = 0.0, tol_step: float = 1e-7,
              max_backtracks: int = 20, callback: Optional[Callable] = None) -> CalibrationResult:
    """Fit the scalar leaves ``fields`` of ``params0`` by minimising ``loss(params)`` with optax.

    Each field is optimised in log space, ``value = start * exp(u)`` with u = 0 at the start, so
    the fields are dimensionless and equally scaled; start values must be positive.

    The loss and its gradient come from one jitted ``value_and_grad(params) -> (loss, Params)``
    (built from ``loss`` unless given), called from the host; the optimizer state lives on the
    host too, so nothing but the loss and its gradient is compiled (a calibration costs one
    compile of the gradient of the rollout).

    Args:
        loss: ``loss(params) -> []``, differentiable (e.g. from ``make_loss``); may be None when
            ``value_and_grad`` is given.
        params0: the starting ``Params`` (the other leaves stay fixed).
        fields: leaf paths (``get_leaf``), each a scalar (``"blocks.density[0]"``).
        value_and_grad: optional ``params -> (loss, grads as Params)``, e.g. an already compiled
            ``jax.jit(jax.value_and_grad(loss))`` shared with other uses.
        method: ``"lbfgs"`` (default): optax ``scale_by_lbfgs`` directions with a backtracking
            (Armijo) line search on the host, the first step capped at ``first_step`` log units;
            or ``"adam"``: ``optax.adam(learning_rate)`` (learning rate in log units per step).
        max_iter: most optimizer iterations.
        tol_loss: stop when the loss falls below this. tol_step: stop when every |du| of an
            iteration is below this (relative change of every field).
        max_backtracks: most halvings of the step in one line search (L-BFGS).
        callback: ``callback(iteration, loss, values_dict)`` on the host after every iteration.
    """
    import optax

    fields = list(fields)
    if not fields:
        raise ValueError("calibrate: fields must name at least one leaf, e.g. ['blocks.density[0]']")
    if loss is None and value_and_grad is None:
        raise ValueError("calibrate: give loss or value_and_grad")
    if method not in ("lbfgs", "adam"):
        raise ValueError(f"calibrate: method must be 'lbfgs' or 'adam' (got {method!r})")
    start = []
    for f in fields:
        v = np.asarray(get_leaf(params0, f))
        if v.shape != ():
            raise ValueError(f"calibrate: field {f!r} has shape {v.shape}; name one scalar entry, e.g. '{f}[0]'")
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"calibrate: field {f!r} starts at {float(v)}; log-space fitting needs a positive start")
        start.append(float(v))
    start = np.asarray(start, np.float64)
    dtype = jnp.asarray(get_leaf(params0, fields[0])).dtype
    vg_params = jax.jit(jax.value_and_grad(loss)) if value_and_grad is None else value_and_grad
    n_evals = 0

    def to_params(u):
        p = params0
        vals = start * np.exp(np.asarray(u, np.float64))
        for f, v in zip(fields, vals):
            p = set_leaf(p, f, jnp.asarray(v, dtype))
        return p, vals

    def vg(u):  # loss and d loss / d u on the host (chain rule through value = start exp(u))
        nonlocal n_evals
        n_evals += 1
        p, vals = to_params(u)
        value, g = vg_params(p)
        gu = np.array([float(get_leaf(g, f)) for f in fields]) * vals
        value = float(value)
        if not (np.isfinite(value) and np.all(np.isfinite(gu))):
            raise FloatingPointError(f"calibrate: non-finite loss {value} or gradient {gu} at {dict(zip(fields, vals))}")
        return value, gu

    t0 = time.perf_counter()
    u = np.zeros(len(fields))
    opt = optax.scale_by_lbfgs() if method == "lbfgs" else optax.adam(learning_rate)
    state = opt.init(jnp.asarray(u))
    value, g = vg(u)
    loss_path, paths = [value], {f: [v] for f, v in zip(fields, start)}
    converged, it = False, 0
    for it in range(1, max_iter + 1):
        if method == "adam":
            upd, state = opt.update(jnp.asarray(g), state, jnp.asarray(u))
            u_new = u + np.asarray(upd)
            v_new, g_new = vg(u_new)
        else:
            d, state_new = opt.update(jnp.asarray(g), state, jnp.asarray(u))
            d = np.asarray(d)
            slope = float(g @ d)
            if slope <= 0:  # not a descent direction (curvature pair gone bad): fall back to the gradient
                d, slope = g.copy(), float(g @ g)
            alpha = min(1.0, first_step / max(np.max(np.abs(d)), 1e-300)) if it == 1 else 1.0
            for _ in range(max_backtracks + 1):
                u_new = u - alpha * d
                v_new, g_new = vg(u_new)
                if v_new <= value - 1e-4 * alpha * slope:
                    break
                alpha *= 0.5
            else:
                converged, it = True, it - 1  # no decrease along the direction: the loss's noise floor
                break
            state = state_new
        step = float(np.max(np.abs(u_new - u)))
        u, value, g = u_new, v_new, g_new
        vals = start * np.exp(u)
        loss_path.append(value)
        for f, v in zip(fields, vals):
            paths[f].append(float(v))
        if callback is not None:
            callback(it, value, {f: float(v) for f, v in zip(fields, vals)})
        if value < tol_loss or step < tol_step:
            converged = True
            break
    p, vals = to_params(u)
    return CalibrationResult(params=p, values={f: float(v) for f, v in zip(fields, vals)}, loss_path=loss_path,
                             param_paths=paths, n_iter=it, n_evals=n_evals, converged=converged,
                             seconds=time.perf_counter() - t0)
