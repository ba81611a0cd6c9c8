"""Ensembles: batching helpers, and the sharded ensemble equal to the unsharded one.

The sharded run needs several devices, which on CPU exist only if
``XLA_FLAGS=--xla_force_host_platform_device_count=4`` is set before JAX starts, so it runs in
a subprocess (``_ENSEMBLE_SCRIPT``): 8 members of the blocks-only incline (``gradcases``)
differing in density, friction angle (Params) and initial down-slope velocity (State), 40 steps,
the final centroid of the box as output. Compared, in float64:

* ``run_ensemble(..., shard=True)`` over 4 devices (shard_map, 2 members each) vs the unsharded
  run: identical (``array_equal``; on the CPU both map the members one at a time, ``ensemble``'s
  default there; ``tests/gradients/test_fluid_grad.py`` runs the vmapped batches);
* 6 members sharded (padded to 8, trimmed) vs the first 6 of the unsharded run: identical;
* two members run alone in this process (no vmap: ``gradcases.incline_functional``, the function
  the block gradient tests compile) vs their rows of the ensemble: equal to 1e-12 m (a vmapped
  program may order reductions differently; measured difference 0).

The members run ``gradcases.INCLINE_STEPS`` (400) steps; the output is the centroid of the box
projected on the down-slope direction and the slope normal.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import sys

import jax.numpy as jnp
import numpy as np
import pytest

from rockjax import ensembles
from rockjax.calibrate import get_leaf, set_leaf
from rockjax.rollout import n_blocks_for

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]

_ENSEMBLE_SCRIPT = r"""
import json, os, sys
import jax
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", os.environ["ROCKJAX_JAX_CACHE"])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
import jax.numpy as jnp, numpy as np
sys.path.insert(0, sys.argv[1])
import gradcases as gc
from rockjax import ensembles as E

scene = gc.incline()
n, steps = 8, gc.INCLINE_STEPS
pb = E.batch(scene.params, n, {"blocks.density[0]": jnp.linspace(2000.0, 3000.0, n),
                               "blocks.friction_angle": jnp.radians(jnp.linspace(15.0, 25.0, n))})
v0 = jnp.outer(jnp.linspace(0.0, 0.2, n), jnp.asarray(gc.incline_axes()[0]))
sb = E.batch(scene.state, n, {"blocks.v[0]": v0})
t_dir, n_dir = (jnp.asarray(a) for a in gc.incline_axes())
obs = lambda s, p: jnp.stack([s.blocks.x[0] @ t_dir, s.blocks.x[0] @ n_dir])
plain = np.asarray(E.run_ensemble(scene, pb, steps, obs, states=sb))
sharded = E.run_ensemble(scene, pb, steps, obs, states=sb, shard=True)
shard_devices = len(sharded.sharding.device_set)
sharded = np.asarray(sharded)
take = lambda t, k: jax.tree_util.tree_map(lambda a: a[:k], t)
padded = np.asarray(E.run_ensemble(scene, take(pb, 6), steps, obs, states=take(sb, 6), shard=True))
print("RESULT " + json.dumps(dict(
    devices=jax.device_count(), shard_devices=shard_devices,
    sharded_equal=bool(np.array_equal(plain, sharded)), padded_equal=bool(np.array_equal(plain[:6], padded)),
    plain=plain.tolist(),
    spread=float(np.ptp(plain[:, 0])), finite=bool(np.all(np.isfinite(plain))))))
