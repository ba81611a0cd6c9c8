"""Does the seed scheme's water come to rest? Energy of the stress suite's collapsed column per
pressure-gradient kernel (``SeedScheme(gradient=...)``) and pressure-force form: JSON lines.

The scene of ``tests/stress/test_long_run.py`` (a water column a x 2a, a = 0.08 m, dx = a / 4,
collapsing in a closed tank 2a long as a periodic slab 7 dx wide), ``SeedScheme``, float32, run for
``--steps`` steps; energies (``validation.energy_history``) in m g 2a, as that test's bounds:
``rebound`` = max_t (E(t) - min_{s<=t} E(s)) (bound 3e-3), ``late`` = |E(end) - E(mid)| (bound
1e-3), ``kinetic_end``, and the mean |rho / rho0 - 1| at the end.

Variants: ``--gradients`` the kernel whose gradient the pressure force uses (``spiky``: the paper's,
seed Eq 15; ``poly6``: the density sum's); ``--forms`` the pressure force's form (``paper``:
Mueller et al.'s ``(p_i + p_j) / (2 rho_i rho_j)``, what ``sph.seed.forces`` computes;
``variational``: ``p_i / rho_i^2 + p_j / rho_j^2``, the gradient of the elastic energy when the
kernel is the density's; swapped in here for the A/B only through ``sph.seed.pressure_coefficient``,
not an option of the package).
``--dam-break RES ...`` also runs ``dam_break_2d.py``'s Martin & Moyce front per gradient kernel.

    python experiments/seed_rest.py --out experiments/results/seed_rest.jsonl
    python experiments/seed_rest.py --forms variational --dam-break --out experiments/results/seed_rest.jsonl
    python experiments/seed_rest.py --no-column --hydrostatic --out experiments/results/seed_rest.jsonl

``--hydrostatic``: the pressure ``p`` of a still tank against rho0 g depth. Mueller's symmetrised force
``(p_i + p_j) / 2`` is half the SPH pressure gradient, so at rest the seed scheme's ``p`` is about twice
the hydrostatic pressure (its forces balance the water's weight: the pressure they carry is p / 2).
"""

from __future__ import annotations

import argparse
import datetime
import os
import time

import numpy as np

from jsonl_out import emit

A = 0.08
DX = A / 4


def _variational_coefficient(m_j, p_i, p_j, rho_i, rho_j):
    """``sph.seed.pressure_coefficient`` of the energy-conserving form: ``-m_j rho_i (p_i / rho_i^2 + p_j / rho_j^2)``
    (``forces`` divides by ``rho_i``)."""
    return -m_j * rho_i * (p_i / rho_i**2 + p_j / rho_j**2)


def _forget_compiled():
    import jax

    from rockjax import driver

    driver._compiled_chunk.cache_clear()
    jax.clear_caches()


def column(gradient: str):
    """The stress long run's seed scene with ``SeedScheme(gradient=gradient)`` (a name: spiky, poly6)."""
    import rockjax as rj

    w = 7 * DX
    scene = rj.scenes.dam_break(dx=DX, column_length=A, column_width=w, column_height=2 * A, tank_length=2 * A,
                                tank_width=w, tank_height=4 * A, periodic_y=True,
                                scheme=rj.sph.from_names("seed", gradient=gradient))
    return scene


