"""Zeroth-order consistency of the BOUNDARY_INTEGRAL wall term under a held box: JSON lines.

The WCSPH pressure sum ``-sum_j m_j (p_i + p_j) / (rho_i rho_j) grad W_ij`` and the wall term's
``(p_i + p_f) / rho_i P_f n_f`` (``coupling.penalty.wall_terms``) cancel for a uniform pressure only
if the particle's discrete kernel-gradient sum ``S_i = sum_j V_j grad W_ij`` equals the analytic
``sum_f P_f n_f`` of the faces its support cuts. Under the bottom face of a box held at its draft
(``held_box_load.py``'s scene, the wide box by default so that the particles under its middle see only
the bottom face) this records, per band of distance s from the face, ``D_z = S_z + A(s)`` [1/m]
(0 when consistent; ``A`` = ``P_f``), its share of ``A``, the mean pressure, and the spurious
acceleration ``-2 p D_z / rho`` [m/s^2] that the mismatch leaves -- on the lattice at t = 0 and over
10 snapshots of the last 200 steps before ``--t-end``. ``V_j = rho0 vol_j / rho_j``; fluid and wall
particles count; targets are fluid particles under the box farther than 2h from its sides.

    python experiments/wall_consistency.py --out experiments/results/wall_consistency.jsonl
"""

from __future__ import annotations

import argparse
import datetime
import os
import time

from held_box_load import held_box, scene_arguments
from jsonl_out import emit


def bands(*, box, tank, dx: float, t_end: float, h_factor: float, depth: float = 0.16, draft: float = 0.04) -> list[dict]:
    import jax
    import jax.numpy as jnp
    import numpy as np

    import rockjax as rj
    from rockjax.rollout import scheduled_step
    from rockjax.sph.kernels import WendlandC2, plane_integrals, wendland_c2_f

    sc, config, params = held_box("boundary_integral", box=box, tank=tank, dx=dx, h_factor=h_factor, depth=depth,
                                  draft=draft)
    if config.scheme.kernel != WendlandC2():
        raise ValueError("wall_consistency: written for the Wendland C2 kernel")
    h, rho0, nf = float(params.fluid.h), float(params.fluid.rho0), config.n_fluid
    plane = plane_integrals(config.scheme.kernel)
    step = jax.jit(scheduled_step(config, period=32))

    def analyse(s):
        P = s.particles
        x, kind = np.asarray(P.x, np.float64), np.asarray(P.kind)
        V = rho0 * np.asarray(P.vol) / np.asarray(P.rho)
        p, rho = np.asarray(P.p), np.asarray(P.rho)
        live = (kind == int(rj.Kind.FLUID)) | (kind == int(rj.Kind.WALL))
        X = np.asarray(s.blocks.x[0])
        rel = x - X
        s_face = (X[2] - 0.5 * box[2]) - x[:, 2]
        fluid = np.zeros(len(x), bool)
        fluid[:nf] = kind[:nf] == int(rj.Kind.FLUID)
        mid = (np.abs(rel[:, 0]) < 0.5 * box[0] - 2 * h) & (np.abs(rel[:, 1]) < 0.5 * box[1] - 2 * h)
        tgt = np.where(fluid & mid & (s_face > 0) & (s_face < 2 * h))[0]
        if tgt.size == 0:
            raise ValueError(f"wall_consistency: no water under the box farther than 2h = {2 * h:g} m from its sides: "
                             "make --box wider")
        d = x[tgt, None, :] - x[None, live, :]
        F = np.asarray(wendland_c2_f(jnp.asarray(np.sqrt((d * d).sum(-1))), h))
        Sz = np.sum(V[None, live] * F * d[..., 2], 1)
        A = np.asarray(plane(jnp.asarray(s_face[tgt]), h)[0])
        return np.stack([s_face[tgt] / dx, Sz + A, A, p[tgt], rho[tgt]], 1)

    s = rj.prime(sc.state, params, config)
    rows = {"t0": analyse(s)}
    n = int(round(t_end / config.dt))
    snaps = []
    for k in range(n):
        s = step(s, params)
        if k >= n - 200 and (n - 1 - k) % 20 == 0:
            snaps.append(analyse(s))
    if int(s.status):
        raise RuntimeError(f"wall_consistency: status {rj.Status.describe(int(s.status))}")
    rows["end"] = np.concatenate(snaps)
    out = []
    edges = np.arange(0.0, 2 * h / dx + 0.25, 0.25)
    for when, r in rows.items():
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (r[:, 0] >= lo) & (r[:, 0] < hi)
            if not m.any():
                continue
            D, A, p, rho = r[m, 1], r[m, 2], r[m, 3], r[m, 4]
            out.append({"bench": "wall_consistency", "when": when, "t": 0.0 if when == "t0" else n * config.dt,
                        "s_dx": [float(lo), float(hi)], "n": int(m.sum()), "D_z": float(D.mean()),
                        "D_z_sd": float(D.std()), "A": float(A.mean()), "D_over_A": float(D.mean() / A.mean()) if A.mean() > 0.05 else None,
                        "p_Pa": float(p.mean()), "spurious_az": float(np.mean(-2 * p * D / rho))})
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    scene_arguments(ap, box=[0.24, 0.24, 0.08], tank=[0.6, 0.6])
    a = ap.parse_args(argv)
    import jax

    jax.config.update("jax_enable_x64", True)
    t0 = time.perf_counter()
    recs = bands(box=tuple(a.box), tank=tuple(a.tank), dx=a.dx, t_end=a.t_end, h_factor=a.h_factor)
    stamp = {"box": a.box, "tank": a.tank, "dx": a.dx, "h_factor": a.h_factor, "wall_s": round(time.perf_counter() - t0, 1),
             "date": datetime.date.today().isoformat(), "load": round(os.getloadavg()[0], 2)}
    for r in recs:
        emit({**r, **stamp}, a.out)


if __name__ == "__main__":
    main()
