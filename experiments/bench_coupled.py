"""Coupled step cost of the sliding-wedge scene, split into SPH, blocks and coupling shares.

For each resolution the same scene is timed three ways, with the same state: the full coupled
step; the fluid alone (blocks and coupling removed from the Config, so they are not traced);
the blocks alone (no particles); and the blocks alone with the joint patch built from all
contact slots instead of the gathered ``joint_patch_points`` (``ms_per_step_blocks_all_slots``);
with boundary particles also the full step without the guard (``Config.coupling_guard``:
``ms_per_step_guard`` = full - full without it); their loads are summed over the list's
(fluid, block particle) sub-list (``Config.body_pair_capacity`` slots, recorded). coupling = full - fluid - blocks. Each timing is the best of
``--reps`` runs of one jitted chunk of ``rebuild_every`` steps (list rebuild included), the three
variants interleaved round by round.
JSON lines out; compare the shares within one run (the machine is shared and noisy).

    python experiments/bench_coupled.py --dx 0.04 0.03 0.02 --coupling penalty
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import jax


def _timed(cases, reps):
    """Best wall time of each ``(fn, state, params)`` in ``cases``, the cases interleaved round by
    round (so a slow spell of the shared machine hits all of them alike); compile excluded."""
    for fn, state, params in cases:
        jax.block_until_ready(fn(state, params))
    best = [float("inf")] * len(cases)
    for _ in range(reps):
        for i, (fn, state, params) in enumerate(cases):
            t0 = time.perf_counter()
            jax.block_until_ready(fn(state, params))
            best[i] = min(best[i], time.perf_counter() - t0)
    return best


def bench(dx: float, coupling: str, reps: int) -> dict:
    import rockjax as rj
    from rockjax.rollout import make_rollout
    from rockjax.types import Config, Coupling, State

    scene = rj.scenes.sliding_wedge(dx=dx, coupling=Coupling(coupling))
    c, p = scene.config, scene.params
    state = rj.prime(scene.state, p, c)
    k = c.rebuild_every

    def chunk(config):
        run = make_rollout(config, 1, checkpoint=False)
        return jax.jit(lambda s, q: run(s, q)[0])

    t0 = time.perf_counter()
    full = chunk(c)
    jax.block_until_ready(full(state, p))
    compile_s = time.perf_counter() - t0
    c_fluid = c.replace(blocks=None, coupling=Coupling.NONE)
    s_fluid = state.replace(blocks=None, coupling=None)
    c_blocks = Config(n_fluid=0, n_wall=0, dt=c.dt, grid=None, cutoff=0.0, skin=0.0, rebuild_every=k, blocks=c.blocks)
    s_blocks = State(step=state.step, particles=None, nbrs=None, status=state.status, blocks=state.blocks)
    # the blocks alone once more with the joint patch built from all contact slots (no gathering
    # of the active points into ``joint_patch_points``: the cost before 2026-11-25's change)
    b = c.blocks  # BlockConfig.grown (BlockCapacities) where this commit has it, else its own field
    all_slots = (b.grown(joint_patch_points=b.contact_slots) if hasattr(b, "grown")
                 else dataclasses.replace(b, joint_patch_points=b.contact_slots))
    c_all = c_blocks.replace(blocks=all_slots)
    p_blocks = p.replace(fluid=None, coupling=None)
    cases = [(full, state, p), (chunk(c_fluid), s_fluid, p.replace(blocks=None, coupling=None)),
             (chunk(c_blocks), s_blocks, p_blocks), (chunk(c_all), s_blocks, p_blocks)]
    guard = c.coupling == Coupling.BOUNDARY_PARTICLES and c.coupling_guard
    if guard:  # the full step once more without the guard (the penalty within dx/4 of the faces)
        cases.append((chunk(c.replace(coupling_guard=False)), state, p))
    times = _timed(cases, reps)
    t_full, t_fluid, t_blocks, t_all = times[:4]
    per = lambda t: 1e3 * t / k  # ms per step
    t_coup = max(t_full - t_fluid - t_blocks, 0.0)
    extra = {"coupling_guard": guard}
    if c.coupling == Coupling.BOUNDARY_PARTICLES:  # the (fluid, block particle) sub-list the loads are summed over
        extra.update(body_pair_capacity=c.body_pair_capacity, wall_pair_capacity=c.wall_pair_capacity)
    if guard:
        extra.update(ms_per_step_full_without_guard=per(times[4]), ms_per_step_guard=per(t_full - times[4]))
    return {"bench": "coupled_step", "dx": dx, "coupling": coupling, "n_fluid": c.n_fluid, "n_wall": c.n_wall,
            "n_blocks": c.blocks.n_blocks, "joint_water": c.blocks.joint_water, "ms_per_step_full": per(t_full), "ms_per_step_fluid": per(t_fluid),
            "ms_per_step_blocks": per(t_blocks), "ms_per_step_coupling": per(t_coup),
            "joint_patch_points": c.blocks.joint_patch_points, "ms_per_step_blocks_all_slots": per(t_all),
            "share_blocks_plus_coupling": (t_blocks + t_coup) / t_full,
            "fluid_particle_steps_per_s": c.n_fluid * k / t_full, "compile_plus_first_s": compile_s,
            **extra, "backend": jax.default_backend(), "load": os.getloadavg()[0]}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--dx", type=float, nargs="+", default=[0.04, 0.025, 0.02])
    ap.add_argument("--coupling", default="penalty", choices=["penalty", "boundary_particles", "boundary_integral"])
    ap.add_argument("--reps", type=int, default=15)
    a = ap.parse_args()
    for dx in a.dx:
        print(json.dumps(bench(dx, a.coupling, a.reps)), flush=True)


if __name__ == "__main__":
    main()
