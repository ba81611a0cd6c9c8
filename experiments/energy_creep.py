"""Where the WCSPH energy "rebound" of the long stress run comes from (tests/stress/test_long_run.py).

The stress scene (a water column a x 2a, a = 0.08 m, collapsing in a tank 2a long, a periodic slab
7 dx wide) loses 0.1-0.25 m g 2a in the impact; afterwards, with the water all but still, the WCSPH
total energy (kinetic + potential + Tait elastic, ``validation.energy_history``) climbs again by a
few 1e-3 m g 2a. Three measurements, float64 (float32 creeps the same, see the test):

* ``resolution``: the same scene at a/dx = 4, 6, 8 to ``--t-end``: the rebound (max over t of
  E(t) - min_{s<=t} E(s)) and E(t_end) - E(t_end / 2), in m g 2a; ``--diffusion fourtakas antuono``
  runs it with each density diffusion;
* ``continuation`` (a/dx = 4, ``--continuation-diffusion``, default ``fourtakas_surface``, the
  default before 2026-11-26 that the records of 2026-11-24 ran): from the state at ``--t-start``
  the run is continued for ``--t-len`` with one term switched off at a time (same state, same dt):
  artificial viscosity (alpha = 0), density diffusion (delta = 0), both, and the Fourtakas
  hydrostatic term replaced by its odd part (``(H(a) - H(-a)) / 2``: the 4th-order series is not
  odd in ``a``, so its even part is a net density source on vertical pairs). The energy change
  over the continuation says which term feeds the creep;
* ``variants`` (``--variants``, a/dx = 4, from rest to ``--variants-t-end``): the change of
  2026-11-26 that makes ``sph.diffusion.Fourtakas`` (the hydrostatic difference about each
  pair's mean density, ``sph.diffusion.hydrostatic_pair_difference``) against the old term
  (``fourtakas_surface``), and what was tried with it: the odd part of the surface series instead,
  and the wet (wall density above rho0) or every Adami wall pair in the diffusion too
  (``wcsph._diffusion_pairs``; not kept: see its docstring).

JSON lines out (``--out`` appends). Nothing here is a test.

    .venv/bin/python experiments/energy_creep.py --out experiments/results/energy_creep.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from jsonl_out import emit  # noqa: E402

A = 0.08


def _scene(a_over_dx: int, diffusion: str = "fourtakas"):
    import rockjax as rj

    dx = A / a_over_dx
    w = 7 * dx
    return rj.scenes.dam_break(dx=dx, column_length=A, column_width=w, column_height=2 * A, tank_length=2 * A,
                               tank_width=w, tank_height=4 * A, periodic_y=True,
                               scheme=rj.sph.from_names("wcsph", diffusion=diffusion))


def _energy(res, scene):
    from rockjax.observables import fluid_mass
    from rockjax.validation import energy_history

    e = energy_history(res)
    scale = float(fluid_mass(scene.state, scene.params)) * 9.81 * 2 * A
    return e["t"], {k: v / scale for k, v in e.items() if k != "t"}


def resolution(a_over_dx: int, t_end: float, diffusion: str = "fourtakas") -> dict:
    import rockjax as rj

    scene = _scene(a_over_dx, diffusion)
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=t_end, frame_dt=0.25, progress=False)
    wall = time.perf_counter() - t0
    t, e = _energy(res, scene)
    tot = e["total"]
    half = int(np.searchsorted(t, t[-1] / 2))
    fl = np.asarray(res.frames["kind"][0]) == rj.Kind.FLUID
    z = np.asarray(res.frames["x"])[:, fl, 2]
    return {"case": "resolution", "diffusion": diffusion, "a_over_dx": a_over_dx, "n_fluid": scene.config.n_fluid, "dt": scene.config.dt,
            "steps": res.stats["steps"], "t_end": float(t[-1]), "wall_s": wall, "lost": float(tot[0] - tot.min()),
            "t_min": float(t[np.argmin(tot)]), "rebound": float(np.max(tot - np.minimum.accumulate(tot))),
            "late": float(tot[-1] - tot[half]), "t_half": float(t[half]), "kinetic_end": float(e["kinetic"][-1]),
            "lowest_particle_z_over_dx": [float(z[half].min() / (A / a_over_dx)), float(z[-1].min() / (A / a_over_dx))]}


def _odd_surface_series(g_dx, rho_i, rho_j, params, gamma):
    from rockjax.sph import diffusion

    h = diffusion.hydrostatic_density_difference
    return 0.5 * (h(g_dx, params, gamma) - h(-g_dx, params, gamma))


def variants(t_end: float) -> list[dict]:
    """``fourtakas`` taken apart (module docstring): one ``resolution``-like run per variant."""
    from rockjax.sph import diffusion as sph_diffusion
    from rockjax.sph import wcsph
    from rockjax.types import Kind

    # the diffusion terms (rockjax.sph.diffusion) call hydrostatic_pair_difference as a module global there
    saved = (wcsph._diffusion_pairs, sph_diffusion.hydrostatic_pair_difference)
    cases = [("fourtakas_surface", "fourtakas_surface", {}),
             ("fourtakas", "fourtakas", {}),
             ("fourtakas, odd surface series", "fourtakas",
              {(sph_diffusion, "hydrostatic_pair_difference"): _odd_surface_series}),
             ("fourtakas + wet wall pairs", "fourtakas",
              {(wcsph, "_diffusion_pairs"): lambda k, r, p, c: (k == Kind.FLUID) | (r > p.fluid.rho0)}),
             ("fourtakas + every wall pair", "fourtakas", {(wcsph, "_diffusion_pairs"): lambda k, r, p, c: k != Kind.PAD})]
    out = []
    for name, diffusion, patch in cases:
        for (module, k), fn in patch.items():
            setattr(module, k, fn)
        jax.clear_caches()
        try:
            r = resolution(4, t_end, diffusion)
        finally:
            wcsph._diffusion_pairs, sph_diffusion.hydrostatic_pair_difference = saved
        out.append({**r, "case": "variants", "variant": name})
    jax.clear_caches()
    return out


def continuation(t_start: float, t_len: float, diffusion: str = "fourtakas_surface") -> list[dict]:
    import rockjax as rj
    from rockjax.sph import diffusion as sph_diffusion

    scene = _scene(4, diffusion)
    first = rj.simulate(scene, t_end=t_start, frame_dt=0.25, progress=False)
    base = dataclasses.replace(scene, state=first.state)
    # FourtakasSurface (rockjax.sph.diffusion) calls hydrostatic_density_difference as a module global there
    full_h = sph_diffusion.hydrostatic_density_difference

    def odd_h(g_dx, params, gamma):
        return 0.5 * (full_h(g_dx, params, gamma) - full_h(-g_dx, params, gamma))

    out = []
    variants = [("all terms", {}, False), ("alpha = 0", {"alpha": 0.0}, False), ("delta = 0", {"delta": 0.0}, False),
                ("alpha = delta = 0", {"alpha": 0.0, "delta": 0.0}, False), ("odd Fourtakas term", {}, True)]
    for name, change, odd in variants:
        f = base.params.fluid
        f = f.replace(**{k: jnp.asarray(v, f.alpha.dtype) for k, v in change.items()})
        sc = dataclasses.replace(base, params=base.params.replace(fluid=f))
        sph_diffusion.hydrostatic_density_difference = odd_h if odd else full_h
        jax.clear_caches()
        try:
            res = rj.simulate(sc, t_end=t_len, frame_dt=0.1, progress=False)
        finally:
            sph_diffusion.hydrostatic_density_difference = full_h
        t, e = _energy(res, scene)
        out.append({"case": "continuation", "variant": name, "diffusion": diffusion, "a_over_dx": 4, "t_start": t_start, "t_len": t_len,
                    "dE": float(e["total"][-1] - e["total"][0]), "dE_potential": float(e["potential"][-1] - e["potential"][0]),
                    "dE_elastic": float(e["elastic"][-1] - e["elastic"][0]), "kinetic_start": float(e["kinetic"][0]),
                    "kinetic_max": float(e["kinetic"].max()), "kinetic_end": float(e["kinetic"][-1])})
    return out


def main():
    import rockjax as rj

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--a-over-dx", type=int, nargs="*", default=[4, 6, 8])
    ap.add_argument("--t-end", type=float, default=16.0)
    ap.add_argument("--t-start", type=float, default=4.0)
    ap.add_argument("--t-len", type=float, default=6.0)
    ap.add_argument("--diffusion", nargs="*", default=["fourtakas"], choices=rj.sph.names("diffusion"),
                    help="density diffusion of the resolution runs (each)")
    ap.add_argument("--continuation-diffusion", default="fourtakas_surface", choices=["fourtakas", "fourtakas_surface"])
    ap.add_argument("--variants", action="store_true", help="only the variants case")
    ap.add_argument("--variants-t-end", type=float, default=36.7)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    stamp = {"date": datetime.date.today().isoformat(), "dtype": "float64", "load": os.getloadavg()[0]}
    if a.variants:
        recs = variants(a.variants_t_end)
    else:
        recs = [resolution(n, a.t_end, d) for d in a.diffusion for n in a.a_over_dx]
        recs += continuation(a.t_start, a.t_len, a.continuation_diffusion) if a.t_len > 0 else []
    for r in recs:
        emit({**r, **stamp}, a.out)


if __name__ == "__main__":
    main()
