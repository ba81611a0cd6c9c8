"""Gradients of a fluid-only rollout (float64): central finite differences and vmap(grad).

Scene (``gradcases.tiny_dam_break``): a 0.3 x 0.3 x 0.5 m column at dx = 0.1 m (45 fluid
particles, WCSPH, Adami walls, artificial viscosity) collapsing for 96 steps (0.1 s, 12 list
rebuilds). Observable: the fluid kinetic energy at the end [J]; gradients w.r.t. the speed of
sound ``fluid.c0`` and the artificial-viscosity coefficient ``fluid.alpha``.

Why the horizon is not chaotic: 0.1 s is the early collapse (the front has not reached the far
wall; no impact, no splash); each particle moves less than one dx. The neighbour lists are built
under stop_gradient and the kernel is C2 with compact support, so a pair entering or leaving the
list changes nothing; the particle re-sort at each rebuild is a permutation (the observable is
a sum over particles).

Tolerance: 1 % relative. Measured: c0 3e-9, alpha 6e-10 (FD step 1e-5 relative). The kinetic
energy oscillates with the acoustic period (~h / c0), so the central difference needs a small
step: at 1e-3 relative its truncation error in c0 was 0.3 %, at 1e-4 0.006 %.
vmap(grad) over three (c0, alpha) members equals per-member grad to 1e-13 relative (measured);
the bound is 1e-10 (vmapped reductions may sum in another order).

Checkpointing changes what is stored, not what is computed: the gradient with 1, 2 or 3
checkpoint levels (``make_rollout(checkpoint_levels=...)``; the finite-difference tests above check
the default, 2) agree to round-off (5 blocks in chunks of 2, 2 and a tail of 1, so every level and
the tail are exercised). That check and the forward-mode one (``jax.jvp`` through the rollout)
are in the slow suite: ~240 s and ~95 s of tracing and compiles on 2 cores.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gradcases as gc
from rockjax import ensembles
from rockjax.calibrate import get_leaf, observed, set_leaf

REL_TOL = 0.01
FD_STEP = 1e-5


@pytest.fixture(scope="module")
def dam(x64):
    scene = gc.tiny_dam_break()
    vg = gc.dam_functional(scene.config)
    value, grads = vg(scene.params, scene.state)
    return dict(scene=scene, vg=vg, value=float(value), grads=grads)


@pytest.mark.parametrize("path", ["fluid.c0", "fluid.alpha"])
def test_kinetic_energy_gradient_matches_fd(dam, path):
    scene, vg = dam["scene"], dam["vg"]
    assert dam["value"] > 1.0  # the column is collapsing (~10 J)
    ad = float(get_leaf(dam["grads"], path))
    fd = gc.central_fd(lambda p: vg(p, scene.state)[0], scene.params, path, FD_STEP, get_leaf=get_leaf,
                       set_leaf=set_leaf)
    assert np.isfinite(ad) and ad != 0.0
    assert abs(ad - fd) <= REL_TOL * abs(fd), f"{path}: AD {ad:.6e} vs FD {fd:.6e}"


@pytest.mark.parametrize("batch_size", [None, 2])
def test_vmap_grad_equals_per_member_grad(dam, batch_size):
    """``ensemble(grad)``: all three members under one ``vmap`` (None), or a ``lax.map`` of vmapped
    pairs and a remainder of one (2), equal each member's own gradient."""
    scene, vg = dam["scene"], dam["vg"]
    pb = ensembles.batch(scene.params, 3, {"fluid.c0": jnp.array([25.0, 31.3, 40.0]),
                                           "fluid.alpha": jnp.array([0.01, 0.02, 0.05])})
    values, grads = ensembles.ensemble(lambda p: vg(p, scene.state), batch_size=batch_size)(pb)
    for i in range(3):
        v_i, g_i = vg(ensembles.member(pb, i), scene.state)
        assert abs(float(values[i]) - float(v_i)) <= 1e-10 * abs(float(v_i))
        for a, b in zip(jax.tree_util.tree_leaves(ensembles.member(grads, i)), jax.tree_util.tree_leaves(g_i)):
            assert np.all(np.isfinite(np.asarray(a)))
            np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-10, atol=1e-12 * float(jnp.max(jnp.abs(b))))
    # the members differ: the batch really swept the parameters
    assert float(jnp.std(values)) > 1e-3 * float(jnp.mean(values))


def _short_loss(scene, **kw):
    n_steps = 5 * scene.config.rebuild_every  # 5 blocks: chunks of 2, 2 and a tail of 1

    def L(p):
        final, _ = observed(scene, p, n_steps, None, chunk=2, **kw)
        return jnp.sum(jnp.where(final.particles.kind[:, None] == 0, final.particles.v**2, 0.0))

    return L


def _grad_c0_alpha(scene, **kw):
    g = jax.jit(jax.grad(_short_loss(scene, **kw)))(scene.params)
    return np.array([float(get_leaf(g, "fluid.c0")), float(get_leaf(g, "fluid.alpha"))])


@pytest.mark.slow  # three checkpointed-rollout gradients (~240 s of tracing and compiles on 2 cores)
def test_checkpoint_levels_give_the_same_gradient(dam):
    scene = dam["scene"]
    n_steps = 5 * scene.config.rebuild_every

    def grad(**kw):
        return _grad_c0_alpha(scene, **kw)

    ref = grad(checkpoint_levels=2)
    assert np.all(np.isfinite(ref)) and np.all(ref != 0.0)
    for levels in (1, 3):
        np.testing.assert_allclose(grad(checkpoint_levels=levels), ref, rtol=1e-9, err_msg=f"levels={levels}")
    with pytest.raises(ValueError, match="checkpoint_levels"):
        observed(scene, scene.params, n_steps, None, checkpoint_levels=4)


@pytest.mark.slow  # a gradient and a jvp of the rollout (~95 s of compiles on 2 cores)
def test_forward_mode_matches_reverse_mode(dam):
    # jax.jvp goes through the checkpointed rollout too: the directional derivative along
    # (dc0, dalpha) equals grad . (dc0, dalpha)
    scene = dam["scene"]
    L = _short_loss(scene)
    g = _grad_c0_alpha(scene)
    dc0, dalpha = 0.7, -1.3
    tangent = jax.tree_util.tree_map(jnp.zeros_like, scene.params)
    tangent = set_leaf(set_leaf(tangent, "fluid.c0", dc0), "fluid.alpha", dalpha)
    _, dL = jax.jit(lambda p, t: jax.jvp(L, (p,), (t,)))(scene.params, tangent)
    expect = g[0] * dc0 + g[1] * dalpha
    assert abs(float(dL) - expect) <= 1e-9 * (abs(g[0] * dc0) + abs(g[1] * dalpha)), (float(dL), expect)
