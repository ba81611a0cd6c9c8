"""A progressive linear wave in a periodic box: the bulk damping per wavelength, without a paddle.

One wavelength of water (``depth`` 0.3 m, kh ~ 1, periodic in x and y, a wall bed) starts as a
linear (Airy) progressive wave of amplitude ``a``: every particle displaced by the linear particle
orbit ``xi = -a cosh(kz)/sinh(kd) sin(kx)``, ``zeta = a sinh(kz)/sinh(kd) cos(kx)`` and given the
orbit velocity (``z`` the height of its rest position above the bed), its density from the pressure
of linear theory at its displaced position. The first Fourier mode of the surface elevation (64
gauges across the box, ``observables.gauge_elevation``) is fitted as ``A(t) exp(i omega t)``:

* ``decay / period``: ``1 - exp(-mu T)`` from the slope ``-mu`` of ``ln |A|`` (a least-squares line
  over the periods after the first); ``decay / wavelength``: the loss over one wavelength of
  travel, ``1 - exp(-mu L / c_g)`` (what a flume shows along its length: issue 45's target is <= 1 %);
* ``omega / theory``: the phase speed of the mode against ``sqrt(g k tanh(kd))`` (the dispersion
  relation, i.e. the wavelength at a given period);
* Lamb's viscous decay for the effective viscosity (``2 nu k^2``) and the bed's laminar Stokes layer
  (Hunt 1952) are printed for scale, as in ``piston_decay.py``.

Variants (``--variant``): ``base`` (the flume's WCSPH: artificial alpha 0.02, Fourtakas diffusion,
h = 1.5 dx, bed viscosity 1), ``laminar`` (Laminar nu = 1e-6), ``free-slip`` (bed viscosity 0),
``alpha0.005``, ``no-diffusion``; ``--diffusion NAME`` replaces the density diffusion. One JSON line per run to ``results/wave_box.jsonl``.

    python experiments/wave_box.py --dx 0.03 --variant base --periods 8
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import pathlib
import time

import numpy as np
from jsonl_out import emit

HERE = pathlib.Path(__file__).resolve().parent
DEPTH, G = 0.3, 9.81


def build(dx: float, amplitude: float, variant: str, h_factor: float, diffusion: str | None = None):
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.types import Kind

    n_x = int(round(2 * math.pi * DEPTH / dx))  # one wavelength, a whole number of dx: kd ~ 1
    L = n_x * dx
    k = 2 * math.pi / L
    width = 8 * dx if h_factor > 1.3 else 7 * dx  # the narrowest periodic width for the list (as the flumes)
    scene = rj.scenes.hydrostatic_tank(dx=dx, length=L, width=width, depth=DEPTH, periodic_xy=True,
                                       h_factor=h_factor, c0=15.0 * math.sqrt(G * DEPTH))  # the piston flume's c0
    scheme = scene.config.scheme
    fl = scene.params.fluid
    if variant == "laminar":
        scheme = dataclasses.replace(scheme, viscosity=rj.sph.Laminar())
        fl = fl.replace(nu=jnp.asarray(1e-6, fl.nu.dtype))
    elif variant == "free-slip":
        fl = fl.replace(wall_viscosity=jnp.asarray(0.0, fl.alpha.dtype))
    elif variant == "alpha0.005":
        fl = fl.replace(alpha=jnp.asarray(0.005, fl.alpha.dtype))
    elif variant == "no-diffusion":
        scheme = scheme.replace(diffusion=rj.sph.by_name("diffusion", "none"))
    elif variant != "base":
        raise SystemExit(f"unknown variant {variant!r}")
    if diffusion is not None:
        scheme = scheme.replace(diffusion=rj.sph.by_name("diffusion", diffusion))
    scene = scene.replace(config=scene.config.replace(scheme=scheme), params=scene.params.replace(fluid=fl))

    P = scene.state.particles
    x = np.asarray(P.x).copy()
    v = np.asarray(P.v).copy()
    rho = np.asarray(P.rho).copy()
    fluid = np.asarray(P.kind) == Kind.FLUID
    omega = math.sqrt(G * k * math.tanh(k * DEPTH))
    z = x[fluid, 2]  # rest height above the bed (the bed is z = 0)
    ch, sh = np.cosh(k * z) / math.sinh(k * DEPTH), np.sinh(k * z) / math.sinh(k * DEPTH)
    s, c = np.sin(k * x[fluid, 0]), np.cos(k * x[fluid, 0])
    xi, zeta = -amplitude * ch * s, amplitude * sh * c
    v[fluid, 0] = amplitude * omega * ch * c
    v[fluid, 2] = amplitude * omega * sh * s
    zd = z + zeta
    p = float(fl.rho0) * G * (DEPTH - zd) + float(fl.rho0) * G * amplitude * np.cosh(k * z) / math.cosh(k * DEPTH) * c
    dens = scheme.initial_density(p, rho0=float(fl.rho0), c0=float(fl.c0))
    if dens is not None:
        rho[fluid] = dens
    x[fluid, 0] = np.mod(x[fluid, 0] + xi, L)
    x[fluid, 2] = zd
    P = P.replace(x=jnp.asarray(x, P.x.dtype), v=jnp.asarray(v, P.v.dtype), rho=jnp.asarray(rho, P.rho.dtype))
    scene = scene.replace(state=scene.state.replace(particles=P))
    return scene, dict(L=L, k=k, omega=omega, width=width)


def run(dx: float, amplitude: float, variant: str, periods: float, h_factor: float, diffusion: str | None = None) -> dict:
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.observables import gauge_elevation

    scene, w = build(dx, amplitude, variant, h_factor, diffusion)
    L, k, omega = w["L"], w["k"], w["omega"]
    T = 2 * math.pi / omega
    M = 64
    gx = (np.arange(M) + 0.5) * L / M
    pts = jnp.asarray(np.stack([gx, np.full(M, 0.5 * w["width"])], 1))

    def observe(state, params, config):
        return {"eta": gauge_elevation(state, params, config, pts, bottom_z=0.0, still_level=DEPTH)}

    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=periods * T, frame_dt=T / 16, observe=observe, progress=False)
    wall = time.perf_counter() - t0
    t = np.asarray(res.times)
    eta = np.asarray(res.observed["eta"])
    mode = 2.0 / M * (eta @ np.exp(-1j * k * gx))  # eta ~ Re(mode e^{ikx}); a progressive wave: mode ~ a e^{-i omega t}
    amp = np.abs(mode)
    keep = t >= T  # after the first period (the start's acoustic transient)
    mu = -np.polyfit(t[keep], np.log(amp[keep]), 1)[0]
    phase = np.unwrap(np.angle(mode[keep]))
    omega_fit = -np.polyfit(t[keep], phase, 1)[0]
    cg = 0.5 * omega / k * (1 + 2 * k * DEPTH / math.sinh(2 * k * DEPTH))
    fl = scene.params.fluid
    laminar = variant == "laminar"
    nu_eff = float(fl.nu) if laminar else float(fl.alpha) * float(fl.h) * float(fl.c0) / 10.0
    delta = math.sqrt(2 * nu_eff / omega)
    mu_bed = (omega ** 3 * delta / (4 * G * cg * math.sinh(k * DEPTH) ** 2)) * cg if float(fl.wall_viscosity) > 0 else 0.0
    return dict(experiment="wave_box", variant=variant, diffusion=scene.config.scheme.diffusion.name, dx=dx, h_over_dx=float(fl.h) / dx, amplitude=amplitude,
                ka=k * amplitude, a_over_dx=amplitude / dx, kd=k * DEPTH, L=L, periods=periods,
                n_fluid=scene.config.n_fluid, amp_first_period=float(amp[keep][0]) / amplitude,
                amp_last=float(amp[-1]) / amplitude, mu=mu, decay_per_period=1 - math.exp(-mu * T),
                decay_per_wavelength=1 - math.exp(-mu * L / cg), omega_over_theory=omega_fit / omega,
                nu_eff=nu_eff, lamb_per_wavelength=1 - math.exp(-2 * nu_eff * k * k * L / cg),
                bed_per_wavelength=1 - math.exp(-mu_bed * L / cg), wall_s=wall, load=os.getloadavg()[0],
                amp_series=[round(float(a) / amplitude, 4) for a in amp[::4]])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dx", type=float, default=0.03)
    ap.add_argument("--amplitude", type=float, default=0.02, help="a [m] (H = 2a; the piston runs' H/d ~ 0.13)")
    ap.add_argument("--variant", default="base", choices=["base", "laminar", "free-slip", "alpha0.005", "no-diffusion"])
    ap.add_argument("--periods", type=float, default=8.0)
    ap.add_argument("--diffusion", default=None, help="density diffusion by name (sph.by_name): none, molteni, "
                    "fourtakas (the scenes' default), fourtakas_surface, antuono")
    ap.add_argument("--h-factor", type=float, default=1.5)
    ap.add_argument("--out", default=str(HERE / "results" / "wave_box.jsonl"))
    a = ap.parse_args()
    rec = run(a.dx, a.amplitude, a.variant, a.periods, a.h_factor, a.diffusion)
    emit({**rec, "date": time.strftime("%Y-%m-%d")}, a.out, shown={k: v for k, v in rec.items() if k != "amp_series"})


if __name__ == "__main__":
    main()