def rest(gradient: str, form: str, steps: int) -> dict:
    import rockjax as rj
    from rockjax.observables import fluid_mass
    from rockjax.sph import seed
    from rockjax.validation import energy_history

    scene = column(gradient)
    k = scene.config.rebuild_every
    per_frame = max(k, (steps // 50) // k * k)
    n_frames = max(1, round(steps / per_frame))
    t_end = n_frames * per_frame * scene.config.dt
    paper = seed.pressure_coefficient
    seed.pressure_coefficient = _variational_coefficient if form == "variational" else paper
    _forget_compiled()  # the compiled steps are cached per Config, which the form is not part of
    try:
        t0 = time.perf_counter()
        res = rj.simulate(scene, t_end=t_end * (1 - 1e-9), frame_dt=per_frame * scene.config.dt, progress=False)
        wall = time.perf_counter() - t0
        e = energy_history(res)
    finally:
        seed.pressure_coefficient = paper
        _forget_compiled()
    scale = float(fluid_mass(scene.state, scene.params)) * 9.81 * 2 * A
    tot, ke = e["total"] / scale, e["kinetic"] / scale
    half = len(tot) // 2
    fluid = res.frames["kind"][0] == rj.Kind.FLUID
    at = lambda t: float(ke[int(np.argmin(np.abs(res.times - t)))])  # noqa: E731
    return {"bench": "seed_rest", "gradient": gradient, "form": form, "a_over_dx": round(A / DX), "dtype":
            str(scene.state.particles.x.dtype), "steps": int(res.stats["steps"]), "t_end": float(res.times[-1]),
            "status": int(res.state.status), "growth": float(np.max(tot - tot[0])),
            "rebound": float(np.max(tot - np.minimum.accumulate(tot))), "late": float(abs(tot[-1] - tot[half])),
            "lost": float(tot[0] - tot[-1]), "kinetic_2s": at(2.0), "kinetic_end": float(ke[-1]),
            "rho_dev_end": float(np.mean(np.abs(res.frames["rho"][-1, fluid] / scene.params.fluid.rho0 - 1.0))),
            "wall_s": round(wall, 1), "date": datetime.date.today().isoformat(), "load": round(os.getloadavg()[0], 2)}


def front(gradient: str, res: int) -> dict:
    import dam_break_2d

    out = dam_break_2d.run("seed", res, seed_gradient=gradient)
    keep = ("a_over_dx", "n_fluid", "steps", "wall_s", "front_rms_rel_err", "front_rms_rel_err_best_shift")
    return {"bench": "seed_rest_front", "gradient": gradient, **{k: out[k] for k in keep},
            "date": datetime.date.today().isoformat(), "load": round(os.getloadavg()[0], 2)}


def hydrostatic(gradient: str, *, dx: float = 0.02, depth: float = 0.3, t_end: float = 2.0) -> dict:
    """Pressure at rest over the hydrostatic one, ``p / (rho0 g (depth - z))``, per 0.06 m band of a
    still tank (``scenes.hydrostatic_tank``, 0.2 x 0.2 m), averaged over frames from 1 s to ``t_end``."""
    import rockjax as rj

    sc = rj.scenes.hydrostatic_tank(dx=dx, length=0.2, width=0.2, depth=depth,
                                    scheme=rj.sph.from_names("seed", gradient=gradient))
    res = rj.simulate(sc, t_end=t_end, frame_dt=0.1, progress=False)
    fl = res.frames["kind"][0] == rj.Kind.FLUID
    late = res.times >= 1.0
    z, p = res.frames["x"][late][:, fl, 2], res.frames["p"][late][:, fl]
    rho_g = float(sc.params.fluid.rho0) * 9.81
    bands = [(lo, lo + 0.06) for lo in (0.0, 0.06, 0.12, 0.18)]
    ratio = [float(np.mean(p[(z >= lo) & (z < hi)]) / (rho_g * (depth - np.mean(z[(z >= lo) & (z < hi)]))))
             for lo, hi in bands]
    return {"bench": "seed_rest_hydrostatic", "gradient": gradient, "dx": dx, "depth": depth, "bands_z": bands,
            "p_over_hydrostatic": [round(r, 3) for r in ratio], "date": datetime.date.today().isoformat(),
            "load": round(os.getloadavg()[0], 2)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gradients", nargs="+", default=["spiky", "poly6"], choices=["spiky", "poly6"])
    ap.add_argument("--forms", nargs="+", default=["paper"], choices=["paper", "variational"])
    ap.add_argument("--steps", type=int, default=30000, help="time steps of the column run (30000: 11 s)")
    ap.add_argument("--dam-break", type=int, nargs="*", default=None, metavar="RES",
                    help="also the 2D dam-break front at these a/dx (none given: 10 20)")
    ap.add_argument("--hydrostatic", action="store_true",
                    help="also the pressure of a still tank over the hydrostatic one, per gradient kernel")
    ap.add_argument("--no-column", action="store_true", help="skip the column runs")
    ap.add_argument("--out", default=None, help="also append the JSON lines to this file")
    a = ap.parse_args(argv)
    for form in [] if a.no_column else a.forms:
        for g in a.gradients:
            emit(rest(g, form, a.steps), a.out)
    if a.hydrostatic:
        for g in a.gradients:
            emit(hydrostatic(g), a.out)
    if a.dam_break is not None:
        for res in a.dam_break or [10, 20]:
            for g in a.gradients:
                emit(front(g, res), a.out)


if __name__ == "__main__":
    main()
