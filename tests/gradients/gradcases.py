"""Shared scenes and compiled functions for the gradient tests (not a test module).

Every compiled function is cached (``functools.lru_cache``) so that the test modules of this
folder share one compile per scene: the blocks-only functions serve the finite-difference tests,
the contact-event test and the calibration test. All of it runs in float64: call the builders
only while ``jax_enable_x64`` is on (the ``x64`` fixture in ``conftest.py``).
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np

from rockjax import blocks as B
from rockjax.calibrate import observed, trajectory_loss
from rockjax.scenes.coupled import coupled_scene

# --------------------------------------------------------------------------------------------
# blocks only: a box on a 30 degree incline
# --------------------------------------------------------------------------------------------

INCLINE_DEG = 30.0
INCLINE_STEPS = 400  # x dt = 1.48e-4 s -> 0.059 s


def incline(*, friction_deg: float = 20.0, density: float = 2500.0, gap: float = 0.0):
    """A 0.2 x 0.2 x 0.1 m box on a fixed 30 degree slope, its bottom face ``gap`` [m] above it.

    Like ``scenes.block_on_incline`` but with ``penalty_modulus = 1e7`` Pa (100x softer than the
    default): the stable step grows 10x to 1.48e-4 s, so 400 steps cover 0.059 s of sliding.
    The static Config does not depend on ``gap``, ``friction_deg`` or ``density`` (only the
    initial State and Params do), so every variant shares one compiled function.
    """
    geo = B.geometry
    lx, ly, lz = 0.2, 0.2, 0.1
    slope = geo.slope(20 * lx, 10 * ly, 0.2, INCLINE_DEG)
    th = math.radians(INCLINE_DEG)
    n = np.array([math.sin(th), 0.0, math.cos(th)])
    c, s = math.cos(th), math.sin(th)
    box = geo.box(lx, ly, lz)
    rot = box.vertices @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]).T
    tilted = geo.ConvexPolyhedron.from_vertices(rot + (0.5 * lz + gap) * n)
    # the same dt for every variant: from the reference density (a lighter block would get a
    # smaller one); the in-jit BLOCK_UNSTABLE bit checks the others
    return coupled_scene(name="incline", dx=None, polyhedra=[tilted, slope],
                         positions=[tilted.centroid_world, slope.centroid_world],
                         motion=(B.Motion.DYNAMIC, B.Motion.FIXED), block_density=density,
                         friction_angle_deg=friction_deg, block_kwargs=dict(penalty_modulus=1e7))


def incline_axes():
    """(down-slope unit vector, slope normal) [3] each."""
    th = math.radians(INCLINE_DEG)
    return np.array([math.cos(th), 0.0, -math.sin(th)]), np.array([math.sin(th), 0.0, math.cos(th)])


@functools.lru_cache(maxsize=None)
def incline_functional(config):
    """``vg(params, state, target, w_lin, w_quad) -> ((value, (obs, status)), grads)``, jitted once.

    ``obs`` [n_steps, 2]: block 0's centroid projected on the down-slope direction and on the
    slope normal [m], after every step (``incline_obs0`` gives the same at the start). ``value =
    sum(w_lin * obs) + sum(w_quad * (obs - target)^2)`` (``rockjax.calibrate.trajectory_loss``):
    with a one-hot ``w_lin`` it is one coordinate at one time (the final position), with
    ``w_quad`` a least-squares misfit (calibration). One compile serves both and every initial
    state of the incline.
    """
    t_dir, n_dir = (jnp.asarray(a) for a in incline_axes())

    def obs_fn(s, p):
        return jnp.stack([s.blocks.x[0] @ t_dir, s.blocks.x[0] @ n_dir])

    return jax.jit(jax.value_and_grad(trajectory_loss(config, INCLINE_STEPS, obs_fn), has_aux=True))


def incline_obs0(scene):
    """[2] the initial down-slope and slope-normal coordinates of block 0's centroid [m]."""
    t_dir, n_dir = incline_axes()
    x = np.asarray(scene.state.blocks.x[0])
    return np.array([x @ t_dir, x @ n_dir])


def central_fd(f, params, path, rel_step, *, get_leaf, set_leaf, abs_step=1e-4):
    """Central finite difference of the scalar ``f(params)`` w.r.t. the leaf at ``path``, with
    step ``rel_step * |value|``, or ``abs_step`` where the value is 0 (a water level at z = 0)."""
    x0 = float(get_leaf(params, path))
    h = rel_step * abs(x0) if x0 != 0.0 else abs_step
    fp = float(f(set_leaf(params, path, x0 + h)))
    fm = float(f(set_leaf(params, path, x0 - h)))
    return (fp - fm) / (2 * h)