"""


def test_sharded_ensemble_equals_unsharded(tmp_path, x64):
    script = tmp_path / "ensemble.py"
    script.write_text(_ENSEMBLE_SCRIPT)
    env = dict(os.environ)
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_force_host_platform_device_count=4").strip()
    env["JAX_PLATFORMS"] = "cpu"
    env.setdefault("ROCKJAX_JAX_CACHE", str(ROOT / ".jax_cache"))
    proc = subprocess.run([sys.executable, str(script), str(HERE)], capture_output=True, text=True, env=env,
                          timeout=900, cwd=str(ROOT))
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stdout[-2000:] + proc.stderr[-4000:]
    r = json.loads(lines[-1][len("RESULT "):])
    assert r["devices"] == 4 and r["shard_devices"] == 4
    assert r["finite"] and r["spread"] > 1e-4  # the members really differ (cm apart after 0.059 s)
    assert r["sharded_equal"], r
    assert r["padded_equal"], r
    # members 0 and 5 alone, with the same params and initial velocity as in the script
    import gradcases as gc

    scene = gc.incline()
    vg = gc.incline_functional(scene.config)
    plain = np.asarray(r["plain"])
    zero = jnp.zeros((gc.INCLINE_STEPS, 2))
    for i in (0, 5):
        p = set_leaf(scene.params, "blocks.density[0]", float(np.linspace(2000.0, 3000.0, 8)[i]))
        p = set_leaf(p, "blocks.friction_angle", float(np.radians(np.linspace(15.0, 25.0, 8)[i])))
        v0 = float(np.linspace(0.0, 0.2, 8)[i]) * gc.incline_axes()[0]
        s = scene.state.replace(blocks=scene.state.blocks.replace(v=scene.state.blocks.v.at[0].set(jnp.asarray(v0))))
        (_, (obs, status)), _ = vg(p, s, zero, zero, zero)
        np.testing.assert_allclose(np.asarray(obs[-1]), plain[i], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------------
# host-side helpers (no compile)
# --------------------------------------------------------------------------------------------


def test_batch_sets_leaves_and_entries(x64):
    import gradcases as gc

    scene = gc.incline()
    pb = ensembles.batch(scene.params, 3, {"blocks.density[0]": jnp.array([1.0, 2.0, 3.0]),
                                           "blocks.friction_angle": jnp.array([0.1, 0.2, 0.3])})
    assert pb.blocks.density.shape == (3, 2)
    np.testing.assert_array_equal(np.asarray(pb.blocks.density[:, 0]), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(np.asarray(pb.blocks.density[:, 1]), np.full(3, float(scene.params.blocks.density[1])))
    np.testing.assert_array_equal(np.asarray(pb.blocks.friction_angle), [0.1, 0.2, 0.3])
    members = ensembles.unstack(pb)
    assert len(members) == 3 and float(members[2].blocks.density[0]) == 3.0
    back = ensembles.stack(members)
    np.testing.assert_array_equal(np.asarray(back.blocks.density), np.asarray(pb.blocks.density))
    with pytest.raises(ValueError, match="blocks.density"):
        ensembles.batch(scene.params, 3, {"blocks.density[0]": jnp.ones(4)})


def test_leaf_paths_reject_bad_input(x64):
    import gradcases as gc

    scene = gc.incline()
    assert float(get_leaf(scene.params, "blocks.density[0]")) == 2500.0
    p = set_leaf(scene.params, "blocks.friction_angle", 0.5)
    assert float(p.blocks.friction_angle) == 0.5 and float(scene.params.blocks.friction_angle) != 0.5
    with pytest.raises(ValueError, match="no field 'densty'"):
        get_leaf(scene.params, "blocks.densty")
    with pytest.raises(ValueError, match="None"):
        get_leaf(scene.params, "fluid.c0")  # a blocks-only scene has no fluid params
    with pytest.raises(ValueError, match="form"):
        get_leaf(scene.params, "blocks/density")
    with pytest.raises(ValueError, match="shape"):
        set_leaf(scene.params, "blocks.density", jnp.ones(3))
    with pytest.raises(ValueError, match="rebuild_every"):
        n_blocks_for(scene.config.replace(rebuild_every=8), 12)


def test_batch_size_of_the_mapped_ensemble(x64):
    """``ensemble``'s ``batch_size``: every choice gives each member's own result (a cheap function,
    6 members: one scan, vmapped pairs, vmapped fours with a remainder of two, one vmap), with the
    shared argument held fixed; bad values are refused by name; the default is one member at a
    time on the CPU."""
    x = jnp.arange(6.0)
    f = lambda a, c: jnp.sin(a) * c + a**2
    want = np.asarray(f(x, 3.0))
    for b in (1, 2, 4, None, 10):
        np.testing.assert_allclose(np.asarray(ensembles.ensemble(f, in_axes=(0, None), batch_size=b)(x, 3.0)), want,
                                   rtol=1e-15, err_msg=str(b))
    assert ensembles.default_batch_size() == 1  # the tests run on the CPU
    for bad in (0, -1, 1.5, "all"):
        with pytest.raises(ValueError, match="batch_size"):
            ensembles.ensemble(f, batch_size=bad)
    with pytest.raises(ValueError, match="disagree"):
        ensembles.ensemble(f, batch_size=2)(x, jnp.ones(5))
