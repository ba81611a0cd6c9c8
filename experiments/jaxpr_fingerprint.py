"""Fingerprints of the traced programs: one JSON line per case with a hash of the step's jaxpr (and
of a gradient's), so that a refactor can show it traces the same program (same numbers, same speed).

Usage: ``python experiments/jaxpr_fingerprint.py --out before.jsonl`` on the old commit, the same
with ``--out after.jsonl`` on the new one, then ``--compare before.jsonl after.jsonl``. Tracing only
(no compile): ~1 min on 2 cores. Equal hashes mean the same primitives in the same order with the
same shapes and parameters; the names of jitted sub-functions are stripped first.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys

import jax
import jax.numpy as jnp


def _cases():
    """(name, scene) pairs: each scheme term and coupling once, at tiny sizes."""
    import rockjax as rj

    S = rj.scenes
    tiny = dict(dx=0.1, column_length=0.3, column_width=0.3, column_height=0.4, tank_length=0.8, tank_width=0.4)
    out = [("dam_default", S.dam_break(**tiny))]
    variants = _variants()
    for name, kw in variants.items():
        post = kw.pop("_post", None)
        scene = S.dam_break(**tiny, **kw)
        out.append((f"dam_{name}", post(scene) if post else scene))
    d = out[0][1]
    out.append(("dam_pair_sums", d.replace(config=d.config.tuned(adjoint=rj.Adjoint.PAIR_SUMS))))
    out.append(("tank_default", S.hydrostatic_tank(dx=0.05)))
    out.append(("wedge_penalty", S.sliding_wedge(dx=0.08)))
    out.append(("wedge_bp", S.sliding_wedge(dx=0.08, coupling=rj.Coupling.BOUNDARY_PARTICLES)))
    out.append(("wedge_bi", S.sliding_wedge(dx=0.08, coupling=rj.Coupling.BOUNDARY_INTEGRAL)))
    bp = S.sliding_wedge(dx=0.08, coupling=rj.Coupling.BOUNDARY_PARTICLES)
    out.append(("wedge_seed_bp", bp.replace(config=bp.config.replace(**_seed_kw()))))
    out.append(("incline", S.block_on_incline()))
    return out


def _seed_kw():
    import rockjax as rj

    if hasattr(rj, "SeedScheme"):
        return dict(scheme=rj.SeedScheme())
    return dict(scheme=rj.Scheme.SEED)


def _variants():
    """Scheme variants of the dam break, in whichever API this commit has."""
    import rockjax as rj

    if hasattr(rj, "WCSPH"):  # the scheme objects
        W = rj.WCSPH
        return {
            "laminar": dict(scheme=W(viscosity=rj.sph.Laminar())),
            "dynamic": dict(scheme=W(walls=rj.sph.DynamicWalls())),
            "cubic": dict(scheme=W(kernel=rj.sph.CubicSpline())),
            "molteni": dict(scheme=W(diffusion=rj.sph.Molteni())),
            "nodiff": dict(scheme=W(diffusion=rj.sph.NoDiffusion())),
            "fsurface": dict(scheme=W(diffusion=rj.sph.FourtakasSurface())),
            "antuono": dict(scheme=W(diffusion=rj.sph.Antuono())),
            "seed": dict(scheme=rj.SeedScheme()),
            "seed_poly6": dict(scheme=rj.SeedScheme(gradient=rj.sph.Poly6Gradient())),
            "seed_dynamic": dict(scheme=rj.SeedScheme(walls=rj.sph.DynamicWalls())),
        }
    return {
        "laminar": dict(viscosity=rj.Viscosity.LAMINAR),
        "dynamic": dict(wall_model=rj.WallModel.DYNAMIC),
        "cubic": dict(kernel=rj.KernelKind.CUBIC_SPLINE),
        "molteni": dict(density_diffusion=rj.DensityDiffusion.MOLTENI),
        "nodiff": dict(density_diffusion=rj.DensityDiffusion.NONE),
        "fsurface": dict(density_diffusion=rj.DensityDiffusion.FOURTAKAS_SURFACE),
        "antuono": dict(density_diffusion=rj.DensityDiffusion.ANTUONO),
        "seed": dict(scheme=rj.Scheme.SEED),
        "seed_poly6": dict(scheme=rj.Scheme.SEED, _post=lambda sc: sc.replace(
            config=sc.config.replace(seed_gradient=rj.SeedGradient.POLY6))),
        "seed_dynamic": dict(scheme=rj.Scheme.SEED, wall_model=rj.WallModel.DYNAMIC),
    }


def _text(jaxpr) -> str:
    s = str(jaxpr)
    s = re.sub(r"name=[A-Za-z_0-9<>.]+", "name=_", s)
    return s


def fingerprint(scene):
    import rockjax as rj

    cfg, params, state = scene.config, scene.params, scene.state
    step = rj.make_step(cfg)
    j_step = jax.make_jaxpr(step)(state, params)

    def loss(p):
        s = step(step(state, p), p)
        return jnp.sum(s.particles.x[:, 2]) if s.particles is not None else jnp.sum(s.blocks.x)

    j_grad = jax.make_jaxpr(jax.grad(loss))(params)
    j_prime = jax.make_jaxpr(lambda s, p: rj.prime(s, p, cfg))(state, params)
    out = {}
    for key, j in (("step", j_step), ("grad", j_grad), ("prime", j_prime)):
        t = _text(j)
        out[key] = hashlib.sha256(t.encode()).hexdigest()[:16]
        out[key + "_eqns"] = t.count("\n")
    return out


def compiled_pile(n: int) -> dict:
    """Op counts of the optimised, compiled XLA program of one block step of an n-box pile
    (``bench_blocks.pile``): what XLA runs after its own CSE and fusion (the jaxpr can differ where
    the compiled program does not)."""
    import collections

    import rockjax as rj
    import rockjax.blocks as rb
    from bench_blocks import pile

    polys, pos = pile(n)
    motion = [rb.Motion.FIXED] + [rb.Motion.DYNAMIC] * n
    cfg, par, st = rb.make_blocks(polys, positions=pos, motion=motion, normal_stiffness=1e7, shear_stiffness=4e6,
                                  broadphase=rb.Broadphase.GRID, pair_capacity=None)
    dt = float(rb.stable_dt(cfg, par, st))
    g = jnp.asarray([0.0, 0.0, -9.81], st.x.dtype)
    txt = jax.jit(lambda s: rb.advance_blocks(s, par, cfg, dt=dt, t=0.0, gravity=g)).lower(st).compile().as_text()
    ops = collections.Counter(re.findall(r"^\s*(?:ROOT )?\S+ = [^ ]+ ([a-z][\w-]*)\(", txt, re.M))
    import os
    import subprocess

    commit = subprocess.run(["git", "-C", os.path.dirname(rj.__file__), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    return dict(bench="compiled_pile", n_blocks=n, commit=commit, instructions=sum(ops.values()),
                fusions=ops["fusion"], gathers=ops["gather"], scatters=ops["scatter"], custom_calls=ops["custom-call"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default=None)
    ap.add_argument("--compare", nargs=2, default=None)
    ap.add_argument("--dump", default=None, help="directory: also write each jaxpr's text")
    ap.add_argument("--record", default=None, help="with --compare: append one JSON line per case and program here")
    ap.add_argument("--label", default="", help="with --record: what the two files are (e.g. 'a12d93b vs HEAD')")
    ap.add_argument("--compiled-pile", type=int, default=None, metavar="N",
                    help="instead: op counts of the compiled block step of an N-box pile (JSON line)")
    args = ap.parse_args(argv)
    if args.compiled_pile:
        import time

        rec = dict(compiled_pile(args.compiled_pile), date=time.strftime("%Y-%m-%d"))
        print(json.dumps(rec), file=open(args.out, "a") if args.out else sys.stdout, flush=True)
        return 0
    if args.compare:
        a = {r["case"]: r for r in map(json.loads, open(args.compare[0]))}
        b = {r["case"]: r for r in map(json.loads, open(args.compare[1]))}
        bad = 0
        rec = open(args.record, "a") if args.record else None
        for k in a:
            if k not in b:
                print(f"{k}: missing in {args.compare[1]}")
                bad += 1
                continue
            for key in ("step", "grad", "prime"):
                same = a[k][key] == b[k][key]
                bad += not same
                print(f"{k:16s} {key:5s} {'same' if same else 'DIFFERENT'} ({a[k][key + '_eqns']} / {b[k][key + '_eqns']} lines)")
                if rec:
                    import time

                    rec.write(json.dumps(dict(bench="jaxpr_fingerprint", case=k, program=key, same=same,
                                              lines_before=a[k][key + "_eqns"], lines_after=b[k][key + "_eqns"],
                                              label=args.label, date=time.strftime("%Y-%m-%d"))) + "\n")
        return 1 if bad else 0
    import rockjax as rj

    cases = _cases()
    f = open(args.out, "w") if args.out else sys.stdout
    for name, scene in cases:
        rec = dict(case=name, **fingerprint(scene))
        if args.dump:
            import os

            os.makedirs(args.dump, exist_ok=True)
            step = rj.make_step(scene.config)
            open(os.path.join(args.dump, name + ".txt"), "w").write(_text(jax.make_jaxpr(step)(scene.state,
                                                                                               scene.params)))
        print(json.dumps(rec), file=f, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