# --------------------------------------------------------------------------------------------
# fluid only: a tiny dam break
# --------------------------------------------------------------------------------------------

DAM_STEPS = 96  # 12 list rebuilds x 8 steps, x dt ~1.04e-3 s -> 0.1 s


def tiny_dam_break(**kwargs):
    """A 0.3 x 0.3 x 0.5 m water column at dx = 0.1 m (45 fluid particles) in a 0.8 x 0.3 m tank
    (``kwargs``: more options of ``scenes.dam_break``, e.g. ``scheme``)."""
    from rockjax import scenes

    return scenes.dam_break(dx=0.1, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8,
                            tank_width=0.3, **kwargs)


@functools.lru_cache(maxsize=None)
def dam_functional(config, n_steps: int = DAM_STEPS):
    """``vg(params, state) -> (kinetic energy [J] of the fluid after n_steps, grads)``, jitted."""
    from rockjax.observables import energies

    def L(params, state):
        final, _ = observed(config, params, n_steps, None, state=state)
        return energies(final, params, config)["kinetic"]

    return jax.jit(jax.value_and_grad(L))


# --------------------------------------------------------------------------------------------
# coupled: a small wedge sliding into water
# --------------------------------------------------------------------------------------------

WEDGE_SLOPE_DEG = 40.0
WEDGE_STEPS = 248  # 31 list rebuilds x 8 steps x dt 7.6e-4 s -> 0.19 s


def tiny_wedge(coupling="penalty"):
    """``scenes.sliding_wedge`` at dx = 0.05 m: a 0.2 m wedge on a 40 degree slope (friction 15
    deg), front at the shoreline, 0.2 m deep water, 0.4 m flat (408 fluid, 4390 wall particles),
    seed Eq 22 penalty coupling (or ``coupling="boundary_particles"``)."""
    from rockjax import Coupling, scenes

    return scenes.sliding_wedge(dx=0.05, slope_angle_deg=WEDGE_SLOPE_DEG, block_length=0.2, block_width=0.2,
                                water_depth=0.2, flat_length=0.4, flume_width=0.4, start_distance=0.0,
                                coupling=Coupling(coupling))


def wedge_observe(scene):
    """``observe(state, params) -> [3]``: the wedge centroid's down-slope coordinate [m] and the
    free-surface elevation [m] at x = 0.15 and 0.30 m on the flume axis (over the submerged slope)."""
    from rockjax.observables import gauge_elevation

    th = math.radians(scene.meta["slope_angle_deg"])
    s_dir = jnp.asarray([math.cos(th), 0.0, -math.sin(th)])
    y = 0.5 * scene.meta["flume_width"]
    xs = np.array([0.15, 0.30])
    pts = jnp.asarray(np.stack([xs, np.full(2, y)], 1))
    bottom = jnp.asarray(np.maximum(-xs * math.tan(th), -scene.meta["water_depth"]))
    config = scene.config

    def observe(state, params):
        eta = gauge_elevation(state, params, config, pts, bottom_z=bottom, still_level=scene.meta["still_level"])
        return jnp.concatenate([(state.blocks.x[0] @ s_dir)[None], eta])

    return observe


@functools.lru_cache(maxsize=None)
def wedge_functional(config, observe, n_steps: int = WEDGE_STEPS):
    """``vg(params, state, target, w_lin, w_quad)`` of ``trajectory_loss`` for the wedge, jitted."""
    return jax.jit(jax.value_and_grad(trajectory_loss(config, n_steps, observe), has_aux=True))


# --------------------------------------------------------------------------------------------
# a whole event observed along the way (test_full_event, test_rock_slope_runup_grad)
# --------------------------------------------------------------------------------------------

def event_rollout(scene, config, n_steps: int, observe, n_obs: int) -> dict:
    """A scene's event under ``config`` for ``n_steps``, observed by ``observe`` (``n_obs``
    observables per list block): ``f(params, w) -> (loss, (obs, status))`` of ``trajectory_loss``
    with the weights ``w`` [n_blocks, n_obs] on the observables' values (target 0), its jitted
    ``vg = value_and_grad(loss)``, ``nb`` list blocks, and the run at ``scene.params`` (``obs``
    [nb, n_obs] numpy, ``status`` int)."""
    L = trajectory_loss(config, n_steps, observe)
    f = jax.jit(lambda p, w: L(p, scene.state, jnp.zeros_like(w), w, jnp.zeros_like(w)))
    vg = jax.jit(jax.value_and_grad(lambda p, w: f(p, w)[0]))
    nb = n_steps // config.rebuild_every
    (_, (obs, status)) = f(scene.params, jnp.zeros((nb, n_obs)))
    return dict(scene=scene, f=f, vg=vg, nb=nb, obs=np.asarray(obs), status=int(status))
