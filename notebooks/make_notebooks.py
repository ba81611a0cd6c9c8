"""Write the notebooks in this folder (nbformat v4, no outputs) from the cell sources below.

    .venv/bin/python notebooks/make_notebooks.py

Edit the cells here, not in the .ipynb files, and rerun: the notebooks are generated so that they
stay valid and free of outputs. ``tests/test_notebooks.py`` executes every ``*.ipynb`` here.
A notebook whose metadata has ``"rockjax": {"slow": true}`` runs only in the slow test set.
"""

from __future__ import annotations

import pathlib

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = pathlib.Path(__file__).resolve().parent

SWITCH = '''import os
FAST = os.environ.get("ROCKJAX_NB_FAST", "1") == "1"  # tiny scene for CI; ROCKJAX_NB_FAST=0 for the documented run'''

# the scene every FAST run uses: the wedge of experiments/calibrate_wedge.py (408 water particles)
TINY = '''dict(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                flat_length=0.4, flume_width=0.4, start_distance=0.0)'''


def md(text: str):
    return new_markdown_cell(text.strip("\n"))


def code(text: str):
    return new_code_cell(text.strip("\n"))


QUICKSTART = [
    md("""
# Quickstart: a rock wedge sliding into a water flume

This notebook builds the built-in `sliding_wedge` scene (the seed paper's second example: a rigid
wedge sliding down a plane into water, Mikola & Sitar 2013), runs it with `rockjax.simulate`,
and plots what the scene's observer records at every output frame: the free-surface elevation at
three wave gauges on the flat, the run-up on the far beach, and the wedge's trajectory.

**Resolution switch.** `ROCKJAX_NB_FAST=1` (the default, used by the tests) runs a tiny version:
a 0.2 m wedge on a 40 degree slope into 0.2 m of water at `dx = 0.05` m (408 water particles),
1.0 s of simulated time -- coarse, only to show the workflow.
`ROCKJAX_NB_FAST=0` runs the scene's default geometry (0.4 m wedge, 25 degree slope, 0.4 m of
water, 1 m flat, 30 degree beach) at `dx = 0.04` m for 1.5 s. See `notebooks/README.md` for the
measured run times.
"""),
    code(SWITCH),
    code("""
import time

import matplotlib.pyplot as plt
import numpy as np

import rockjax as rj
from rockjax.observables import scene_observer

if FAST:
    scene_kw = """ + TINY + """
    T_END = 1.0
else:
    scene_kw = dict(dx=0.04)   # everything else: the builder's defaults (the seed's geometry)
    T_END = 1.5
FRAME_DT = 0.02  # s between recorded frames

scene = rj.scenes.sliding_wedge(**scene_kw)
cfg = scene.config
print(f"{cfg.n_fluid} water particles, {cfg.n_wall} wall particles, {len(scene.params.blocks.density)} blocks "
      f"(wedge, slope, floor); dt = {cfg.dt:.3g} s -> {round(T_END / cfg.dt)} steps")
print("gauges (x, y) [m]:", scene.meta["gauges"]["names"], np.round(scene.meta["gauges"]["xy"], 3).tolist())
"""),
    md("""
`simulate` runs jitted chunks of steps between frames, checks the status bits after each chunk
(growing buffers if needed, stopping with a message otherwise) and stacks what `observe` returns.
`scene_observer(scene.meta)` records the gauges, the run-up (hard maximum, and the smooth
version used for gradients), the wedge centroid and the energy budget. The first call compiles
(most of the run time at this size).
"""),
    code("""
t0 = time.perf_counter()
result = rj.simulate(scene, t_end=T_END, frame_dt=FRAME_DT, observe=scene_observer(scene.meta))
print(f"{result.stats['steps']} steps in {time.perf_counter() - t0:.1f} s (compile included), "
      f"{len(result.times)} frames, buffer regrows: {result.stats['regrows']}")
obs = result.observed
print("recorded:", sorted(obs))
"""),
    code("""
t = result.times
fig, ax = plt.subplots(1, 2, figsize=(11, 3.5))
for name, eta in zip(scene.meta["gauges"]["names"], obs["gauges"].T):
    ax[0].plot(t, 1000 * eta, label=name)
ax[0].set_xlabel("t [s]"); ax[0].set_ylabel("surface elevation [mm]"); ax[0].set_title("wave gauges on the flat")
ax[0].legend()
ax[1].plot(t, 1000 * obs["runup"], label="run-up (highest particle)")
ax[1].plot(t, 1000 * obs["smooth_runup"], "--", label="smooth run-up (log-sum-exp, for gradients)")
ax[1].set_xlabel("t [s]"); ax[1].set_ylabel("run-up above still water [mm]"); ax[1].set_title("far beach")
ax[1].legend()
fig.tight_layout(); plt.show()
i = int(np.argmax(obs["runup"]))
print(f"maximum run-up {1000 * obs['runup'][i]:.1f} mm at t = {t[i]:.2f} s "
      f"(particle centres: at rest the run-up reads about -dx/2 = {-500 * scene.meta['dx']:.0f} mm)")
print("largest gauge elevations [mm]:", np.round(1000 * obs["gauges"].max(0), 1).tolist())
"""),
    md("""
The wedge's centroid (`observed["block_x"]`, the same as `result.frames["block_x"]`): its path in
the x-z plane over the slope, and its speed along the slope.
"""),
    code("""
xw = obs["block_x"][:, 0]          # (frames, 3) centroid of block 0, the wedge [m]
th = np.radians(scene.meta["slope_angle_deg"])
s = (xw - xw[0]) @ np.array([np.cos(th), 0.0, -np.sin(th)])   # distance travelled down the slope [m]
speed = np.gradient(s, t)
fig, ax = plt.subplots(1, 2, figsize=(11, 3.5))
xs = np.linspace(xw[:, 0].min() - 0.1, scene.meta["x_toe"], 2)
ax[0].plot(xs, -np.tan(th) * xs, "k-", lw=1, label="slope surface")
ax[0].axhline(0.0, color="tab:blue", lw=1, label="still water")
ax[0].plot(xw[:, 0], xw[:, 2], "o-", ms=3, label="wedge centroid")
ax[0].set_aspect("equal"); ax[0].set_xlabel("x [m]"); ax[0].set_ylabel("z [m]"); ax[0].legend(fontsize=8)
ax[1].plot(t, speed)
ax[1].set_xlabel("t [s]"); ax[1].set_ylabel("down-slope speed [m/s]")
fig.tight_layout(); plt.show()
print(f"wedge travelled {s[-1]:.3f} m down the slope (the toe is {scene.meta['water_depth'] / np.sin(th):.3f} m "
      f"from the shoreline); top speed {speed.max():.2f} m/s, final {speed[-1]:.2f} m/s")
"""),
    md("""
A snapshot of the last frame: water particles (coloured by speed) and the wedge centroid path, seen
from the side.
"""),
    code("""
f = result.frames
water = f["kind"][-1] == rj.Kind.FLUID
x, v = f["x"][-1][water], f["v"][-1][water]
fig, ax = plt.subplots(figsize=(11, 3))
sc = ax.scatter(x[:, 0], x[:, 2], c=np.linalg.norm(v, axis=1), s=4, cmap="viridis")
ax.plot(xw[:, 0], xw[:, 2], "r.-", ms=3, label="wedge centroid")
fig.colorbar(sc, ax=ax, label="|v| [m/s]")
ax.set_aspect("equal"); ax.set_xlabel("x [m]"); ax.set_ylabel("z [m]"); ax.set_title(f"t = {t[-1]:.2f} s")
ax.legend(fontsize=8); plt.show()
"""),
    md("""
Next: `rockjax run sliding_wedge --out run.h5` writes the same run to HDF5 from the command line;
`calibration.ipynb` fits the wedge's density and friction to observations, and
`ensembles.ipynb` runs a batch of sampled slides at once.
"""),
]


