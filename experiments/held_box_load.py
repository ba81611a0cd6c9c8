"""The water's vertical load on a box HELD at its Archimedes draft, per coupling: JSON lines.

A direct check of a coupling's buoyancy without the heave of a floating box (issue 5; the floating
test, ``tests/coupling/test_floating.py``, mixes the load's bias with a hardly damped oscillation):
``scenes.floating_box`` with the box started at its equilibrium draft (0.04 m for 500 kg/m^3 and
0.08 m height) and its motion made PRESCRIBED with a zero stroke, so it never moves; the water
around it was removed where the box is, so the still level stays at ``water_depth`` and Archimedes
gives ``rho g x (submerged volume)``. The step's load on the block (``state.coupling.force``) is
averaged over every step from t_end/3 to t_end (the water's acoustic noise is +-50 % step to
step). ``ratio`` = mean load / Archimedes. Also averaged: ``n_within_r0``, the water particles within
the penalty's interaction distance r0 of the box (with boundary particles and BOUNDARY_INTEGRAL the
penalty is a guard at r0 = dx/4, where no water should sit), and with BOUNDARY_INTEGRAL
``wall_term_N``, the wall term's share of the load (the load with the guard's constants zeroed,
evaluated on each step's end state; the rest is the guard's); ``fill_under``, the water particles in the
3 dx thick slab under the bottom face over the particles the lattice puts there (the t = 0 value is 1):
where the water sits decides the load of a held body in still water (momentum balance: the load is
the pressure below the slab times the area minus the slab's weight), so a slab short of water by a
fraction e carries e x 3 dx / draft more load.

    python experiments/held_box_load.py --coupling penalty boundary_particles boundary_integral
    python experiments/held_box_load.py --coupling boundary_integral --box 0.24 0.24 0.08 --tank 0.6 0.6
    python experiments/held_box_load.py --coupling boundary_particles boundary_integral --dx 0.01
    python experiments/held_box_load.py --coupling boundary_integral --guard-scale 4
    python experiments/held_box_load.py --coupling boundary_particles penalty --scheme dfsph
    python experiments/held_box_load.py --coupling boundary_particles --scheme dfsph --wall-pressure akinci

``--guard-scale`` multiplies the penalty's stiffness (its damping by the square root): with boundary
particles and BOUNDARY_INTEGRAL that is the guard within dx/4, which water at rest should not touch.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import time

from jsonl_out import emit


def held_box(coupling: str, *, box, tank, dx: float, h_factor: float, depth: float = 0.16, draft: float = 0.04,
             guard_scale: float = 1.0, scheme: str = "wcsph", wall_pressure: str | None = None):
    """``(scene, config, params)``: ``scenes.floating_box`` with the box at ``draft`` and held there
    (PRESCRIBED motion with a zero stroke); ``guard_scale`` multiplies the penalty's stiffness (and
    its damping by the square root, the same damping ratio). Also used by ``wall_consistency.py``."""
    import jax.numpy as jnp

    import rockjax as rj

    sc = rj.scenes.floating_box(dx=dx, box_size=box, tank_size=tank, water_depth=depth, coupling=rj.Coupling(coupling),
                                initial_draft=draft, h_factor=h_factor)
    held = dataclasses.replace(sc.config.blocks, motion=(rj.blocks.Motion.PRESCRIBED,))
    params = sc.params.replace(blocks=sc.params.blocks.replace(stroke=jnp.zeros_like(sc.params.blocks.stroke)))
    if guard_scale != 1.0:
        cp = params.coupling
        params = params.replace(coupling=cp.replace(penalty_stiffness=guard_scale * cp.penalty_stiffness,
                                                    penalty_damping=guard_scale**0.5 * cp.penalty_damping))
    fluid = rj.sph.from_names(scheme)
    if wall_pressure is not None:
        fluid = dataclasses.replace(fluid, wall_pressure=wall_pressure)
    return sc, sc.config.replace(blocks=held, scheme=fluid), params


def scene_arguments(ap: argparse.ArgumentParser, *, box, tank) -> None:
    """The held box's command-line options (``--box --tank --dx --h-factor --t-end --out``)."""
    ap.add_argument("--box", type=float, nargs=3, default=box)
    ap.add_argument("--tank", type=float, nargs=2, default=tank)
    ap.add_argument("--dx", type=float, default=0.02)
    ap.add_argument("--h-factor", type=float, default=1.3)
    ap.add_argument("--t-end", type=float, default=1.5)
    ap.add_argument("--out", default=None, help="also append the JSON lines to this file")


