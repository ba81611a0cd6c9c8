"""Long-run soak (issue 48, stress suite): the coupled sliding wedge and a wave flume, each run for
1e5 steps in float32; per frame the fluid mass, the particles that left through a wall, the energy
budget, max |v| and finiteness. The records go to ``results/soak.jsonl`` (one JSON line per scene);
``tests/stress/test_soak.py`` runs the same soaks through ``soak()`` and asserts on them.

Scenes (coarse, so that 1e5 steps take minutes on 2 cores):

* ``wedge``: ``scenes.sliding_wedge`` (the README demo: a 2500 kg/m^3 wedge sliding down a 25 deg
  plane into 0.4 m of water, penalty coupling, joint water) at ``WEDGE_DX``;
* ``flume``: ``scenes.wave_flume`` with a regular wave (T = 1 s in 0.3 m of water: kh = 1.37,
  wavelength 1.37 m; target height 0.05 m, stroke 0.038 m) made for the whole run, a flat of 1.8 m
  whose last 1.0 m are a sponge (``sph.Sponge``, strength 2 omega), then a 1:2 beach; a periodic
  2D slab 8 dx wide, boundary-particle paddle, WCSPH with laminar viscosity (the scene's defaults).

Resolutions: wedge dx 0.08 m (515 water particles, 5 over the depth), flume dx 0.06 m (1360, 5 over
the depth), so that 1e5 steps take ~2.5 and ~7.5 min on the 2 shared cores (measured 1.4 and 4.6
ms/step at load ~5; RESULTS.md has the record's).

Per frame (``observer``; frames every ``STEPS_PER_FRAME`` steps):

* mass: the count of FLUID particles, their mass ``sum rho0 vol`` (``observables.fluid_mass``, the
  plain float32 sum) and the same masses summed after sorting (independent of the particles' order,
  which the driver changes at each neighbour-list build);
* outside: the FLUID particles more than dx/2 outside the walls: the container's half-spaces (the
  ones the scene builder filled the water and laid the wall particles with; the first wall layer lies
  dx/2 behind each face, so such a particle is at or behind the wall's first layer) and, in the
  flume, behind the paddle's moving face; ``in_block``: FLUID particles more than dx/2 inside a
  moving block (the wedge, the paddle); ``min_clearance``: the smallest distance inside the walls;
* energy [J]: fluid kinetic + potential (z = 0) + elastic (``observables.energies``), plus the
  wedge's kinetic + potential (``observables.block_energies``, DYNAMIC blocks); in the flume the
  paddle's power into the water, ``-(F . v + T . omega)`` with ``F``, ``T`` the fluid's load on the
  paddle (``State.coupling``), integrated over the frames (trapezoid) to the paddle work ``W(t)``;
* ``vmax``: max |v| of the fluid; ``finite``: every particle and block value finite.

Energy bounded, the definitions used:

* wedge (nothing adds energy; friction, viscosity and the contacts' dampers remove it):
  ``growth = max_t (E(t) - E(0)) / E_ref`` with ``E_ref = m_wedge g (z_wedge(0) + water_depth)``,
  the wedge's potential energy above the floor (all the energy the slide can release). Not counted
  in E: the contact and coupling penalty springs' stored energy, the joint water's work. Bounded:
  ``growth <= GROWTH_TOL``;
* flume (the paddle adds work): ``excess = max_t (E(t) - E(0) - W(t)) / E_ref`` with ``E_ref =
  max_t |W(t)|``, the paddle work (the energy the run received). Bounded: ``excess <=
  GROWTH_TOL``. ``max(E) / E(0)`` is printed too but says little here (E is mostly the water's
  potential energy).

Also recorded: ``rebound``, max_t (B(t) - min_{s<=t} B(s)) / E_ref with B = E (wedge) or E - W
(flume): energy regained after it was lost; ``lost``, (B(0) - B(end)) / E_ref; ``late_drift``: wedge
(at rest by then), |E(end) - E(mid)| / E_ref; flume (the paddle's input balanced by the sponge),
|<E>_end - <E>_mid| / E_ref, the means of E over the 10 wave periods before the end and after the
middle of the run (whole periods: the paddle's phase averages out).

    .venv/bin/python experiments/soak.py                  # both scenes, 1e5 steps each, ~10 min
    .venv/bin/python experiments/soak.py --scenes wedge --steps 2000 --no-out   # a timing probe
"""

