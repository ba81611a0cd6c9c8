"""Water at rest with the incompressible scheme, beside the peer's: how much does it move?

A 0.2 x 0.2 m tank, 0.2 m of water on the cell-centred lattice at dx = 0.02 m (1000 particles),
walls all round but the top; rockjax ``DFSPH`` (laminar viscosity ``nu``) and ``WCSPH`` for
reference, and, with ``--peer-python``, SPlisHSPlasH 2.19's DFSPH on the same water (Akinci wall
particles on the tank faces, its "Standard" viscosity = ``nu``, fixed dt 0.4 dx / sqrt(2 g H), its
default solver settings but for maxError 0.05 %, as ``shared/peers/splash_bench.py``). Per case:
the rms particle speed at 0.1 ... 1.0 s, and for rockjax the pressure at depths > 0.05 m over
rho0 g d (mean and sd over the steps of the last half second), the time-mean pressure of the
particle layers at 0.05 ... 0.17 m depth over rho0 g d, and the sweeps per step. ``--wall-pressure``
runs DFSPH with each wall model (``DFSPH.wall_pressure``).

JSON lines (``--out`` appends). Nothing here is a test.

    python experiments/dfsph_rest.py --peer-python ~/.cache/peer-venv/bin/python \
        --out experiments/results/dfsph_rest.jsonl
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import textwrap

import numpy as np

from jsonl_out import emit

DX, DEPTH, T_END = 0.02, 0.2, 1.0
TIMES = [0.1, 0.25, 0.5, 0.75, 1.0]
LAYERS = [0.05, 0.08, 0.11, 0.14, 0.17]  # depths [m] of the layer pressures (time means over the last half)


def run_rockjax(scheme_name: str, nu: float, wall_pressure: str = "extrapolated") -> dict:
    import jax

    import rockjax as rj
    from rockjax.sph.viscosity import Laminar
    from rockjax.step import make_step, prime

    visc = {} if nu is None else {"viscosity": Laminar()}  # None: the scheme's default (artificial) viscosity
    scheme = (rj.DFSPH(wall_pressure=wall_pressure, **visc) if scheme_name == "dfsph" else rj.WCSPH(**visc))
    sc = rj.scenes.hydrostatic_tank(dx=DX, depth=DEPTH, scheme=scheme, **({} if nu is None else {"nu": nu}))
    config = sc.config.replace(rebuild_every=1)
    step = jax.jit(make_step(config))
    state = prime(sc.state, sc.params, config)
    n = int(round(T_END / config.dt))
    marks = {int(round(t / config.dt)) - 1: t for t in TIMES}
    v_rms, p_ratio, sweeps, layers = {}, [], [], []
    for k in range(n):
        state = step(state, sc.params)
        P = state.particles
        fluid = np.asarray(P.kind) == rj.Kind.FLUID
        if k in marks:
            v_rms[marks[k]] = float(np.sqrt((np.asarray(P.v)[fluid] ** 2).sum(1).mean()))
        if k >= n // 2:
            z, p = np.asarray(P.x)[fluid, 2], np.asarray(P.p)[fluid]
            surface = z.max() + 0.5 * DX
            deep = surface - z > 0.05
            p_ratio.append(float(p[deep].mean() / (1000 * 9.81 * (surface - z[deep])).mean()))
            d = DEPTH - z  # below the lattice's free surface (dx/2 above its top row)
            layers.append([p[np.abs(d - dd) < DX / 2].mean() / (1000 * 9.81 * dd) for dd in LAYERS])
            if P.solver is not None:
                sweeps.append(np.asarray(P.solver)[0, 4:6])
    rec = {"code": "rockjax", "scheme": scheme_name, "kernel": config.scheme.kernel.name,
           "viscosity": config.scheme.viscosity.name,
           "h_dx": round(float(sc.params.fluid.h) / DX, 3), "nu": nu, "dt": config.dt, "steps": n, "status": int(state.status),
           "v_rms": {str(t): round(v, 5) for t, v in v_rms.items()},
           "p_ratio_mean_last_half": round(float(np.mean(p_ratio)), 4),
           "p_ratio_sd_last_half": round(float(np.std(p_ratio)), 4),
           "p_ratio_layers": [round(float(r), 4) for r in np.mean(layers, axis=0)], "layers_m": LAYERS}
    if scheme_name == "dfsph":
        rec["wall_pressure"] = wall_pressure
    if sweeps:
        rec["sweeps_density_divergence"] = [round(float(s), 2) for s in np.mean(sweeps, axis=0)]
    return rec


PEER = textwrap.dedent('''
    import json, math, os, sys, tempfile
    if not os.environ.get("_PRE") and os.path.exists("/usr/lib/x86_64-linux-gnu/libGLdispatch.so.0"):
        env = dict(os.environ, _PRE="1", LD_PRELOAD="/usr/lib/x86_64-linux-gnu/libGLdispatch.so.0")
        os.execve(sys.executable, [sys.executable] + sys.argv, env)
    import numpy as np
    import pysplishsplash as sph
    nu, dx, H, t_end, times, peers = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), json.loads(sys.argv[5]), sys.argv[6]
    sys.path.insert(0, peers)
    from splash_bench import write_open_box_obj
    r, L = dx / 2, H
    tmp = tempfile.mkdtemp()
    write_open_box_obj(os.path.join(tmp, "tank.obj"), (-r, -r, -r), (L + r, H + 0.2, L + r))
    dt = 0.4 * dx / math.sqrt(2 * 9.81 * H)
    conf = {"pause": False, "sim2D": False, "particleRadius": r, "simulationMethod": 4, "gravitation": [0, -9.81, 0],
            "boundaryHandlingMethod": 0, "enableZSort": True, "numberOfStepsPerRenderUpdate": 1,
            "DFSPH": {"minIterations": 2, "maxIterations": 100, "maxError": 0.05, "maxIterationsV": 100,
                      "maxErrorV": 0.1, "enableDivergenceSolver": True}, "cflMethod": 0, "timeStepSize": dt}
    rb = {"geometryFile": "tank.obj", "translation": [0, 0, 0], "rotationAxis": [1, 0, 0], "rotationAngle": 0,
          "scale": [1, 1, 1], "isDynamic": False, "isWall": True, "samplingMode": 1, "mapInvert": True,
          "mapThickness": 0.0, "mapResolution": [40, 40, 20]}
    scene = {"Configuration": conf, "Materials": [{"id": "Fluid", "density0": 1000, "viscosityMethod": 1,
             "Standard viscosity": {"viscosity": nu}}], "RigidBodies": [rb],
             "FluidBlocks": [{"denseMode": 0, "start": [-r, -r, -r], "end": [L + r, H + r, L + r]}]}
    path = os.path.join(tmp, "scene.json"); json.dump(scene, open(path, "w"))
    base = sph.Exec.SimulatorBase()
    base.init(useGui=False, sceneFile=path, outputDir=os.path.join(tmp, "out"), useCache=False, initialPause=False, stopAt=t_end)
    base.initSimulation()
    fluid = sph.Simulation.getCurrent().getFluidModel(0); tm = sph.TimeManager.getCurrent()
    n = fluid.numActiveParticles(); hist = []
    base.setTimeStepCB(lambda: hist.append((tm.getTime(), float(np.sqrt((np.asarray(fluid.getFieldBuffer("velocity"))[:n] ** 2).sum(1).mean())))))
    base.runSimulation()
    ts = np.array([h[0] for h in hist]); vs = np.array([h[1] for h in hist])
    out = {str(t): round(float(vs[np.argmin(np.abs(ts - t))]), 5) for t in times}
    print("RESULT " + json.dumps({"n_fluid": int(n), "dt": dt, "v_rms": out}))
''')


def run_peer(python: str, nu: float) -> dict:
    peers = os.environ.get("PEERS_DIR", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "peers"))
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:  # a file: it re-execs itself
        f.write(PEER)
    out = subprocess.run([python, f.name, str(nu), str(DX), str(DEPTH), str(T_END), json.dumps(TIMES),
                          os.path.abspath(peers)], capture_output=True, text=True, timeout=900)
    os.unlink(f.name)
    line = [s for s in out.stdout.splitlines() if s.startswith("RESULT ")]
    if not line:
        return {"code": "splishsplash", "scheme": "dfsph", "nu": nu, "error": (out.stderr or out.stdout)[-500:]}
    return dict({"code": "splishsplash", "version": "2.19.0", "scheme": "dfsph", "nu": nu}, **json.loads(line[0][7:]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nu", type=float, nargs="*", default=[1e-6, 1e-3, 1e-2])
    ap.add_argument("--schemes", nargs="*", default=["dfsph", "wcsph"])
    ap.add_argument("--peer-python", default=None, help="a python with pysplishsplash 2.19 (the peer venv)")
    ap.add_argument("--wall-pressure", nargs="+", default=["extrapolated"], choices=["extrapolated", "akinci"],
                    help="DFSPH's wall pressure models to run (DFSPH.wall_pressure)")
    ap.add_argument("--artificial", action="store_true",
                    help="also run DFSPH with its default (artificial) viscosity instead of the laminar nu")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    meta = {"bench": "dfsph_rest", "date": datetime.date.today().isoformat(), "dx": DX, "depth": DEPTH}
    if args.artificial:  # the schemes' default viscosity (no peer counterpart)
        for wp in args.wall_pressure:
            emit(dict(meta, **run_rockjax("dfsph", None, wp)), args.out)
    for nu in args.nu:
        for scheme in args.schemes:
            if scheme == "wcsph" and nu != args.nu[0]:
                continue  # WCSPH's reference: one viscosity
            for wp in (args.wall_pressure if scheme == "dfsph" else [None]):
                emit(dict(meta, **run_rockjax(scheme, nu, *([wp] if wp else []))), args.out)
        if args.peer_python:
            emit(dict(meta, **run_peer(args.peer_python, nu)), args.out)


if __name__ == "__main__":
    sys.exit(main())
