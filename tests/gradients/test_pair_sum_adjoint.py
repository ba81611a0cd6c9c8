"""The gather-only reverse mode of the WCSPH pair sums (``Adjoint.PAIR_SUMS``, ``rockjax.sph.pair_sum``)
against JAX's own (``Adjoint.AUTODIFF``), float64.

The custom VJP rests on one property of the neighbour list: a fluid pair within the kernel's
support is listed both ways (``test_fluid_pairs_within_support_are_listed_both_ways``, on a
developed dam break). Given it, the two reverse modes compute the same derivatives in another
order, so the gradient of one step's outcome with respect to every state and parameter leaf must
agree to round-off (bound 1e-10 of each leaf's largest entry; measured <= 2e-14):

* ``dam``: the default scheme (Fourtakas diffusion, artificial viscosity, Adami walls), the
  forward in one block and the reverse pass in blocks (of 128 rows: ``Tuning.backward_tile``);
* ``dam-antuono-laminar-dynamic``: Antuono's diffusion (renormalised gradients as pass outputs and
  inputs), laminar viscosity, dynamic walls, in blocks of 7 rows, so the last block overlaps its
  predecessor (its shared rows must count once);
* ``wedge``: the sliding wedge with boundary particles (block particles as wall columns; the
  blocks' loads from the pairs; the block state in the outcome);
* ``dam-no-diffusion``: no density diffusion, in blocks of 7 rows.

``dam``, ``wedge`` and ``dam-no-diffusion`` run the hand-derived pullbacks of ``rockjax.sph.pullbacks``
(both ends of a pair at once; the test checks that the trace takes them), the Antuono/laminar case
JAX's VJP of each pair function.

And through a whole checkpointed rollout (``gradcases.tiny_dam_break``, 96 steps, 12 rebuilds):
the gradient of ``test_fluid_grad``'s loss agrees to round-off (measured <= 2e-15).
The ``wedge`` case and the rollout are in the slow suite (~140 s and ~110 s of compiles on 2 cores).

Each state is the scene's lattice with the water moved by up to 0.15 dx, random velocities and
densities, then primed (list rebuilt), so every pair term is live. Also: ``jax.vmap`` of the
custom VJP (ensembles) equals it per member, and ``jax.jvp`` through it raises (forward mode needs
``Adjoint.AUTODIFF``, as ``Tuning.adjoint`` documents).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
import rockjax as rj
from rockjax.sph import wcsph
from rockjax.sph.kernels import SUPPORT_FACTOR
from rockjax.sph.neighbours import block_plan
from rockjax.step import advance

DX = 0.05
CASES = {
    "dam": dict(scene="dam", kw={}, row_tile=None, backward_tile=128),
    "dam-antuono-laminar-dynamic": dict(scene="dam", kw=dict(scheme=rj.WCSPH(diffusion=rj.sph.Antuono(),
                                                                             viscosity=rj.sph.Laminar(),
                                                                             walls=rj.sph.DynamicWalls())),
                                        row_tile=7),
    "wedge": dict(scene="wedge", kw=dict(coupling=rj.Coupling.BOUNDARY_PARTICLES), row_tile=None),
    "dam-no-diffusion": dict(scene="dam", kw=dict(scheme=rj.WCSPH(diffusion=rj.sph.NoDiffusion())), row_tile=7),
}

#: which cases' pair functions have a hand-derived pullback (``rockjax.sph.pullbacks``): the
#: others run JAX's VJP of the pair function from each end
HAND = {"dam": True, "dam-antuono-laminar-dynamic": False, "wedge": True, "dam-no-diffusion": True}


def _scene(case):
    if case["scene"] == "dam":
        return rj.scenes.dam_break(dx=DX, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8,
                                   tank_width=0.3, **case["kw"])
    return rj.scenes.sliding_wedge(dx=DX, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                                   flat_length=0.4, flume_width=0.4, start_distance=0.0, **case["kw"])


def _outcome(state):
    P = state.particles
    out = jnp.sum(P.v**2 * jnp.arange(1, 4)) + 1e-3 * jnp.sum(P.rho) + jnp.sum(P.x[:, 2] ** 2) + 1e-4 * jnp.sum(P.p)
    if state.blocks is not None:
        out = out + jnp.sum(state.blocks.x**2) + jnp.sum(state.blocks.v**2)
    return out


def _perturbed(scene, config, seed=0):
    """The scene's state with the fluid moved by up to 0.15 dx, random velocities (0.3 m/s) and
    densities (0.2 %), primed (list rebuilt, pressures and rates filled): every pair term is live."""
    rng = np.random.default_rng(seed)
    P = scene.state.particles
    fluid = np.asarray(P.kind) == rj.Kind.FLUID
    n = int(fluid.sum())
    dx = DX
    x = np.asarray(P.x).copy()
    v = np.asarray(P.v).copy()
    rho = np.asarray(P.rho).copy()
    x[fluid] += rng.uniform(-0.15, 0.15, (n, 3)) * dx
    v[fluid] = rng.normal(0.0, 0.3, (n, 3))
    rho[fluid] *= 1.0 + rng.uniform(-2e-3, 2e-3, n)
    P = P.replace(x=jnp.asarray(x, P.x.dtype), v=jnp.asarray(v, P.v.dtype), rho=jnp.asarray(rho, P.rho.dtype))
    state = jax.jit(rj.prime, static_argnums=2)(scene.state.replace(particles=P), scene.params, config)
    assert int(state.status) == 0
    return state


class _Warm(dict):
    """Per case, built on first use (the slow ``wedge`` case's scene only when it runs): the
    config, a perturbed state and the parameters."""

    def __missing__(self, name):
        case = CASES[name]
        scene = _scene(case)
        config = scene.config.tuned(row_tile=case["row_tile"])
        self[name] = (config, _perturbed(scene, config), scene.params)
        return self[name]


@pytest.fixture(scope="module")
def warm(x64):
    return _Warm()


def _grad(config, state, params, adjoint):
    c = config.tuned(adjoint=adjoint)
    return jax.jit(jax.grad(lambda s, p: _outcome(advance(s, p, c)), argnums=(0, 1), allow_int=True))(state, params)


#: the coupled case compiles two gradients of a wedge step (~140 s on 2 cores): in the slow suite
SLOW_CASES = {"wedge"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_CASES else n for n in CASES])
def test_pair_sum_adjoint_equals_autodiff(warm, name, monkeypatch):
    config, state, params = warm[name]
    if CASES[name]["row_tile"]:
        size, count = block_plan(config.n_fluid, config.tuning.row_tile)
        assert size * count > config.n_fluid  # the last block overlaps (the case is meant to)
    used = []
    for fn in (wcsph._momentum_pair, wcsph._continuity_pair):  # record which pullbacks the trace takes
        def spy(config, factory=fn.symmetric_pullback):
            pb = factory(config)
            used.append(pb is not None)
            return pb
        monkeypatch.setattr(fn, "symmetric_pullback", spy)
    if CASES[name].get("backward_tile"):  # the reverse pass in blocks although the forward runs in one
        config = config.tuned(backward_tile=CASES[name]["backward_tile"])
        assert config.n_fluid > config.tuning.backward_rows() and config.effective_row_tile == 0
    ref = _grad(config, state, params, rj.Adjoint.AUTODIFF)
    got = _grad(config, state, params, rj.Adjoint.PAIR_SUMS)
    assert set(used) == {HAND[name]} and len(used) == (2 if HAND[name] else 1), used  # Antuono: no momentum_pair
    ref_leaves, _ = jax.tree_util.tree_flatten_with_path(ref)
    checked = 0
    for (path, a), b in zip(ref_leaves, jax.tree_util.tree_leaves(got)):
        if not jnp.issubdtype(a.dtype, jnp.floating):
            continue
        a, b = np.asarray(a), np.asarray(b)
        assert np.all(np.isfinite(b)), jax.tree_util.keystr(path)
        scale = np.max(np.abs(a))
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-10 * scale, err_msg=jax.tree_util.keystr(path))
        checked += scale > 0
    assert checked >= 10  # x, v, a, rho, vol and the fluid parameters carry gradients


def test_fluid_pairs_within_support_are_listed_both_ways(warm):
    config, state, params = warm["dam"]
    assert int(state.nbrs.max_count) > 20  # a real list (the support holds ~30-60 neighbours)
    idx, x = np.asarray(state.nbrs.idx), np.asarray(state.particles.x)
    nf = config.n_fluid
    support = SUPPORT_FACTOR * float(params.fluid.h)
    rows = {i: set(idx[i].tolist()) for i in range(nf)}
    both = one_way = 0
    for i in range(nf):
        for j in rows[i]:
            if j == i or j >= nf or np.linalg.norm(x[i] - x[j]) >= support:
                continue
            if i in rows[j]:
                both += 1
            else:
                one_way += 1
    assert both > 10 * nf and one_way == 0, (both, one_way)


def test_forward_mode_through_pair_sums_raises(warm):
    config, state, params = warm["dam"]
    c = config.tuned(adjoint=rj.Adjoint.PAIR_SUMS)
    tangent = jax.tree_util.tree_map(jnp.zeros_like, params)
    with pytest.raises(TypeError, match="custom_vjp"):
        jax.jvp(lambda p: _outcome(advance(state, p, c)), (params,), (tangent,))


def test_vmap_of_pair_sum_gradient_equals_per_member(warm):
    # ensembles batch the custom VJP (``rockjax.ensembles``): two members differing in c0 and alpha
    config, state, params = warm["dam"]
    c = config.tuned(adjoint=rj.Adjoint.PAIR_SUMS)

    def g(p):
        return jax.grad(lambda q: _outcome(advance(state, q, c)))(p)

    members = [params.replace(fluid=params.fluid.replace(c0=params.fluid.c0 * s, alpha=params.fluid.alpha * (2 - s)))
               for s in (0.9, 1.1)]
    batched = jax.jit(jax.vmap(g))(jax.tree_util.tree_map(lambda *a: jnp.stack(a), *members))
    for m, p in enumerate(members):
        one = jax.jit(g)(p)
        for a, b in zip(jax.tree_util.tree_leaves(one), jax.tree_util.tree_leaves(batched)):
            np.testing.assert_allclose(np.asarray(b[m]), np.asarray(a), rtol=1e-10, atol=1e-12 * float(np.max(np.abs(a))))


@pytest.mark.slow  # two checkpointed-rollout gradients (~110 s of compiles on 2 cores)
def test_rollout_gradient_equals_autodiff(x64):
    # through the checkpointed rollout (96 steps, 12 list rebuilds with the particles re-sorted,
    # displacement-triggered rebuilds under lax.cond): tests/gradients/test_fluid_grad.py's loss
    scene = gc.tiny_dam_break()
    grads = {}
    for adjoint in rj.Adjoint:
        config = scene.config.tuned(adjoint=adjoint)
        value, grads[adjoint] = gc.dam_functional(config)(scene.params, scene.state)
        assert float(value) > 1.0
    ref, got = (jax.tree_util.tree_leaves(grads[a]) for a in (rj.Adjoint.AUTODIFF, rj.Adjoint.PAIR_SUMS))
    assert any(float(np.max(np.abs(a))) > 0 for a in ref)
    for a, b in zip(ref, got):
        np.testing.assert_allclose(np.asarray(b), np.asarray(a), rtol=0, atol=1e-10 * float(np.max(np.abs(a))))
