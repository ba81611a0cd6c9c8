"""Where water ends up inside the sliding wedge with boundary-particle coupling (tests/coupling/test_wedge_run.py).

Runs ``scenes.sliding_wedge(dx=0.04, coupling=BOUNDARY_PARTICLES)`` to 2 s with frames every
0.025 s and, at each frame, finds the fluid particles inside the wedge's geometric polyhedron
(signed distance to its faces, ``tests/coupling/test_coupling._inside_distance``'s measure). For
the deepest one it records the depth [dx], how many are inside, its position in the wedge's body
frame (x along the top face from the front face towards the back tip, z up from the bottom-front
edge, as built; the wedge's 25 deg edge is at the back) and the wedge's thickness (top face to
slope face) at that x, in dx -- whether the water sits where the wedge is too thin for its
boundary-particle lattice. Also the count of boundary particles, and of the frames where the
water got past their outer layer (deeper than dx/2, the depth of that layer since 2026-11-25's
face-following sampling). With ``--no-guard`` the penalty guard within dx/4 of the faces
(``Config.coupling_guard``, on by default since 2026-11-25) is switched off, with
``--guard-fixed`` the fixed blocks are guarded too (``Config.guard_fixed``); the record also
gives the closest approach of the water to the faces and the guard's share of the load, and
the same for the fixed slope and floor (``scenes.shapes.shell``'s walls). JSON lines out
(``--out`` appends).

    python experiments/wedge_inside.py --out experiments/results/wedge_inside.jsonl   # ~1-5 min
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

from jsonl_out import emit

HERE = Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dx", type=float, default=0.04)
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--no-guard", action="store_true",
                    help="switch off the penalty guard within dx/4 of the faces (Config.coupling_guard)")
    ap.add_argument("--guard-fixed", action="store_true",
                    help="guard the fixed slope and floor too (Config.guard_fixed, off by default)")
    ap.add_argument("--tag", default="", help="label stored in the record (e.g. the sampling used)")
    ap.add_argument("--out", default=None, help="JSON-lines file the record is appended to")
    a = ap.parse_args()
    import jax.numpy as jnp

    import rockjax as rj
    from rockjax.blocks.rotation import quat_matrix

    sys.path.insert(0, str(HERE.parent / "tests" / "coupling"))
    from test_coupling import _inside_distance

    from rockjax.coupling import penalty

    scene = rj.scenes.sliding_wedge(dx=a.dx, coupling=rj.Coupling.BOUNDARY_PARTICLES)
    scene = scene.replace(config=scene.config.replace(coupling_guard=not a.no_guard, guard_fixed=a.guard_fixed))
    P0 = scene.state.particles
    n_bp = int(np.sum(np.asarray(P0.body) == 0))

    from rockjax.blocks import contact_forces

    def observe(s, p, c):  # the load on the wedge, the part the guard's penalty would give (on or off), joint water
        _, _, _, _, info = contact_forces(s.blocks, p.blocks, c.blocks, dt=c.dt, gravity=p.gravity, return_info=True)
        return dict(load=s.coupling.force[0], guard=penalty.load(s.particles, s.blocks, p, c).force[0],
                    joint=-jnp.sum(info["joint_water_force"], 0))  # pairs (wedge, fixed block): i < j

    t0 = time.perf_counter()
    res = rj.simulate(scene, t_end=a.t_end, frame_dt=0.025, observe=observe, progress=False)
    wall = time.perf_counter() - t0
    fluid = np.asarray(res.frames["kind"][0]) == rj.Kind.FLUID
    B0 = scene.state.blocks
    H = float(scene.meta["block_height"])
    L = H / np.tan(np.radians(float(scene.meta["slope_angle_deg"])))
    # the wedge's body-frame geometry: its vertices relative to the centroid at t = 0
    R0 = np.asarray(quat_matrix(B0.q[:1]))[0]
    frames = []
    closest = np.inf
    fixed = {b: (np.inf, 0) for b, m in enumerate(scene.config.blocks.motion) if m.name == "FIXED"}
    for k in range(len(res.times)):
        Bk = B0.replace(x=jnp.asarray(res.frames["block_x"][k]), q=jnp.asarray(res.frames["block_q"][k]))
        xf = np.asarray(res.frames["x"][k])[fluid]
        d = np.asarray(_inside_distance(xf, Bk, 0))
        closest = min(closest, float(d.min()))
        for b in fixed:  # the fixed slope and floor (met by the water as wall particles)
            db = np.asarray(_inside_distance(xf, Bk, b))
            fixed[b] = (min(fixed[b][0], float(db.min())), max(fixed[b][1], int((db < 0).sum())))
        if d.min() >= 0:
            continue
        i = int(np.argmin(d))
        R = np.asarray(quat_matrix(Bk.q[:1]))[0]
        body = R0 @ (R.T @ (xf[i] - np.asarray(res.frames["block_x"][k][0])))  # as built, relative to centroid
        frames.append(dict(t=round(float(res.times[k]), 4), depth_dx=round(float(-d[i] / a.dx), 3),
                           n_inside=int((d < 0).sum()), body_xyz=np.round(body, 4).tolist(),
                           # top face minus slope face at that x (body x from the centroid, L/3 behind the front)
                           wedge_thickness_dx=round(float(H * (2.0 / 3.0 + body[0] / L) / a.dx), 2),
                           world_xyz=np.round(xf[i], 4).tolist()))
    guard = np.linalg.norm(np.asarray(res.observed["guard"]), axis=1)
    late = res.times >= res.times[-1] - 0.3
    rec = dict(dx=a.dx, t_end=float(res.times[-1]), wall_s=wall, n_fluid=scene.config.n_fluid, n_boundary=n_bp,
               guard=not a.no_guard, guard_fixed=a.guard_fixed,
               # signed distance of the closest water particle to the wedge's faces over all frames [dx]
               closest_approach_dx=round(closest / a.dx, 3),
               # per fixed block (1: the slope, 2: the floor): closest water over the frames [dx], most inside at once
               fixed_closest_dx={str(b): round(v[0] / a.dx, 3) for b, v in fixed.items()},
               fixed_most_inside={str(b): v[1] for b, v in fixed.items()},
               # the guard's load |F| (computed whether it is on or not) against the whole load on the
               # wedge: its largest over the frames, and its mean over the last 0.3 s (the wedge at rest)
               guard_load_max_N=round(float(guard.max()), 3), guard_load_late_N=round(float(guard[late].mean()), 4),
               load_late_N=np.round(np.asarray(res.observed["load"])[late].mean(0), 2).tolist(),
               guard_late_N=np.round(np.asarray(res.observed["guard"])[late].mean(0), 3).tolist(),
               joint_late_N=np.round(np.asarray(res.observed["joint"])[late].mean(0), 2).tolist(),
               # Archimedes rho g V of the (submerged) wedge: what particles + joint water should add up to at rest
               archimedes_N=round(float(1000.0 * 9.81 * B0.shape.volume[0]), 2),
               centroid_end=np.round(np.asarray(res.frames["block_x"][-1, 0]), 4).tolist(),
               block_length=L, block_height=H,
               slope_angle_deg=scene.meta.get("slope_angle_deg"), frames_with_water_inside=len(frames),
               worst_depth_dx=max((f["depth_dx"] for f in frames), default=0.0),
               # behind the particles' outer layer (dx/2 deep): past the wall the fluid sees
               frames_behind_outer_layer=sum(f["depth_dx"] > 0.5 for f in frames), frames=frames,
               tag=a.tag, date=datetime.date.today().isoformat(), load=os.getloadavg()[0])
    emit(rec, a.out, shown={k: v for k, v in rec.items() if k != "frames"})


if __name__ == "__main__":
    main()