def held_load(coupling: str, *, box, tank, dx: float, t_end: float, h_factor: float, depth: float = 0.16,
              draft: float = 0.04, guard_scale: float = 1.0, scheme: str = "wcsph", wall_pressure: str | None = None) -> dict:
    import jax
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.coupling import penalty
    from rockjax.rollout import scheduled_step

    sc, config, params = held_box(coupling, box=box, tank=tank, dx=dx, h_factor=h_factor, depth=depth, draft=draft,
                                  guard_scale=guard_scale, scheme=scheme, wall_pressure=wall_pressure)
    archimedes = sc.params.fluid.rho0 * 9.81 * box[0] * box[1] * draft
    one = scheduled_step(config, period=32)
    n = int(round(t_end / config.dt))
    n0 = n // 3

    cp = params.coupling
    r0 = cp.interaction_distance
    wall_only = params.replace(coupling=cp.replace(penalty_stiffness=0.0 * cp.penalty_stiffness,
                                                   penalty_damping=0.0 * cp.penalty_damping))
    nf = config.n_fluid
    bi = config.coupling == rj.Coupling.BOUNDARY_INTEGRAL

    def measures(s):
        x = s.particles.x[:nf]
        rel = x - s.blocks.x[0]
        sd = jnp.max(jnp.abs(rel) - 0.5 * jnp.asarray(box, x.dtype), axis=1)  # the held box is axis-aligned
        n_in = jnp.sum((sd < r0) & (s.particles.kind[:nf] == rj.Kind.FLUID))
        wall = penalty.load(s.particles, s.blocks, wall_only, config).force[0, 2] if bi else 0.0
        under = (jnp.all(jnp.abs(rel[:, :2]) < 0.5 * jnp.asarray(box[:2], x.dtype), axis=1)
                 & (rel[:, 2] < -0.5 * box[2]) & (rel[:, 2] > -0.5 * box[2] - 3 * dx))
        return jnp.stack([s.coupling.force[0, 2], n_in.astype(x.dtype), jnp.asarray(wall, x.dtype),
                          jnp.sum(under).astype(x.dtype)])

    def body(carry, k):
        s, total = carry
        s = one(s, params)
        return (s, total + jnp.where(k >= n0, measures(s), 0.0)), None

    t0 = time.perf_counter()
    s0 = rj.prime(sc.state, params, config)
    load0 = float(s0.coupling.force[0, 2])
    (s, total), _ = jax.jit(lambda s: jax.lax.scan(body, (s, jnp.zeros((4,), s.particles.x.dtype)), jnp.arange(n)))(s0)
    bits = int(s.status)
    if bits:
        raise RuntimeError(f"held box ({coupling}): status {rj.Status.describe(bits)}")
    mean, n_within, wall_term, n_under = (float(v) / (n - n0) for v in total)
    nominal = box[0] * box[1] * 3 * dx / dx**3  # water particles a 3 dx slab under the bottom face holds on the lattice
    return {"bench": "held_box_load", "coupling": coupling, "scheme": scheme,
            **({"wall_pressure": config.scheme.wall_pressure} if scheme == "dfsph" else {}), "dx": dx, "h_factor": h_factor, "box": list(box),
            "tank": list(tank), "guard_scale": guard_scale, "draft": draft, "n_fluid": config.n_fluid, "steps": n,
            "t_end": n * config.dt,
            "archimedes_N": float(archimedes), "load_t0_N": load0, "load_mean_N": mean, "ratio": mean / float(archimedes),
            "ratio_t0": load0 / float(archimedes), "n_within_r0": round(n_within, 2), "r0_dx": float(r0) / dx,
            "wall_term_N": wall_term if bi else None, "fill_under": n_under / nominal, "wall_s": round(time.perf_counter() - t0, 1),
            "date": datetime.date.today().isoformat(), "load": round(os.getloadavg()[0], 2)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--coupling", nargs="+", default=["penalty", "boundary_particles", "boundary_integral"])
    scene_arguments(ap, box=[0.12, 0.12, 0.08], tank=[0.36, 0.36])
    ap.add_argument("--guard-scale", type=float, default=1.0,
                    help="multiply the penalty's stiffness by this (its damping by the square root)")
    ap.add_argument("--scheme", default="wcsph", help="the fluid scheme (wcsph, dfsph; the scene's dt either way)")
    ap.add_argument("--wall-pressure", default=None, choices=["extrapolated", "akinci"],
                    help="DFSPH's wall pressure (DFSPH.wall_pressure; default the scheme's)")
    a = ap.parse_args(argv)
    for c in a.coupling:
        emit(held_load(c, box=tuple(a.box), tank=tuple(a.tank), dx=a.dx, t_end=a.t_end, h_factor=a.h_factor,
                       guard_scale=a.guard_scale, scheme=a.scheme, wall_pressure=a.wall_pressure), a.out)


if __name__ == "__main__":
    main()
