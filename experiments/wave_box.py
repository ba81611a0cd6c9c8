"""A progressive linear wave in a periodic box: the bulk damping per wavelength, without a paddle.

``scenes.wave_box``: one wavelength of water (``depth`` 0.3 m, kd ~ 1, periodic in x and y, a wall
bed) started as a linear (Airy) progressive wave of amplitude ``a`` (particles on their orbits,
densities from the wave's pressure). The first Fourier mode of the surface elevation (64 gauges
across the box, ``validation.wave_mode``) gives, from the second period on:

* ``decay / period``: ``1 - exp(-mu T)`` from the slope ``-mu`` of ``ln |A|``; ``decay /
  wavelength``: the loss over one wavelength of travel, ``1 - exp(-mu L / c_g)`` (what a flume
  shows along its length: issue 45's target is <= 1 %);
* ``omega / theory``: the mode's frequency against ``sqrt(g k tanh kd)`` (the dispersion relation,
  i.e. the wavelength at a given period);
* Lamb's viscous decay for the effective viscosity (``2 nu k^2``) and the bed's laminar Stokes layer
  (Hunt 1952) for scale, as in ``piston_decay.py``.

Variants (``--variant``): ``base`` (the flume's WCSPH: artificial alpha 0.02, Fourtakas diffusion,
h = 1.5 dx, bed viscosity 1), ``laminar`` (Laminar nu = 1e-6), ``free-slip`` (bed viscosity 0),
``alpha0.005``, ``no-diffusion``; ``--diffusion NAME`` / ``--walls NAME`` replace the density
diffusion / the wall model; ``--delta``, ``--cfl``, ``--c0-factor``, ``--h-factor``; ``--scheme dfsph``
(``DFSPH`` with its own kernel and h); ``--settle S`` starts from water relaxed for S seconds. One JSON line per run to ``results/wave_box.jsonl``.

The energy budget: ``energy_lost_over_mode_lost`` is the fluid's total energy lost over the wave
mode's energy lost in the fit window (1: all of the wave's loss is dissipated; less: the rest stays
in the water as motion that is not the wave); ``ke_y_over_wave_energy`` and
``ke_rotational_over_wave_energy`` are that motion at the end (``_noise``).

    python experiments/wave_box.py --dx 0.03 --variant base --periods 8
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import time

import numpy as np
from jsonl_out import emit

HERE = pathlib.Path(__file__).resolve().parent
DEPTH, G = 0.3, 9.81


def build(dx: float, amplitude: float, variant: str, h_factor: float, diffusion: str | None = None,
          cfl: float | None = None, c0_factor: float = 15.0, settle: float = 0.0, delta: float = 0.1,
          walls: str | None = None, scheme: str = "wcsph", options: dict | None = None):
    """``scenes.wave_box`` with the variant's terms and constants (``scheme`` "dfsph": ``DFSPH``
    with the variant's viscosity; it has no density diffusion or wall model to replace;
    ``options``: further fields of the scheme object, ``Scheme.replace(**options)``)."""
    import rockjax as rj

    kw, terms = {}, {}
    if variant == "laminar":
        terms["viscosity"], kw["nu"] = rj.sph.Laminar(), 1e-6
    elif variant == "free-slip":
        kw["wall_viscosity"] = 0.0
    elif variant == "alpha0.005":
        kw["alpha"] = 0.005
    elif variant == "no-diffusion":
        terms["diffusion"] = rj.sph.by_name("diffusion", "none")
    elif variant != "base":
        raise SystemExit(f"unknown variant {variant!r}")
    if diffusion is not None:
        terms["diffusion"] = rj.sph.by_name("diffusion", diffusion)
    if walls is not None:
        terms["walls"] = rj.sph.by_name("walls", walls)
    if scheme.startswith("dfsph"):  # "dfsph" or "dfsph:KERNEL" (sph.by_name), relaxation within the sweeps' bound
        from rockjax.sph.dfsph import jacobi_lambda_max

        kw_d = {k: v for k, v in terms.items() if k == "viscosity"}
        if ":" in scheme:
            kw_d["kernel"] = rj.sph.by_name("kernel", scheme.split(":", 1)[1])
        sch = rj.DFSPH(**kw_d)
        if h_factor is not None:
            sch = sch.replace(relaxation=min(sch.relaxation, round(0.9 * 2.0 / jacobi_lambda_max(sch.kernel, h_factor), 2)))
    else:
        sch = rj.WCSPH(**terms)
    if options:
        options = dict(options)
        if "shifting" in options:  # "fickian" or "fickian:A=1,R=0" (sph.shifting)
            name, _, args = str(options["shifting"]).partition(":")
            kw_s = _options([a for a in args.split(",") if a]) if args else {}
            options["shifting"] = rj.sph.by_name("shifting", name, **kw_s)
        sch = sch.replace(**options)
    return rj.scenes.wave_box(dx=dx, depth=DEPTH, amplitude=amplitude, h_factor=h_factor, scheme=sch,
                              cfl=cfl, c0=c0_factor * math.sqrt(G * DEPTH), settle=settle, delta=delta, **kw)


def run(dx: float, amplitude: float, variant: str, periods: float, h_factor: float, diffusion: str | None = None,
        cfl: float | None = None, c0_factor: float = 15.0, settle: float = 0.0, delta: float = 0.1,
        walls: str | None = None, scheme: str = "wcsph", options: dict | None = None) -> dict:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import energies, fluid_mass, gauge_elevation
    from rockjax.validation import wave_mode

    scene = build(dx, amplitude, variant, h_factor, diffusion, cfl, c0_factor, settle, delta, walls, scheme, options)
    sch = scene.config.scheme
    m = scene.meta
    L, k, omega = m["wavelength"], m["k"], m["omega"]
    T = 2 * math.pi / omega
    gx = np.asarray(m.gauges.xy)[:, 0]
    M = len(gx)
    pts = jnp.asarray(m.gauges.xy)

    def observe(state, params, config):
        e = energies(state, params, config)
        return {"eta": gauge_elevation(state, params, config, pts, bottom_z=0.0, still_level=DEPTH),
                "e_total": e["total"], "e_kinetic": e["kinetic"]}

    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=periods * T, frame_dt=T / 16, observe=observe, progress=False, keep_frames=True)
    wall = time.perf_counter() - t0
    t = np.asarray(res.times)
    fit = wave_mode(t, res.observed["eta"], gx, k=k, t_start=T)  # after the first period (the start's transient)
    amp, mu, omega_fit = fit["amplitude"], fit["mu"], fit["omega"]
    keep = t >= T
    # Energy budget: the linear wave's energy (rho g a^2 / 2 per unit area) against the loss of the
    # fluid's total energy. Over the fit window, the mode's energy falls by d_mode; the total by
    # d_total. d_total / d_mode ~ 1: the wave's energy is dissipated (viscosity, diffusion, walls);
    # ~ 0: it is conserved but leaves the wave (into particle noise and other modes).
    fl = scene.params.fluid
    width = float(fluid_mass(scene.state, scene.params)) / (float(fl.rho0) * L * DEPTH)  # the box's periodic width
    e_wave = 0.5 * float(fl.rho0) * G * amplitude ** 2 * L * width
    e_tot = np.asarray(res.observed["e_total"])
    i0, i1 = int(np.argmax(keep)), len(t) - 1
    d_mode = e_wave * ((amp[i0] / amplitude) ** 2 - (amp[i1] / amplitude) ** 2)
    d_total = float(e_tot[i0] - e_tot[i1])
    cg = 0.5 * omega / k * (1 + 2 * k * DEPTH / math.sinh(2 * k * DEPTH))
    laminar = variant == "laminar"
    nu_eff = float(fl.nu) if laminar else float(fl.alpha) * float(fl.h) * float(fl.c0) / 10.0
    stokes = math.sqrt(2 * nu_eff / omega)  # the bed's Stokes-layer thickness m
    no_slip = float(fl.wall_viscosity) > 0
    mu_bed = omega ** 3 * stokes / (4 * G * cg * math.sinh(k * DEPTH) ** 2) * cg if no_slip else 0.0
    noise = _noise(res.frames, L, float(fl.rho0) * dx ** 3, e_wave)
    return dict(experiment="wave_box", scheme=scheme, options=options or {}, shifting=str(getattr(sch, "shifting", "")), kernel=sch.kernel.name, relaxation=getattr(sch, "relaxation", None), variant=variant, settle=settle, delta=delta,
                walls=sch.walls.name if hasattr(sch, "walls") else sch.wall_pressure,
                diffusion=sch.diffusion.name if hasattr(sch, "diffusion") else "none", dx=dx,
                cfl=scene.config.cfl, c0_over_sqrt_gd=c0_factor, dt=scene.config.dt, h_over_dx=float(fl.h) / dx,
                amplitude=amplitude,
                ka=k * amplitude, a_over_dx=amplitude / dx, kd=k * DEPTH, L=L, periods=periods,
                n_fluid=scene.config.n_fluid, amp_first_period=float(amp[keep][0]) / amplitude,
                amp_last=float(amp[-1]) / amplitude, mu=mu, decay_per_period=1 - math.exp(-mu * T),
                decay_per_wavelength=1 - math.exp(-mu * L / cg), omega_over_theory=omega_fit / omega,
                nu_eff=nu_eff, lamb_per_wavelength=1 - math.exp(-2 * nu_eff * k * k * L / cg),
                bed_per_wavelength=1 - math.exp(-mu_bed * L / cg), wall_s=wall, load=os.getloadavg()[0],
                energy_lost_over_mode_lost=d_total / d_mode if d_mode > 0 else float("nan"),
                energy_lost_over_wave_energy=d_total / e_wave,
                kinetic_over_wave_energy_last=float(np.asarray(res.observed["e_kinetic"])[-1]) / e_wave,
                **noise,
                amp_series=[round(float(a) / amplitude, 4) for a in amp[::4]])


def _noise(frames, L: float, m: float, e_wave: float) -> dict:
    """The last frame's kinetic energy outside the waves, over the wave's start energy: ``ke_y``,
    that of the sideways velocities (none in a 2D wave: they grow from round-off as the lattice
    rearranges), and ``ke_rotational``, that of the x-z velocities left after a least-squares fit
    of the box's potential-flow modes 1-6 (``phi ~ cosh(k_n z) (A cos k_n x + B sin k_n x)``):
    spurious vorticity and particle noise (Colagrossi et al. 2013 find that too few neighbours let
    it grow and over-damp the wave)."""
    from rockjax.types import Kind

    kind = np.asarray(frames["kind"][-1])
    fl = kind == int(Kind.FLUID)
    x, v = np.asarray(frames["x"][-1])[fl], np.asarray(frames["v"][-1])[fl]
    cols = []
    for n in range(1, 7):
        kn = 2 * math.pi * n / L
        c, s = np.cos(kn * x[:, 0]), np.sin(kn * x[:, 0])
        ch, sh = np.cosh(kn * x[:, 2]) / np.cosh(kn * DEPTH), np.sinh(kn * x[:, 2]) / np.cosh(kn * DEPTH)
        cols += [np.concatenate([-ch * s, sh * c]), np.concatenate([ch * c, sh * s])]
    A = np.stack(cols, 1)
    b = np.concatenate([v[:, 0], v[:, 2]])
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    resid = b - A @ coef
    return dict(ke_y_over_wave_energy=0.5 * m * float(np.sum(v[:, 1] ** 2)) / e_wave,
                ke_rotational_over_wave_energy=0.5 * m * float(np.sum(resid ** 2)) / e_wave)


def _options(items: list[str]) -> dict:
    """``FIELD=VALUE`` strings as a dict: true/false, ints, floats, else the string."""
    out = {}
    for item in items:
        key, _, text = item.partition("=")
        low = text.strip().lower()
        if low in ("true", "false"):
            out[key.strip()] = low == "true"
            continue
        for cast in (int, float):
            try:
                out[key.strip()] = cast(text)
                break
            except ValueError:
                pass
        else:
            out[key.strip()] = text
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--amplitude", type=float, default=0.02, help="a [m] (H = 2a; the piston runs' H/d ~ 0.13)")
    ap.add_argument("--variant", default="base", choices=["base", "laminar", "free-slip", "alpha0.005", "no-diffusion"])
    ap.add_argument("--periods", type=float, default=8.0)
    ap.add_argument("--cfl", type=float, default=None, help="WCSPH's acoustic CFL (default the scheme's, 0.25)")
    ap.add_argument("--c0-factor", type=float, default=15.0, help="c0 / sqrt(g d) (the piston flume's 15)")
    ap.add_argument("--diffusion", default=None, help="density diffusion by name (sph.by_name): none, molteni, "
                    "fourtakas (the scenes' default), fourtakas_surface, antuono")
    ap.add_argument("--h-factor", type=float, default=None, help="h / dx (default 1.5 for wcsph, the scheme's own for dfsph)")
    ap.add_argument("--scheme", default="wcsph", help="wcsph, dfsph or dfsph:KERNEL (e.g. dfsph:wendland_c2)")
    ap.add_argument("--walls", default=None, help="the wall model by name (sph.by_name): adami (default), dynamic")
    ap.add_argument("--delta", type=float, default=0.1, help="the density diffusion's delta (Params.fluid.delta)")
    ap.add_argument("--settle", type=float, default=0.0, help="s of still-water relaxation before the wave "
                    "(scenes.settle; 0: the cubic lattice)")
    ap.add_argument("--option", action="append", default=[], metavar="FIELD=VALUE",
                    help="a field of the scheme object (repeatable), e.g. divergence_solve=false, tolerance=1e-5, "
                    "shifting=fickian:A=2,R=0.2 (sph.shifting)")
    ap.add_argument("--out", default=str(HERE / "results" / "wave_box.jsonl"))
    a = ap.parse_args()
    hf = a.h_factor if a.h_factor is not None or a.scheme.startswith("dfsph") else 1.5
    rec = run(a.dx, a.amplitude, a.variant, a.periods, hf, a.diffusion, a.cfl, a.c0_factor, a.settle, a.delta, a.walls,
              a.scheme, _options(a.option))
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown={k: v for k, v in rec.items() if k != "amp_series"})


if __name__ == "__main__":
    main()