CALIBRATION = [
    md("""
# Calibration: recover a slide's density and friction angle from synthetic observations

The simulator is differentiable, so a misfit between simulated and observed signals can be
minimised with gradients. Here the "observations" are synthetic: a run of the sliding wedge with
known density (2500 kg/m^3) and friction angle (15 degrees) records, every 8 steps, the wedge's
position along the slope and the water-surface elevation at two gauges over the submerged slope
(x = 0.15 and 0.30 m). The fit starts from +20 % density and -20 % friction angle and runs
`rockjax.calibrate.calibrate` (optax L-BFGS directions with a line search, both fields in log
space) on the mean squared relative misfit. This is `experiments/calibrate_wedge.py` in notebook
form.

Why gauges and not run-up: the run-up on the far beach needs the wave to cross the flume (~0.6 s
here, 3x more steps per gradient); the gauges over the slope see the impact wave within 0.19 s.
`rockjax.observables.smooth_runup` is the differentiable run-up for longer horizons.

**Resolution switch.** Both settings use the tiny wedge (`dx = 0.05` m, 408 water particles,
248 steps = 0.19 s, float64). `ROCKJAX_NB_FAST=1` (CI) stops after 4 L-BFGS iterations: the
friction angle is then within about 1 %, the density is not yet (it is the weakly identified
field: the measured full run needs 18 iterations). `ROCKJAX_NB_FAST=0` runs up to 50 iterations
to convergence. See `notebooks/README.md` for the measured times.
"""),
    code(SWITCH),
    code("""
import math
import time

import jax

jax.config.update("jax_enable_x64", True)  # gradients for calibration in float64

import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import rockjax as rj
from rockjax.calibrate import calibrate, get_leaf, set_leaf, trajectory_loss
from rockjax.observables import gauge_elevation

MAX_ITER = 4 if FAST else 50
N_STEPS = 248           # 31 neighbour-list blocks of 8 steps
FIELDS = ["blocks.density[0]", "blocks.friction_angle"]

scene = rj.scenes.sliding_wedge(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                                flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                friction_angle_deg=15.0, block_density=2500.0)
print(f"{scene.config.n_fluid} water particles, dt = {scene.config.dt:.3g} s, "
      f"{N_STEPS} steps = {N_STEPS * scene.config.dt:.3f} s")
"""),
    md("""
The observation function runs inside the rollout after every block of `rebuild_every` steps:
the wedge centroid's down-slope coordinate [m] and the two gauge elevations [m]
(`gauge_elevation`: the column integral of the particle volumes, smooth in the positions).
`trajectory_loss` turns it into `L(params, state, target, w_lin, w_quad)`; one
`jax.jit(jax.value_and_grad(...))` of it makes the synthetic data and serves every iteration.
"""),
    code("""
th = math.radians(scene.meta["slope_angle_deg"])
s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])      # down-slope unit vector
gx = np.array([0.15, 0.30])                                  # gauge x [m], on the flume axis
gauges = jnp.asarray(np.stack([gx, np.full(2, 0.5 * scene.meta["flume_width"])], 1))
bottom = jnp.asarray(np.maximum(-gx * math.tan(th), -scene.meta["water_depth"]))

def observe(state, params):
    eta = gauge_elevation(state, params, scene.config, gauges, bottom_z=bottom, still_level=0.0)
    return jnp.concatenate([(state.blocks.x[0] @ s_dir)[None], eta])

L = trajectory_loss(scene.config, N_STEPS, observe)
vg = jax.jit(jax.value_and_grad(L, has_aux=True))
n_obs = N_STEPS // scene.config.rebuild_every
zero = jnp.zeros((n_obs, 3))

t0 = time.perf_counter()
(_, (target, status)), _ = vg(scene.params, scene.state, zero, zero, zero)   # the synthetic data
target = np.asarray(target)
print(f"compile + first run: {time.perf_counter() - t0:.0f} s; status: {rj.Status.describe(int(status))}")
truth = {f: float(get_leaf(scene.params, f)) for f in FIELDS}
"""),
    md("""
The misfit weights each signal by its size (the RMS of the wedge's displacement and of each gauge
record), so that metres of travel and millimetres of surface elevation count equally. The
calibration calls `value_and_grad` from the host; a status bit (instability, penetration) stops it.
"""),
    code("""
sig = target.copy()
sig[:, 0] -= float(scene.state.blocks.x[0] @ s_dir)
scale = np.sqrt(np.mean(sig**2, axis=0))
w = jnp.broadcast_to(jnp.asarray(1.0 / (target.size * scale**2)), target.shape)

def value_and_grad(p):
    (value, (_, st)), g = vg(p, scene.state, jnp.asarray(target), zero, w)
    if int(st):
        raise FloatingPointError(f"status {rj.Status.describe(int(st))} at {[float(get_leaf(p, f)) for f in FIELDS]}")
    return value, g

start = scene.params
for f, ratio in zip(FIELDS, (1.2, 0.8)):
    start = set_leaf(start, f, ratio * truth[f])

def report(it, loss, vals):
    err = ", ".join(f"{f} {vals[f] / truth[f] - 1:+.2%}" for f in FIELDS)
    print(f"iteration {it:2d}: misfit {loss:.3e}; error vs truth: {err}")

res = calibrate(None, start, FIELDS, value_and_grad=value_and_grad, max_iter=MAX_ITER, tol_loss=1e-16,
                callback=report)
print(f"{res.n_iter} iterations, {res.n_evals} loss+gradient evaluations, {res.seconds:.0f} s, converged: {res.converged}")
"""),
    code("""
rows = [("density [kg/m^3]", FIELDS[0], 1.0), ("friction angle [deg]", FIELDS[1], 180 / math.pi)]
print(f"{'':22s}{'truth':>10s}{'start':>10s}{'recovered':>11s}{'error':>9s}")
for label, f, k in rows:
    print(f"{label:22s}{k * truth[f]:10.3f}{k * res.param_paths[f][0]:10.3f}{k * res.values[f]:11.3f}"
          f"{res.values[f] / truth[f] - 1:+9.2%}")
"""),
    md("""
## Can the gradient be trusted at the step a calibration takes?

`rockjax.gradcheck` compares the AD gradient with central secants at several relative steps and
gives a verdict per field: **ok** (the secants at 1e-3 and 1e-4 -- the distance an optimiser
moves -- agree with AD within 2 %), **rough** (AD is exact but local: kinks or jumps of the loss lie
closer than the calibration step), **wrong** (the secants converge to another value: a bug), or
**unresolved**. Over this short horizon it says ok. Over a whole event (the wedge deep in the
water, the wave on the beach) the seed's sharp contact and coupling laws make it rough; build the
loss on `rockjax.calibrate.smooth_config(scene.config)` (smooth contact onset, stick/slip and
coupling entry) and, where it stays rough, average over perturbed initial states
(`rockjax.ensembles.smoothed_value_and_grad`). See RESULTS.md "Gradients over the full event".
"""),
    code("""
import os, tempfile
from rockjax.gradcheck import gradcheck

tgt = jnp.asarray(target)
misfit = jax.jit(lambda p: L(p, scene.state, tgt, zero, w)[0])

def misfit_vg(p):
    (value, _), g = vg(p, scene.state, tgt, zero, w)
    return value, g

rep = gradcheck(misfit, start, FIELDS, steps=(1e-2, 1e-3, 1e-4, 1e-5), jit=False, value_and_grad=misfit_vg,
                scan_points=7, scan_width=1e-2)
print(rep)
from IPython.display import Image
Image(rep.plot(os.path.join(tempfile.mkdtemp(), "gradcheck.png")))
"""),
    code("""
(_, (fit_obs, _)), _ = vg(res.params, scene.state, zero, zero, zero)
(_, (start_obs, _)), _ = vg(start, scene.state, zero, zero, zero)
tt = scene.config.dt * scene.config.rebuild_every * np.arange(1, n_obs + 1)
fig, ax = plt.subplots(1, 3, figsize=(13, 3.5))
ax[0].semilogy(res.loss_path, "o-"); ax[0].set_xlabel("iteration"); ax[0].set_ylabel("misfit")
for f in FIELDS:
    ax[1].semilogy(np.abs(np.asarray(res.param_paths[f]) / truth[f] - 1) + 1e-16, "o-", label=f)
ax[1].axhline(0.01, color="k", lw=0.8, ls="--", label="1 %")
ax[1].set_xlabel("iteration"); ax[1].set_ylabel("|value / truth - 1|"); ax[1].legend(fontsize=8)
for j, name in ((1, "gauge x=0.15 m"), (2, "gauge x=0.30 m")):
    ax[2].plot(tt, 1000 * target[:, j], "k-", lw=2, alpha=0.4, label="data" if j == 1 else None)
    ax[2].plot(tt, 1000 * np.asarray(start_obs)[:, j], ":", label=f"{name}: start")
    ax[2].plot(tt, 1000 * np.asarray(fit_obs)[:, j], "--", label=f"{name}: fitted")
ax[2].set_xlabel("t [s]"); ax[2].set_ylabel("surface elevation [mm]"); ax[2].legend(fontsize=7)
fig.tight_layout(); plt.show()
"""),
]