from __future__ import annotations

import argparse
import math
import os
import pathlib
import platform
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
STEPS = 100_000
STEPS_PER_FRAME = 80
GROWTH_TOL = 1e-2
WEDGE_DX = 0.08
WEDGE = dict(slope_angle_deg=25.0, far_slope_deg=30.0, water_depth=0.4, flat_length=1.0, flume_width=0.4,
             block_length=0.4, block_width=0.2, start_distance=0.1)
FLUME_DX = 0.06
FLUME_DEPTH, FLUME_PERIOD, FLUME_HEIGHT = 0.3, 1.0, 0.05
FLUME_FLAT, FLUME_SPONGE, FLUME_BEACH = 1.8, 1.0, 0.5


def _cache():
    import jax

    cache = os.environ.get("ROCKJAX_JAX_CACHE", str(HERE.parent / ".jax_cache"))
    jax.config.update("jax_compilation_cache_dir", cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


# ----------------------------------------------------------------------------------------------
# scenes and their walls: half-spaces (n, d), inside where n . x <= d
# ----------------------------------------------------------------------------------------------


def wedge_scene(dx: float = WEDGE_DX):
    import rockjax as rj

    return rj.scenes.sliding_wedge(dx=dx, **WEDGE)


def wedge_walls(dx: float) -> list:
    """``scenes.sliding_wedge``'s container (the builder's own half-spaces, rebuilt from ``WEDGE``)."""
    from rockjax.scenes.shapes import plane

    w = WEDGE
    th, be = math.radians(w["slope_angle_deg"]), math.radians(w["far_slope_deg"])
    d, W = w["water_depth"], w["flume_width"]
    H = w["block_length"] * math.tan(th)
    x_beach = d / math.tan(th) + w["flat_length"]
    z_top = max(H + w["start_distance"] * math.sin(th) + 0.1, 0.5 * d)
    x_left = -(z_top / math.tan(th)) - 2 * dx
    x_right = x_beach + (z_top + d) / math.tan(be) + 2 * dx
    n_slope = np.array([math.sin(th), 0.0, math.cos(th)])
    n_beach = np.array([-math.sin(be), 0.0, math.cos(be)])
    return [plane(-n_slope, [0.0, 0.0, 0.0]), plane(-n_beach, [x_beach, 0.0, -d]), plane([0, 0, -1], [0, 0, -d]),
            plane([0, -1, 0], [0, 0, 0]), plane([0, 1, 0], [0, W, 0]), plane([1, 0, 0], [x_right, 0, 0]),
            plane([-1, 0, 0], [x_left, 0, 0])]


def flume_scene(dx: float = FLUME_DX, *, t_end: float):
    """The regular-wave flume, its paddle running (full stroke after a 2-period ramp) past ``t_end``."""
    import rockjax as rj

    omega = 2 * math.pi / FLUME_PERIOD
    return rj.scenes.wave_flume(dx=dx, water_depth=FLUME_DEPTH, wave="regular", period=FLUME_PERIOD,
                                wave_height=FLUME_HEIGHT, duration=t_end + 4 * FLUME_PERIOD, flat_length=FLUME_FLAT,
                                beach_slope=FLUME_BEACH, sponge_length=FLUME_SPONGE, sponge_strength=2 * omega)


def flume_walls(dx: float) -> list:
    """``scenes.piston_wavemaker``'s bed, beach and end wall (the back wall lies behind the paddle,
    whose moving face ``observer`` checks instead)."""
    from rockjax.scenes.shapes import plane

    beach_length = 1.5 * FLUME_DEPTH / FLUME_BEACH
    n_beach = np.array([-FLUME_BEACH, 0.0, 1.0])
    return [plane([0, 0, -1], [0, 0, 0]), plane(-n_beach, [FLUME_FLAT, 0, 0]),
            plane([1, 0, 0], [FLUME_FLAT + beach_length, 0, 0])]


def check_walls(scene, walls) -> dict:
    """The rebuilt walls against the scene's start: every FLUID particle inside with clearance >
    0.3 dx (``shapes.fill``'s margin), every fixed WALL particle outside (clearance < 0), so a
    wrong reconstruction fails here instead of counting nothing."""
    from rockjax.scenes.shapes import clearance
    from rockjax.types import Kind

    P = scene.state.particles
    dx = float(scene.meta["dx"])
    x, kind = np.asarray(P.x, float), np.asarray(P.kind)
    body = np.full(len(x), -1) if P.body is None else np.asarray(P.body)  # block particles: body >= 0
    c = clearance(x, walls)
    fluid, wall = kind == Kind.FLUID, (kind == Kind.WALL) & (body < 0)
    return dict(fluid_min=float(c[fluid].min() / dx), wall_max=float(c[wall].max() / dx),
                ok=bool(c[fluid].min() > 0.3 * dx * (1 - 1e-4) and c[wall].max() < 0))


# ----------------------------------------------------------------------------------------------
# the observer
# ----------------------------------------------------------------------------------------------


def observer(scene, walls, *, paddle: int | None = None, paddle_half: float = 0.0, clock: list | None = None):
    """``observe(state, params, config) -> dict`` (module docstring). ``paddle``: the index of the
    PRESCRIBED piston block, whose face (centroid x + ``paddle_half``) is a wall and whose power
    into the water is recorded. ``clock``: a list that gets ``(wall, cpu)`` seconds
    (``time.perf_counter``, ``time.process_time``) appended at each frame (a host callback), for
    the rate after the first chunk's compile."""
    import jax
    import jax.numpy as jnp

    from rockjax.blocks import Motion, quat_matrix
    from rockjax.observables import block_energies, energies, fluid_mass
    from rockjax.types import Kind

    dx = float(scene.meta["dx"])
    N = jnp.asarray(np.stack([n for n, _ in walls]), jnp.float32)
    D = jnp.asarray([d for _, d in walls], jnp.float32)
    moving = [b for b, m in enumerate(scene.config.blocks.motion) if m != Motion.FIXED]

    def observe(state, params, config):
        P = state.particles
        B = state.blocks
        fluid = P.kind == Kind.FLUID
        x = P.x
        clear = jnp.min(D.astype(x.dtype)[None, :] - x @ N.astype(x.dtype).T, axis=1)
        if paddle is not None:
            clear = jnp.minimum(clear, x[:, 0] - (B.x[paddle, 0] + paddle_half))
        m = jnp.where(fluid, params.fluid.rho0 * P.vol, 0.0)
        out = dict(n_fluid=jnp.sum(fluid.astype(jnp.int32)), mass=fluid_mass(state, params),
                   mass_sorted=jnp.sum(jnp.sort(m)),
                   outside=jnp.sum((fluid & (clear < -0.5 * dx)).astype(jnp.int32)),
                   min_clearance=jnp.min(jnp.where(fluid, clear, jnp.inf)))
        R = quat_matrix(B.q)
        sh = B.shape
        inside = jnp.zeros(x.shape[0], bool)
        for b in moving:  # depth inside block b: min over its faces of d - n . p, p in the body frame
            p = (x - B.x[b]) @ R[b]
            depth = jnp.min(jnp.where(sh.face_mask[b][None, :], sh.face_offset[b][None, :] - p @ sh.face_normal[b].T,
                                      jnp.inf), axis=1)
            inside |= depth > 0.5 * dx
        out["in_block"] = jnp.sum((fluid & inside).astype(jnp.int32))
        e = energies(state, params, config)
        be = block_energies(state, params, config)
        out.update(fluid_kinetic=e["kinetic"], fluid_potential=e["potential"], fluid_elastic=e["elastic"],
                   block_kinetic=be["kinetic"], block_potential=be["potential"])
        out["vmax"] = jnp.sqrt(jnp.max(jnp.where(fluid, jnp.sum(P.v * P.v, -1), 0.0)))
        out["block_vmax"] = jnp.sqrt(jnp.max(jnp.sum(B.v * B.v, -1)))
        if paddle is not None:
            F, T = state.coupling.force[paddle], state.coupling.torque[paddle]
            out["paddle_power"] = -(F @ B.v[paddle] + T @ B.omega[paddle])
        fin = [jnp.all(jnp.isfinite(a)) for a in (P.x, P.v, P.rho, B.x, B.v, B.q, B.omega)]
        out["finite"] = jnp.all(jnp.stack(fin))
        if clock is not None:
            jax.debug.callback(lambda step: clock.append((time.perf_counter(), time.process_time())), state.step)
        return out

    return observe


# ----------------------------------------------------------------------------------------------
# a soak
# ----------------------------------------------------------------------------------------------


def soak(name: str, *, steps: int = STEPS, steps_per_frame: int = STEPS_PER_FRAME, dx: float | None = None) -> dict:
    """Run scene ``name`` ("wedge" or "flume") for ``steps`` steps (a whole number of frames) and
    return ``(record, series)``: the JSON record (module docstring) and the per-frame series
    (``times`` and the observer's arrays, numpy)."""
    import jax

    import rockjax as rj

    if steps % steps_per_frame:
        raise ValueError(f"steps ({steps}) must be a multiple of steps_per_frame ({steps_per_frame})")
    clock: list = []
    if name == "wedge":
        dx = WEDGE_DX if dx is None else dx
        scene = wedge_scene(dx)
        walls = wedge_walls(dx)
        obs = observer(scene, walls, clock=clock)
    elif name == "flume":
        dx = FLUME_DX if dx is None else dx
        probe = flume_scene(dx, t_end=1.0)  # dt does not depend on the paddle's path
        scene = flume_scene(dx, t_end=steps * probe.config.dt)
        walls = flume_walls(dx)
        half = 0.5 * max(4 * dx, 0.1)  # piston_wavemaker's paddle thickness
        obs = observer(scene, walls, paddle=0, paddle_half=half, clock=clock)
        from rockjax.scenes.shapes import plane

        walls = walls + [plane([-1, 0, 0], [float(scene.state.blocks.x[0, 0]) + half, 0, 0])]  # its face at the start
    else:
        raise ValueError(f"soak: unknown scene {name!r} (wedge or flume)")
    walls_check = check_walls(scene, walls)
    if not walls_check["ok"]:
        raise RuntimeError(f"soak {name}: the rebuilt walls do not fit the scene's start ({walls_check})")
    dt = float(scene.config.dt)
    n_frames = steps // steps_per_frame
    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=n_frames * steps_per_frame * dt, frame_dt=steps_per_frame * dt, observe=obs,
                      keep_frames=False, progress=False)
    wall = time.perf_counter() - t0
    s = {k: np.asarray(v) for k, v in res.observed.items()}
    s["times"] = np.asarray(res.times)
    E = (s["fluid_kinetic"] + s["fluid_potential"] + s["fluid_elastic"] + s["block_kinetic"] + s["block_potential"]
         ).astype(float)
    s["energy"] = E
    setup = dict(WEDGE) if name == "wedge" else dict(
        depth=FLUME_DEPTH, flat_length=FLUME_FLAT, sponge_length=FLUME_SPONGE, beach_slope=FLUME_BEACH,
        **{k: v for k, v in scene.meta["signal"].items() if k != "generator"},
        sponge_strength=scene.meta["sponge"]["strength"])
    rec = dict(scene=name, setup=setup, dx=dx, steps=int(res.stats["steps"]), frames=len(s["times"]), steps_per_frame=steps_per_frame,
               dt=dt, sim_s=float(s["times"][-1]), wall_s=wall, n_fluid=int(res.stats["n_fluid"]),
               n_particles=int(scene.config.n_fluid + scene.config.n_wall), regrows=int(res.stats["regrows"]),
               walls=walls_check)
    # rates from the second frame on (the first chunk includes the compile); CPU: this process's
    # CPU seconds (all its threads) over the same frames
    (w1, c1), (w2, c2) = clock[1], clock[-1]
    run_steps = rec["steps"] - steps_per_frame
    rec["ms_per_step"] = 1e3 * (w2 - w1) / run_steps
    rec["cpu_ms_per_step"] = 1e3 * (c2 - c1) / run_steps
    rec["first_chunk_s"] = clock[1][0] - clock[0][0]
    rec["sim_s_per_wall_s"] = dt / (1e-3 * rec["ms_per_step"])
    rec["particle_steps_per_s"] = rec["n_fluid"] / (1e-3 * rec["ms_per_step"])
    m0 = s["mass"][0]
    rec.update(mass0=float(m0), mass_end=float(s["mass"][-1]),
               mass_drift=float(np.max(np.abs(s["mass"].astype(float) - float(m0))) / float(m0)),
               mass_bit_identical=bool(np.all(s["mass"] == m0)),
               mass_sorted_bit_identical=bool(np.all(s["mass_sorted"] == s["mass_sorted"][0])),
               n_fluid_constant=bool(np.all(s["n_fluid"] == s["n_fluid"][0])),
               outside_max=int(s["outside"].max()), in_block_max=int(s["in_block"].max()),
               min_clearance_over_dx=float(s["min_clearance"].min() / dx),
               nan_seen=not bool(np.all(s["finite"])), vmax=float(s["vmax"].max()),
               block_vmax=float(s["block_vmax"].max()))
    half = len(E) // 2
    if name == "wedge":
        from rockjax.blocks import block_mass

        m_w = float(block_mass(scene.state.blocks, scene.params.blocks)[0])
        z_w = float(scene.state.blocks.x[0, 2])
        e_ref = m_w * 9.81 * (z_w + WEDGE["water_depth"])
        budget = E
        rec.update(e_ref_def="m_wedge g (z_wedge(0) + water_depth)", wedge_mass=m_w)
        late = abs(E[-1] - E[half]) / e_ref
    else:
        P = s["paddle_power"].astype(float)
        t = s["times"]
        W = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
        s["paddle_work"] = W
        e_ref = float(np.max(np.abs(W)))
        budget = E - W
        rec.update(e_ref_def="max_t |W(t)|, the paddle work", paddle_work_end=float(W[-1]),
                   max_E_over_E0=float(np.max(E) / E[0]))
        n = max(1, round(10 * FLUME_PERIOD / (steps_per_frame * dt)))  # frames in 10 wave periods
        late = abs(np.mean(E[-n:]) - np.mean(E[half:half + n])) / e_ref
    rec.update(E0=float(E[0]), E_max=float(E.max()), E_end=float(E[-1]), E_ref=e_ref,
               growth=float(np.max(budget - budget[0]) / e_ref),
               rebound=float(np.max(budget - np.minimum.accumulate(budget)) / e_ref),
               late_drift=float(late),
               lost=float((budget[0] - budget[-1]) / e_ref), growth_tol=GROWTH_TOL,
               energy_bounded=bool(np.max(budget - budget[0]) <= GROWTH_TOL * e_ref))
    rec.update(float32=not bool(jax.config.jax_enable_x64), jax=jax.__version__,
               machine=f"{platform.machine()}, {os.cpu_count()} CPUs", load_avg_1m=round(os.getloadavg()[0], 2))
    return rec, s


