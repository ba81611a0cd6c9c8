"""Why the exact gradient of the full event is local: the growth of tangents (issue 44).

Issue 44's test target asks central secants at relative steps 1e-3 and 1e-4 to agree with AD
within 2 % at the full horizon (0.8 s) of the coupled wedge. ``smoothness_ab.py`` found that
beyond ~0.42 s no smoothing setting gets there. This experiment measures whether the cause is the
flow itself (sensitive dependence on the initial state: a smooth map whose derivative varies on
parameter scales that shrink in time) rather than a switch in the step:

1. **Tangent growth** (forward mode, exact): the RMS over the water particles of the position
   tangent ``|dx_i(t)/de|`` for a random unit perturbation ``e`` of the initial water positions,
   and of ``|dx_i(t)/d ln theta|`` for each parameter ``theta`` (``--leaves``). A chaotic flow makes
   them grow like ``exp(lambda t)``; the local rates are fitted over ``--windows``.
2. **The derivative's scale in the parameter**: AD of the observables (wedge position, gauge at
   x = 0.30 m, smooth run-up: ``smoothness_ab.observer``) at ``theta (1 + delta)`` for ``delta`` in
   ``--offsets``; ``scale(t)`` is the largest ``delta`` up to which every AD stays within 2 % of
   the one at ``theta``. A secant over ``+-delta`` can agree with AD to 2 % only where
   ``delta`` is below about that scale: the target's 1e-3 needs ``scale >= 1e-3``.

The same tangent growth on a water-only dam break (``--control``) tells the flow's share from the
block's and its contacts'.

Output: JSON lines (``--out``): per scene and report time, the tangent norms and the scale per
leaf and observable; per scene the fitted rates.

    .venv/bin/python experiments/tangent_growth.py [--variant smooth] [--steps 1056] [--control] [--out F]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from rockjax import Status, scenes  # noqa: E402
from rockjax.calibrate import get_leaf, observed, set_leaf  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from jsonl_out import emit  # noqa: E402
from smoothness_ab import OBS, observer, variant, wedge  # noqa: E402

OFFSETS = (1e-7, 1e-6, 1e-5, 1e-4, 1e-3)


def rms(a):
    """RMS over all axes but the first (time)."""
    return np.sqrt(np.mean(np.asarray(a).reshape(a.shape[0], -1) ** 2, axis=1))


def fit_rate(times, norms, lo, hi):
    """Least-squares slope of ln(norm) over lo <= t <= hi [1/s] (None with fewer than 3 points)."""
    sel = (times >= lo) & (times <= hi) & (norms > 0)
    if sel.sum() < 3:
        return None
    return float(np.polyfit(times[sel], np.log(norms[sel]), 1)[0])


def scale_of(g0, gs, offsets, tol=0.02):
    """The largest offset up to which every ``gs[k]`` stays within ``tol`` of ``g0`` (relative);
    0.0 when even the smallest does not (``offsets`` ascending; ``gs`` [K])."""
    best = 0.0
    for d, g in zip(offsets, gs):
        if abs(g - g0) > tol * abs(g0):
            break
        best = d
    return best


def tangent_runs(config, state, params, n_steps, observe, leaves, seed, n_fluid):
    """Forward-mode tangents along one rollout (observations after every block of steps, T of them).

    Returns ``(obs0, x, tangents, jvp, dx0, zero_p)``: the observables [T, n_obs] ([T, 0] without
    ``observe``), the water positions [T, n_fluid, 3], ``tangents[name] = (d obs [T, n_obs],
    d x [T, n_fluid, 3])`` for ``"x_init"`` (the initial water positions along a random unit-RMS
    direction) and each leaf (``d / d ln theta``); and, for more tangents of the same compiled
    program, ``jvp(params, dx0, params_tangent, dx0_tangent)``, the zero position offset ``dx0``
    and a zero params tangent ``zero_p``.
    """

    def run(p, dx0):
        parts = state.particles
        s = state.replace(particles=parts.replace(x=parts.x.at[:n_fluid].add(dx0)))

        def obs(st, pp):
            o = observe(st, pp) if observe is not None else jnp.zeros((0,))
            return o, st.particles.x[:n_fluid]

        final, (o, x) = observed(config, p, n_steps, obs, state=s)
        return (o, x), final.status

    dx0 = jnp.zeros((n_fluid, 3))
    fwd = jax.jit(run)
    (o0, x0), status = fwd(params, dx0)
    if int(status):
        raise RuntimeError(f"forward run failed: {Status.describe(int(status))}")
    jvp = jax.jit(lambda p, d, tp, td: jax.jvp(lambda q, e: run(q, e)[0], (p, d), (tp, td))[1])
    zero_p = jax.tree_util.tree_map(jnp.zeros_like, params)
    e = jax.random.normal(jax.random.PRNGKey(seed), (n_fluid, 3))
    e = e / jnp.sqrt(jnp.mean(e * e))
    out = {"x_init": jvp(params, dx0, zero_p, e)}
    for leaf in leaves:
        x0_leaf = get_leaf(params, leaf)
        out[leaf] = jvp(params, dx0, set_leaf(zero_p, leaf, x0_leaf), jnp.zeros_like(dx0))
    np_out = {k: (np.asarray(v[0]), np.asarray(v[1])) for k, v in out.items()}
    return np.asarray(o0), np.asarray(x0), np_out, jvp, dx0, zero_p


DAM_OBS = ("kinetic_energy", "centroid_x", "front_x")


def fluid_variant(scene, name: str):
    """The water-only scene's config for a wedge variant name: ``smoothness_ab.variant`` with only
    its fluid parts (``smoothav``, ``softfloor``, ``laminar``); the block parts (``smooth``,
    ``law``, ...) have nothing to act on."""
    parts = [p for p in name.split("+") if p in ("smoothav", "softfloor", "laminar")]
    return variant(scene, "+".join(parts) or "sharp")


def dam_observer(config, dx: float):
    """Water-only observables: kinetic energy [J], the centroid's x [m], and a smooth front
    (log-sum-exp of x over dx / 4) [m]."""
    nf = config.n_fluid

    def observe(state, params):
        P = state.particles
        m = params.fluid.rho0 * P.vol[:nf]
        v2 = jnp.sum(P.v[:nf] ** 2, axis=1)
        x = P.x[:nf, 0]
        tau = 0.25 * dx
        front = tau * jax.scipy.special.logsumexp(x / tau)
        return jnp.stack([0.5 * jnp.sum(m * v2), jnp.sum(m * x) / jnp.sum(m), front])

    return observe


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.05)
    ap.add_argument("--steps", type=int, default=1056)
    ap.add_argument("--variant", default="smooth", help="smoothness_ab.variant name (sharp, smooth, ...)")
    ap.add_argument("--leaves", default="blocks.density[0],blocks.friction_angle,fluid.alpha")
    ap.add_argument("--scale-leaves", default="blocks.density[0],blocks.friction_angle",
                    help="leaves whose derivative scale is measured (AD at theta (1 + delta) per offset)")
    ap.add_argument("--offsets", default=",".join(f"{d:g}" for d in OFFSETS))
    ap.add_argument("--report-times", default="0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8")
    ap.add_argument("--windows", default="0.05-0.25,0.25-0.45,0.45-0.8")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--control", action="store_true",
                    help="also the water-only dam break (0.2 x 0.2 x 0.4 m column in a 0.8 x 0.2 m tank, dx / 2), "
                         "with the variant's fluid parts")
    ap.add_argument("--only-control", action="store_true", help="the dam break only")
    ap.add_argument("--water-depth", type=float, default=0.2,
                    help="m; 0.4 puts the slope's toe beyond the wedge's reach within 0.8 s")
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    offsets = tuple(float(s) for s in a.offsets.split(","))
    windows = [tuple(float(v) for v in w.split("-")) for w in a.windows.split(",")]
    report = [float(s) for s in a.report_times.split(",")]
    leaves = a.leaves.split(",")

    scene = wedge(a.dx, a.water_depth)
    cfg = variant(scene, a.variant)
    cases = [("wedge", cfg, scene.state, scene.params, observer(scene, cfg), leaves, a.scale_leaves.split(","), OBS)]
    if a.control:
        dam = scenes.dam_break(dx=a.dx / 2, column_length=0.2, column_width=0.2, column_height=0.4, tank_length=0.8,
                               tank_width=0.2)
        dcfg = fluid_variant(dam, a.variant)
        cases.append(("dam_break", dcfg, dam.state, dam.params, dam_observer(dcfg, a.dx / 2), ["fluid.alpha"], ["fluid.alpha"],
                      DAM_OBS))
    if a.only_control:
        cases = cases[1:]
    for name, config, state, params, observe, lv, scale_leaves, obs_names in cases:
        nf = config.n_fluid
        dt = float(config.dt)
        steps = a.steps if name == "wedge" else int(round(a.steps * float(scene.config.dt) / dt / config.rebuild_every)) * config.rebuild_every
        t0 = time.perf_counter()
        o0, x0, tang, jvp, dx0, zero_p = tangent_runs(config, state, params, steps, observe, lv, a.seed, nf)
        t_tan = time.perf_counter() - t0
        times = dt * config.rebuild_every * np.arange(1, x0.shape[0] + 1)
        norms = {k: rms(v[1]) for k, v in tang.items()}
        rates = {k: [fit_rate(times, n, lo, hi) for lo, hi in windows] for k, n in norms.items()}
        # the derivative's scale in each leaf: AD at theta (1 + delta)
        scales = {}
        t1 = time.perf_counter()
        if observe is not None:
            for leaf in scale_leaves:
                th = float(get_leaf(params, leaf))
                gs = []
                for d in offsets:
                    p = set_leaf(params, leaf, th * (1 + d))
                    gs.append(np.asarray(jvp(p, dx0, set_leaf(zero_p, leaf, th), jnp.zeros_like(dx0))[0]))
                gs = np.stack(gs)  # [K, T, n_obs]
                g0 = tang[leaf][0]
                scales[leaf] = np.array([[scale_of(g0[t, k], gs[:, t, k], offsets) for k in range(g0.shape[1])]
                                         for t in range(g0.shape[0])])  # [T, n_obs]
        t_scale = time.perf_counter() - t1
        for tr in report:
            if tr > times[-1] + 1e-9:
                continue
            t = int(np.argmin(np.abs(times - tr)))
            rec = dict(scene=name, variant=a.variant, water_depth=a.water_depth if name == "wedge" else None, dx=a.dx if name == "wedge" else a.dx / 2,
                       n_fluid=nf, t=round(float(times[t]), 4),
                       tangent_rms={k: float(n[t]) for k, n in norms.items()})
            if observe is not None:
                rec["obs"] = {on: float(o0[t, k]) for k, on in enumerate(obs_names)}
                rec["ad"] = {leaf: {on: float(tang[leaf][0][t, k]) for k, on in enumerate(obs_names)} for leaf in lv}
                rec["scale"] = {leaf: {on: float(s[t, k]) for k, on in enumerate(obs_names)} for leaf, s in scales.items()}
            emit(rec, a.out)
        emit(dict(scene=name, variant=a.variant, summary=True, water_depth=a.water_depth if name == "wedge" else None, n_fluid=nf, steps=steps,
                  t_end=round(float(times[-1]), 4), dt=dt, windows=[f"{lo}-{hi}" for lo, hi in windows],
                  rates_per_s={k: [None if r is None else round(r, 2) for r in v] for k, v in rates.items()},
                  growth_to_end={k: (float(n[-1] / n[0]) if n[0] > 0 else None) for k, n in norms.items()},
                  tangents_s=round(t_tan, 1), scales_s=round(t_scale, 1)), a.out)


if __name__ == "__main__":
    main()