ENSEMBLES = [
    md("""
# Ensembles: run-up distribution over sampled slides

Every member of an ensemble has the same `Config` (array shapes), so `jax.vmap` runs a batch of
scenarios in one compiled program; `rockjax.ensembles` builds the batched `Params`
(`ensembles.batch`) and vmaps (and optionally shards over devices, `shard=True`) a function of
one member (`ensembles.ensemble`). Here the slide's density and friction angle are sampled and the
maximum run-up on the far beach is recorded for each member.

**Resolution switch.** `ROCKJAX_NB_FAST=1` (CI): the tiny wedge (`dx = 0.05` m, 408 water
particles) in a short flume (0.2 m flat, 0.3 m wide), 4 members, 0.7 s each -- the distribution
of 4 coarse runs only shows the workflow. `ROCKJAX_NB_FAST=0`: the same scene with 32 members. See
`notebooks/README.md` for the measured times.
"""),
    code(SWITCH),
    code("""
import time

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import rockjax as rj
from rockjax import ensembles
from rockjax.calibrate import observed
from rockjax.observables import runup

N_MEMBERS = 4 if FAST else 32
T_END = 0.7   # s: the wave reaches the beach (0.44 m from the shoreline) at about 0.4 s

scene = rj.scenes.sliding_wedge(dx=0.05, slope_angle_deg=40.0, block_length=0.2, block_width=0.2, water_depth=0.2,
                                flat_length=0.2, flume_width=0.3, start_distance=0.0)
cfg = scene.config
k = cfg.rebuild_every
n_steps = k * round(T_END / (cfg.dt * k))      # a whole number of neighbour-list blocks
print(f"{cfg.n_fluid} water particles; {N_MEMBERS} members x {n_steps} steps ({n_steps * cfg.dt:.2f} s)")
"""),
    md("""
Sample the slide: density uniform in [2000, 3000] kg/m^3, friction angle uniform in [10, 25]
degrees (a seeded generator, so the notebook is reproducible). `ensembles.batch` copies the
scene's `Params` `N_MEMBERS` times and sets the swept leaves by path.
"""),
    code("""
rng = np.random.default_rng(0)
density = rng.uniform(2000.0, 3000.0, N_MEMBERS)
friction_deg = rng.uniform(10.0, 25.0, N_MEMBERS)
params = ensembles.batch(scene.params, N_MEMBERS, {"blocks.density[0]": density,
                                                   "blocks.friction_angle": np.radians(friction_deg)})
print("batched density leaf:", params.blocks.density.shape, "(members, blocks)")
"""),
    md("""
One member: run `n_steps` (`rockjax.calibrate.observed`, the differentiable rollout; no
checkpointing is needed without a gradient) recording the run-up after every block of 8 steps,
and return its maximum over time and the final status bits. `ensembles.ensemble` maps it over the
members, jitted: on the CPU one member at a time (a `lax.map`: vmapped batches ran slower there),
on a GPU all at once under `jax.vmap` (its `batch_size` chooses).
"""),
    code("""
sl = scene.meta["runup_slope"]
runup_kw = dict(slope_point=jnp.asarray(sl["point"]), slope_normal=jnp.asarray(sl["normal"]),
                band=2 * scene.meta["dx"], still_level=scene.meta["still_level"], x_min=sl["x_min"])

def one(p):
    final, r = observed(scene, p, n_steps, lambda s, _: runup(s, **runup_kw), checkpoint=False)
    return jnp.max(r), final.status

run = ensembles.ensemble(one)
t0 = time.perf_counter()
max_runup, status = jax.device_get(run(params))
print(f"{N_MEMBERS} members in {time.perf_counter() - t0:.1f} s (compile included)")
bad = [i for i, s in enumerate(status) if int(s)]
for i in bad:
    print(f"member {i} stopped with status: {rj.Status.describe(int(status[i]))}")
print(f"{N_MEMBERS - len(bad)} of {N_MEMBERS} members ran clean")
"""),
    code("""
ok = np.asarray(status) == 0
R = 1000 * np.asarray(max_runup)
fig, ax = plt.subplots(1, 2, figsize=(11, 3.5))
ax[0].hist(R[ok], bins=max(4, N_MEMBERS // 4))
ax[0].set_xlabel("maximum run-up [mm]"); ax[0].set_ylabel("members"); ax[0].set_title("run-up distribution")
sc = ax[1].scatter(friction_deg[ok], density[ok], c=R[ok], cmap="viridis")
fig.colorbar(sc, ax=ax[1], label="maximum run-up [mm]")
ax[1].set_xlabel("friction angle [deg]"); ax[1].set_ylabel("density [kg/m^3]")
fig.tight_layout(); plt.show()
for i in np.argsort(friction_deg):
    print(f"density {density[i]:6.0f} kg/m^3, friction {friction_deg[i]:4.1f} deg -> max run-up {R[i]:6.1f} mm")
print(f"run-up: mean {R[ok].mean():.1f} mm, min {R[ok].min():.1f}, max {R[ok].max():.1f} "
      f"(particle centres: at rest it reads about -dx/2 = {-500 * scene.meta['dx']:.0f} mm)")
"""),
    md("""
The same pattern gives a batch of gradients: `ensembles.ensemble(jax.grad(loss))(params)`, and
`ensembles.ensemble(fn, shard=True)` splits the members over all devices (several GPUs, or
several hosts with `jax.distributed`; see the `rockjax.ensembles` docstring).
"""),
]