def summary(rec: dict) -> str:
    return (f"soak {rec['scene']}: {rec['steps']} steps of {rec['dt']:.4g} s ({rec['sim_s']:.1f} s) in {rec['wall_s']:.0f} s "
            f"({rec['ms_per_step']:.2f} ms/step, CPU {rec['cpu_ms_per_step']:.2f} ms/step, {rec['sim_s_per_wall_s']:.3f} sim s/wall s, "
            f"load {rec['load_avg_1m']}), n_fluid {rec['n_fluid']}; "
            f"mass drift {rec['mass_drift']:.2e} (bit-identical {rec['mass_bit_identical']}); outside max "
            f"{rec['outside_max']}, in block max {rec['in_block_max']}, min clearance {rec['min_clearance_over_dx']:.2f} dx; "
            f"energy growth {rec['growth']:.2e}, rebound {rec['rebound']:.2e}, late drift {rec['late_drift']:.2e}, "
            f"lost {rec['lost']:.3f} E_ref ({rec['E_ref']:.4g} J); NaN {rec['nan_seen']}; vmax {rec['vmax']:.3f} m/s")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["wedge", "flume"], choices=["wedge", "flume"])
    ap.add_argument("--steps", type=int, default=STEPS)
    ap.add_argument("--dx", type=float, default=None, help="override the scene's dx (one scene)")
    ap.add_argument("--out", default=str(HERE / "results" / "soak.jsonl"))
    ap.add_argument("--no-out", action="store_true", help="print only")
    a = ap.parse_args()
    _cache()
    from jsonl_out import emit

    for name in a.scenes:
        rec, _ = soak(name, steps=a.steps, dx=a.dx)
        print(summary(rec), flush=True)
        emit({**rec, "date": time.strftime("%Y-%m-%d")}, None if a.no_out else a.out)


if __name__ == "__main__":
    main()
