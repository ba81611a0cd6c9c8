"""The gradient of an ensemble-smoothed objective over the full wedge event (issue 44, item 4).

Scene and smooth settings as ``smoothness_ab.py`` (variant ``smooth``: ``calibrate.smooth_config``;
the first records were taken with ``law+coupling``, before the joint-water fade), float64, ``--steps`` (default 1056 = 0.80 s). The
objective is an observation at the end (``--obs``: the smooth run-up on the far beach, or the
wedge's down-slope coordinate), averaged over ``--members`` initial states whose wedge velocity
is perturbed by ``--sigma`` m/s (``ensembles.perturbed(..., {"blocks.v[0]": sigma})``).

Per leaf: the ensemble's mean AD gradient and its standard error
(``ensembles.smoothed_value_and_grad``), the single member's AD gradient and secants (the exact,
local derivative), and central secants of the smoothed objective at relative steps 1e-2, 1e-3,
1e-4 (common random numbers: every member with its own perturbation at p + h and p - h).

    .venv/bin/python experiments/smoothed_gradient.py [--members 8] [--sigma 1e-3] [--obs smooth_runup]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from rockjax.calibrate import get_leaf, observed, set_leaf  # noqa: E402
from rockjax.ensembles import ensemble, member, perturbed, smoothed_value_and_grad  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402
from smoothness_ab import OBS, observer, variant, wedge  # noqa: E402

STEPS = (1e-2, 1e-3, 1e-4)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1056)
    ap.add_argument("--members", type=int, default=8)
    ap.add_argument("--sigma", type=float, default=1e-3)
    ap.add_argument("--obs", default="smooth_runup", choices=OBS)
    ap.add_argument("--variant", default="smooth")
    ap.add_argument("--leaves", default="blocks.density[0],blocks.friction_angle")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    scene = wedge(0.05)
    cfg = variant(scene, a.variant)
    observe = observer(scene, cfg)
    k = OBS.index(a.obs)

    def loss(p, s):
        final, _ = observed(cfg, p, a.steps, None, state=s)
        return observe(final, p)[k]

    states = perturbed(scene.state, jax.random.PRNGKey(0), a.members, {"blocks.v[0]": a.sigma})
    t0 = time.perf_counter()
    sm = smoothed_value_and_grad(loss, scene.params, states)
    t_grad = time.perf_counter() - t0
    values = ensemble(loss, in_axes=(None, 0))
    one_vg = jax.jit(jax.value_and_grad(loss))
    one_v = jax.jit(loss)
    leaves = a.leaves.split(",")
    for leaf in leaves:
        x0 = float(get_leaf(scene.params, leaf))
        fd_mean, fd_sem, fd_one = [], [], []
        for r in STEPS:
            h = r * abs(x0)
            d = (np.asarray(values(set_leaf(scene.params, leaf, x0 + h), states))
                 - np.asarray(values(set_leaf(scene.params, leaf, x0 - h), states))) / (2 * h)
            fd_mean.append(float(d.mean()))
            fd_sem.append(float(d.std(ddof=1) / np.sqrt(len(d))))
            s0 = member(states, 0)
            fd_one.append(float((one_v(set_leaf(scene.params, leaf, x0 + h), s0)
                                 - one_v(set_leaf(scene.params, leaf, x0 - h), s0)) / (2 * h)))
        ad_one = float(get_leaf(one_vg(scene.params, member(states, 0))[1], leaf))
        g, sem = float(get_leaf(sm.grad, leaf)), float(get_leaf(sm.grad_sem, leaf))
        emit(dict(kind="smoothed_gradient", variant=a.variant, obs=a.obs, leaf=leaf, t_end=round(a.steps * float(cfg.dt), 4),
                  members=a.members, sigma_v=a.sigma, value=float(sm.value), value_std=float(sm.value_std),
                  ad_mean=g, ad_sem=sem, fd_mean={f"{r:.0e}": v for r, v in zip(STEPS, fd_mean)},
                  fd_sem={f"{r:.0e}": v for r, v in zip(STEPS, fd_sem)},
                  member0_ad=ad_one, member0_fd={f"{r:.0e}": v for r, v in zip(STEPS, fd_one)},
                  grad_wall_s=round(t_grad, 1)), a.out)


if __name__ == "__main__":
    main()