WAVE_MAKER = [
    md("""
# Wave makers: a solitary wave running up a beach, and paddles of any motion

A wave flume's paddle is a PRESCRIBED block that follows a **path** (`rockjax.blocks.paths`): a
table of displacements (piston) or angles (flap), interpolated by a clamped cubic spline so that
the paddle's velocity is the exact derivative of its position. Generators turn a target wave
into a paddle signal with linear wave-maker theory (Biesel's transfer functions) or, for a
solitary wave, Goring's (1978) path. `scenes.wave_flume` builds a flume around any of them;
`sponge_length` ends the flat in a damping layer (`rockjax.Sponge`).

**Resolution switch.** `ROCKJAX_NB_FAST=1` (the tests) runs the flume at `dx = 0.05` m (six
particle layers in 0.3 m of water: coarse, the wave comes out low); `ROCKJAX_NB_FAST=0` at
`dx = 0.02` m (see `experiments/solitary_runup.py` and RESULTS.md for the measured errors).
"""),
    code(SWITCH),
    code("""
import matplotlib.pyplot as plt
import numpy as np

import rockjax as rj
from rockjax.blocks import paths
from rockjax.observables import scene_observer
from rockjax.validation import solitary_profile, synolakis_runup

DEPTH, H = 0.3, 0.06
fig, ax = plt.subplots(1, 4, figsize=(15, 3))
sig = paths.solitary(wave_height=H, water_depth=DEPTH)
ax[0].plot(sig.times, 100 * sig.displacement); ax[0].set_title("solitary (Goring): piston [cm]")
reg = paths.regular(period=1.2, water_depth=DEPTH, duration=8.0, wave_height=0.03, kind="flap")
ax[1].plot(reg.times, 100 * reg.displacement); ax[1].set_title("regular, flap: stroke at SWL [cm]")
foc = paths.focused_group(amplitude=0.04, water_depth=DEPTH, f_min=0.6, f_max=1.2, x_focus=3.0, t_focus=10.0)
ax[2].plot(foc.times, 100 * foc.displacement); ax[2].set_title("focused group: piston [cm]")
irr = paths.jonswap(hs=0.03, tp=1.2, water_depth=DEPTH, duration=40.0, seed=1)
ax[3].plot(irr.times, 100 * irr.displacement); ax[3].set_title("JONSWAP, seed 1: piston [cm]")
for a in ax:
    a.set_xlabel("t [s]")
fig.tight_layout(); plt.show()
print(f"solitary: stroke {sig.stroke:.3f} m, celerity {sig.info['celerity']:.3f} m/s")
"""),
    md("""
The solitary wave (H/d = 0.2) runs 10 depths along the flat and up a 20 degree beach. Gauges at
2, 5 and 10 depths; the run-up is the highest water particle on the beach.
"""),
    code("""
dx = 0.05 if FAST else 0.02
scene = rj.scenes.wave_flume(dx=dx, water_depth=DEPTH, wave="solitary", wave_height=H, flat_length=10 * DEPTH,
                             beach_slope=np.tan(np.radians(20.0)), gauge_x=[2 * DEPTH, 5 * DEPTH, 10 * DEPTH])
t_end = sig.info["t_crest_at_paddle"] + 10 * DEPTH / sig.info["celerity"] + 1.5
print(f"{scene.config.n_fluid} water particles, dt = {scene.config.dt:.2e} s, {round(t_end / scene.config.dt)} steps")
result = rj.simulate(scene, t_end=t_end, frame_dt=0.02, observe=scene_observer(scene.meta))
t, eta, ru = result.times, result.observed["gauges"], result.observed["runup"]
"""),
    code("""
fig, ax = plt.subplots(1, 2, figsize=(12, 3.5))
for j, name in enumerate(scene.meta["gauges"]["names"]):
    line, = ax[0].plot(t, 1000 * eta[:, j], label=name)
    i = int(np.argmax(eta[:, j]))
    ax[0].plot(t, 1000 * solitary_profile(0.0, -(t - t[i]), wave_height=H, depth=DEPTH), ":", color=line.get_color())
ax[0].set_xlabel("t [s]"); ax[0].set_ylabel("elevation [mm]")
ax[0].set_title("gauges (dotted: Boussinesq profile of height H at each crest)"); ax[0].legend()
R_syn = synolakis_runup(wave_height=H, depth=DEPTH, beach_slope=np.tan(np.radians(20.0)))
ax[1].plot(t, 1000 * ru, label="run-up (highest particle)")
ax[1].axhline(1000 * R_syn, color="k", ls="--", label="Synolakis (1987)")
ax[1].set_xlabel("t [s]"); ax[1].set_ylabel("run-up [mm]"); ax[1].legend()
fig.tight_layout(); plt.show()
print(f"crest at 10 depths: {1000 * eta[:, 2].max():.1f} mm (target {1000 * H:.0f} mm); "
      f"max run-up {1000 * ru.max():.0f} mm, Synolakis {1000 * R_syn:.0f} mm")
"""),
    md("""
Gradients flow through the paddle's path: `Params.blocks.stroke` scales it (the scene was built
with `BlockConfig.path_stroke`, so `stroke / path_stroke = 1` is the path as given); `jax.grad`
of a gauge or run-up misfit w.r.t. `blocks.stroke` is the sensitivity to the wave's size
(`tests/gradients/test_paddle_grad.py` checks it against finite differences).
"""),
]


def write(name: str, cells, *, slow: bool = False):
    nb = new_notebook(cells=cells)
    for i, cell in enumerate(nb.cells):  # stable ids: regenerating an unchanged notebook changes nothing
        cell.id = f"{pathlib.Path(name).stem}-{i}"
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    if slow:
        nb.metadata["rockjax"] = {"slow": True}
    nbformat.validate(nb)
    nbformat.write(nb, str(HERE / name))


if __name__ == "__main__":
    write("quickstart.ipynb", QUICKSTART)
    write("calibration.ipynb", CALIBRATION, slow=True)  # measured 9 min on a loaded 2-core machine: slow set
    write("ensembles.ipynb", ENSEMBLES, slow=True)
    write("wave_maker.ipynb", WAVE_MAKER, slow=True)  # a ~4 s flume run: slow set  # measured 112 s in the tests (2026-11-27): slow set
