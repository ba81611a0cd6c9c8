"""Fluid-block coupling: Newton's third law, no particle inside a block, a dropped block.

The coupling methods (seed Eq 22 penalty; boundary particles carried by the block; the
semi-analytical wall term of ``Coupling.BOUNDARY_INTEGRAL``) are checked.
Scenes are tiny (dx = 2.5 cm, < 1000 water particles) so the default suite stays short.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import rockjax as rj
from rockjax import Coupling
from rockjax.coupling import penalty
from rockjax.step import advance as _advance
from rockjax.blocks.rotation import quat_matrix
from rockjax.scenes.coupled import block_drop

# one step, compiled per static config (op by op a coupled step took ~30-70 s on 2 cores)
advance = jax.jit(_advance, static_argnums=2)
accelerations = jax.jit(penalty.accelerations, static_argnums=3)


def _submerged(coupling):
    """A box half under water (so many particles feel it), primed (pressures, neighbour list)."""
    scene = block_drop(dx=0.025, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15,
                       drop_height=0.1, coupling=coupling)
    B = scene.state.blocks
    # lower the box into the water (its bottom 5 cm below the surface); remove water inside it
    x_new = B.x.at[0, 2].set(0.15 - 0.05 + 0.05)
    scene = scene.replace(state=scene.state.replace(blocks=B.replace(x=x_new, v=B.v.at[0].set([0.1, -0.2, -0.5]),
                                                                     omega=B.omega.at[0].set([0.5, 1.0, -0.3]))))
    state = rj.prime(scene.state, scene.params, scene.config)
    return scene, state


@pytest.mark.parametrize("coupling", [Coupling.PENALTY, Coupling.BOUNDARY_PARTICLES, Coupling.BOUNDARY_INTEGRAL])
def test_newton_third_law(coupling):
    """The load on the block equals minus the sum of the forces on the fluid, and likewise the
    torque about the block's centroid (to float32 round-off of the sums)."""
    scene, state = _submerged(coupling)
    config, params = scene.config, scene.params
    P, B = state.particles, state.blocks
    nf = config.n_fluid
    m = params.fluid.rho0 * P.vol[:nf]
    if coupling != Coupling.BOUNDARY_PARTICLES:  # the penalty (and with BOUNDARY_INTEGRAL the wall term)
        acc, r, idx = accelerations(P, B, params, config)
        a = jnp.sum(acc, axis=1)
    else:
        from rockjax.sph import wcsph
        from rockjax.sph.neighbours import pairs

        pr = pairs(P.x, P.kind, state.nbrs.idx, config)
        only = pr._replace(mask=pr.mask & (P.body[pr.idx] == 0))
        a = wcsph.acceleration(only, P.v, P.rho, P.p, P.vol, P.kind, params, config)[:nf] - params.gravity
        a = jnp.where((P.kind[:nf] == rj.Kind.FLUID)[:, None], a, 0.0)
        assert config.coupling_guard  # the default: the penalty within dx/4 of a face is part of the exchange
        a = a + jnp.sum(accelerations(P, B, params, config)[0], axis=1)
    f = m[:, None] * a
    n_active = int(jnp.sum(jnp.any(f != 0, axis=1)))
    assert n_active > 20, f"the test needs particles in contact with the block ({n_active})"
    load = state.coupling
    scale = float(jnp.sum(jnp.linalg.norm(f, axis=1)))
    total_f = np.asarray(load.force[0] + jnp.sum(f, 0))
    r = P.x[:nf] - B.x[0]
    total_t = np.asarray(load.torque[0] + jnp.sum(jnp.cross(r, f), 0))
    assert np.linalg.norm(total_f) <= 1e-5 * scale, (total_f, scale)
    assert np.linalg.norm(total_t) <= 1e-5 * scale * 0.2, (total_t, scale)
    assert np.all(np.asarray(load.force[1]) == 0), "the fixed floor takes no fluid load"
    assert float(load.force[0, 2]) > 0, "submerged box: the water pushes it up"


def test_boundary_particle_load_of_a_step_is_the_reaction():
    """A WCSPH step sums the block particles' loads in its own momentum pass: they equal minus the
    force that pass gave the fluid (``boundary_particles.load`` re-evaluated at the step's new
    positions, densities and pressures with the mid-step velocities ``v' - dt/2 a'`` that the
    viscous term saw), to float32 round-off. The guard (``Config.coupling_guard``, the penalty
    within dx/4 of a face, applied after that pass) adds exactly minus the momentum it gives the
    fluid."""
    from rockjax.coupling import boundary_particles

    scene, state = _submerged(Coupling.BOUNDARY_PARTICLES)
    config, params = scene.config.replace(coupling_guard=False), scene.params

    new = advance(state, params, config)
    guarded = advance(state, params, scene.config)
    nf = config.n_fluid
    m = (params.fluid.rho0 * new.particles.vol[:nf])[:, None]
    f_guard = m * (guarded.particles.v[:nf] - new.particles.v[:nf]) / config.dt  # the guard's force on the fluid
    assert float(jnp.max(jnp.abs(guarded.particles.x - new.particles.x))) == 0.0  # applied after the SPH pass
    assert int(jnp.sum(jnp.any(f_guard != 0, axis=1))) > 0, "the test needs water within dx/4 of the box"
    r = new.particles.x[:nf] - new.blocks.x[0]
    g_scale = float(jnp.sum(jnp.linalg.norm(f_guard, axis=1)))
    np.testing.assert_allclose(np.asarray(guarded.coupling.force[0] - new.coupling.force[0]),
                               -np.asarray(jnp.sum(f_guard, 0)), rtol=0, atol=1e-4 * g_scale)
    np.testing.assert_allclose(np.asarray(guarded.coupling.torque[0] - new.coupling.torque[0]),
                               -np.asarray(jnp.sum(jnp.cross(r, f_guard), 0)), rtol=0, atol=1e-4 * g_scale * 0.2)
    P = new.particles
    fluid = (P.kind == rj.Kind.FLUID)[:, None]
    v_half = jnp.where(fluid, P.v - 0.5 * config.dt * P.a, P.v)
    ref = jax.jit(boundary_particles.load, static_argnums=4)(P.replace(v=v_half), new.nbrs, new.blocks, params, config)
    scale = float(jnp.linalg.norm(ref.force[0]))
    assert scale > 0.1, "the submerged box carries a load"
    np.testing.assert_allclose(np.asarray(new.coupling.force), np.asarray(ref.force), rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(np.asarray(new.coupling.torque), np.asarray(ref.torque), rtol=0, atol=1e-5 * scale * 0.2)


def _inside_distance(x, B, i):
    R = np.asarray(quat_matrix(B.q[i]))
    rb = (np.asarray(x) - np.asarray(B.x[i])) @ R
    s = rb @ np.asarray(B.shape.face_normal[i]).T - np.asarray(B.shape.face_offset[i])
    s = np.where(np.asarray(B.shape.face_mask[i])[None], s, -np.inf)
    return s.max(1)


@pytest.fixture(scope="module", params=[Coupling.PENALTY, pytest.param(Coupling.BOUNDARY_INTEGRAL, marks=pytest.mark.slow)],
                ids=lambda c: c.value)
def dropped(request):
    scene = block_drop(dx=0.025, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15,
                       drop_height=0.1, coupling=request.param)
    return scene, rj.simulate(scene, t_end=0.5, frame_dt=0.05)


def test_block_drop_keeps_water_out_and_mass(dropped):
    """A 2.5 t/m^3 box dropped 10 cm into a 15 cm pool: no NaN (the driver would raise), mass
    constant (fixed particle masses, none lost), no water particle inside the box at any frame,
    and the box ends resting on the floor (its centroid at half its height, 0.05 m, within
    a quarter particle spacing)."""
    scene, res = dropped
    kind = res.frames["kind"][0]
    fluid = kind == rj.Kind.FLUID
    assert fluid.sum() == scene.config.n_fluid

    B0 = scene.state.blocks
    for k in range(len(res.times)):
        Bk = B0.replace(x=jnp.asarray(res.frames["block_x"][k]), q=jnp.asarray(res.frames["block_q"][k]))
        s = _inside_distance(res.frames["x"][k][fluid], Bk, 0)
        assert s.min() > 0.0, f"frame {k}: a water particle {-s.min():.3g} m inside the box"
    z_end = res.frames["block_x"][-1, 0, 2]
    assert abs(z_end - 0.05) < 0.25 * 0.025, z_end
    assert np.all(np.isfinite(res.frames["x"]))
    # the water slowed the fall: entry speed sqrt(2 g 0.1) = 1.40 m/s; the box hit the floor slower than a
    # free fall through 0.25 m would give (2.21 m/s)
    vz = res.frames["block_v"][:, 0, 2]
    assert vz.min() > -np.sqrt(2 * 9.81 * 0.25)


def test_guard_keeps_water_out_of_fixed_blocks():
    """With boundary particles, the guard and ``Config.guard_fixed`` the FIXED blocks' faces are
    guarded too (``penalty.guard_fixed``), since their wall particles are no tight barrier either: a
    water particle put 0.1 dx inside the fixed floor block gets the seed Eq 22 kick
    ``dt K_S (r0 - s)`` straight up (s = -0.1 dx, the particle at rest), and the fixed floor takes
    no load. Without ``guard_fixed`` it gets nothing beyond the SPH step."""

    scene, state = _submerged(Coupling.BOUNDARY_PARTICLES)
    assert scene.config.coupling_guard and not scene.config.guard_fixed  # the defaults
    config, params = scene.config.replace(guard_fixed=True), scene.params
    B = state.blocks
    floor = 1  # block_drop: the box, then the fixed floor
    assert config.blocks.motion[floor] == rj.blocks.Motion.FIXED
    np.testing.assert_allclose(np.asarray(B.q[floor]), [1.0, 0.0, 0.0, 0.0], atol=1e-7)
    up = np.argmax(np.asarray(B.shape.face_normal[floor])[:, 2])
    z_top = float(B.x[floor, 2] + B.shape.face_offset[floor, up])
    dx = 0.025
    P = state.particles
    nf = config.n_fluid
    i = int(jnp.argmin(jnp.where(P.kind[:nf] == rj.Kind.FLUID, P.x[:nf, 2], jnp.inf)))  # the lowest water particle
    P = P.replace(x=P.x.at[i, 2].set(z_top - 0.1 * dx), v=P.v.at[i].set(0.0), a=P.a.at[i].set(0.0))
    state = state.replace(particles=P)
    on = advance(state, params, config)
    off = advance(state, params, config.replace(guard_fixed=False))
    cp = params.coupling
    s = -0.1 * dx
    expected = config.dt * float(cp.penalty_stiffness) * (float(cp.interaction_distance) - s)
    dv = np.asarray(on.particles.v - off.particles.v)
    # the moving box's guard does not reach the particle (it is far from the box)
    np.testing.assert_allclose(dv[i], [0.0, 0.0, expected], rtol=2e-3, atol=1e-6 * expected)
    assert float(on.coupling.force[floor, 2]) == 0.0 and float(off.coupling.force[floor, 2]) == 0.0


def test_body_pair_list_is_the_block_part_of_the_wall_list():
    """``NeighbourList.body_row`` / ``body_col`` (boundary particles: the pairs a step sums the loads
    over) are exactly the wall-list pairs whose wall particle is carried by a block, in the wall
    list's order; a step's loads from it equal those from the whole wall list
    (``body_pair_capacity = 0``) to float32 round-off; a sub-list too short is reported
    (``BODY_PAIR_OVERFLOW``), never silently cut."""
    from rockjax.sph.neighbours import rebuild

    scene, state = _submerged(Coupling.BOUNDARY_PARTICLES)
    config, params = scene.config, scene.params
    nb, body = state.nbrs, np.asarray(state.particles.body)
    n = int(nb.wall_count)
    row, col = np.asarray(nb.wall_row)[:n], np.asarray(nb.wall_col)[:n]
    keep = body[col] >= 0
    m = int(nb.body_count)
    assert m == int(keep.sum()) > 100, m
    assert m <= config.body_pair_capacity and not int(state.status) & rj.Status.BODY_PAIR_OVERFLOW
    np.testing.assert_array_equal(np.asarray(nb.body_row)[:m], row[keep])
    np.testing.assert_array_equal(np.asarray(nb.body_col)[:m], col[keep])
    sub = advance(state, params, config)
    whole = advance(state, params, config.grown(body_pairs=0))
    scale = float(jnp.linalg.norm(whole.coupling.force[0]))
    np.testing.assert_allclose(np.asarray(sub.coupling.force), np.asarray(whole.coupling.force), rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(np.asarray(sub.coupling.torque), np.asarray(whole.coupling.torque), rtol=0,
                               atol=1e-5 * scale * 0.2)
    _, short, status = jax.jit(rebuild, static_argnums=1)(state.particles, config.grown(body_pairs=m - 8))
    assert int(status) & rj.Status.BODY_PAIR_OVERFLOW and int(short.body_count) == m


@pytest.mark.slow  # four coupled rollouts' compiles (~100-160 s on 2 cores); regrowing in general: test_driver_io_cli
def test_driver_grows_the_body_pair_list():
    """A boundary-particle scene started with a body-pair sub-list far too short: the driver grows
    it on ``BODY_PAIR_OVERFLOW`` and reruns, and the block moves exactly as with an ample one."""
    scene = block_drop(dx=0.025, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15,
                       drop_height=0.02, coupling=Coupling.BOUNDARY_PARTICLES)
    ref = rj.simulate(scene, t_end=0.08, frame_dt=0.04, progress=False)
    tight = scene.replace(config=scene.config.grown(body_pairs=8))
    grown = rj.simulate(tight, t_end=0.08, frame_dt=0.04, progress=False)
    assert int(ref.state.nbrs.max_body_count) > 8, "the box must be in the water by the end"
    assert grown.stats["regrows"] >= 1
    assert grown.scene.config.body_pair_capacity >= int(grown.state.nbrs.max_body_count)
    np.testing.assert_allclose(grown.frames["block_x"], ref.frames["block_x"], rtol=0, atol=1e-6)


def test_seed_scheme_boundary_particle_load_is_the_reaction():
    """The seed scheme with boundary particles: the load on the block is minus what the block's
    particles give the fluid *in the seed scheme's own forces* (spiky-kernel pressure, Eq 18
    viscosity, Eq 22 repulsion per particle pair), at priming and in a step (symplectic Euler: the
    forces at the start of the step, after the block particles are placed). Checked against the
    seed forces with all pairs minus those with the block's pairs removed (an independent sum)."""
    from rockjax.sph import seed
    from rockjax.sph.neighbours import pairs
    from rockjax.step import _advance_blocks

    scene, _ = _submerged(Coupling.BOUNDARY_PARTICLES)
    config = scene.config.replace(scheme=rj.SeedScheme(), coupling_guard=False)
    params = scene.params.replace(fluid=scene.params.fluid.replace(nu=1e-3))
    nf = config.n_fluid

    @jax.jit
    def reaction(P, nbrs, B):
        P = seed.prime(P, nbrs, params, config)
        pr = pairs(P.x, P.kind, nbrs.idx, config)
        without = pr._replace(mask=pr.mask & (P.body[pr.idx] != 0))
        a_b = (seed.forces(pr, P.v, P.rho, P.p, P.vol, P.kind, params, config)
               - seed.forces(without, P.v, P.rho, P.p, P.vol, P.kind, params, config))[:nf]
        f = params.fluid.rho0 * P.vol[:nf, None] * a_b
        return -jnp.sum(f, 0), -jnp.sum(jnp.cross(P.x[:nf] - B.x[0], f), 0), jnp.sum(jnp.linalg.norm(f, axis=1))

    state = rj.prime(scene.state, params, config)
    F, T, scale = reaction(state.particles, state.nbrs, state.blocks)
    scale = float(scale)
    assert scale > 0.1 and float(F[2]) > 0, "the submerged box carries an upward load"
    np.testing.assert_allclose(np.asarray(state.coupling.force[0]), np.asarray(F), rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(np.asarray(state.coupling.torque[0]), np.asarray(T), rtol=0, atol=1e-5 * scale * 0.2)
    new = advance(state, params, config)
    placed = jax.jit(lambda s: config.coupling_method.place(_advance_blocks(s, params, config), params, config))(state)
    F, T, scale = reaction(placed.particles, placed.nbrs, placed.blocks)
    scale = float(scale)
    np.testing.assert_allclose(np.asarray(new.coupling.force[0]), np.asarray(F), rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(np.asarray(new.coupling.torque[0]), np.asarray(T), rtol=0, atol=1e-5 * scale * 0.2)


def test_boundary_integral_needs_wcsph():
    """The wall term of ``Coupling.BOUNDARY_INTEGRAL`` is written for the WCSPH scheme: the seed
    scheme with it is refused on the host, naming the field."""
    scene = block_drop(dx=0.05, box_size=(0.1, 0.1, 0.1), tank_size=(0.3, 0.3), water_depth=0.15, drop_height=0.1,
                       coupling=Coupling.BOUNDARY_INTEGRAL)
    with pytest.raises(ValueError, match="BOUNDARY_INTEGRAL needs scheme WCSPH"):
        scene.config.replace(scheme=rj.SeedScheme())


def test_penalty_smooth_onset_and_face_blend():
    """``coupling.Penalty(onset=, face_blend=)`` (issue 44): one layer of fluid particles swept through
    the penalty layer of a resting box's top face while approaching it at 0.3 m/s, and one around its
    edge. The seed law jumps to ``K_D |v_n|`` where a particle enters (d = 0+) and switches faces at
    the edge's bisector; the smooth law starts from zero and turns the normal continuously, and is the
    seed's law (shifted by d_s / 2) beyond its onset band and away from the edge."""
    scene, state = _submerged(Coupling.PENALTY)
    config, params = scene.config, scene.params
    P, B = state.particles, state.blocks
    B = B.replace(v=jnp.zeros_like(B.v), omega=jnp.zeros_like(B.omega), q=B.q.at[0].set(jnp.asarray([1.0, 0, 0, 0])))
    nf = config.n_fluid
    cp = params.coupling
    r0, ks, kd = float(cp.interaction_distance), float(cp.penalty_stiffness), float(cp.penalty_damping)
    top = np.asarray(B.x[0]) + np.array([0.01, 0.0, 0.05])
    smooth = config.replace(coupling=penalty.Penalty(onset=0.5, face_blend=0.05))
    kind = P.kind.at[:nf].set(rj.Kind.FLUID)

    def acc_at(points, cfg, v=(0.0, 0.0, -0.3)):
        x = P.x.at[:nf].set(jnp.asarray(np.resize(points, (nf, 3)), P.x.dtype))
        vv = P.v.at[:nf].set(jnp.asarray(v, P.v.dtype))
        return np.asarray(accelerations(P.replace(x=x, v=vv, kind=kind), B, params, cfg)[0][:, 0])[:len(points)]

    # (1) through the layer along the face normal: d = r0 - s
    d = np.array([1e-7 * r0, 0.1 * r0, 0.5 * r0, 0.75 * r0, r0])
    pts = top + (r0 - d)[:, None] * np.array([0.0, 0.0, 1.0])
    a_sharp, a_smooth = acc_at(pts, config)[:, 2], acc_at(pts, smooth)[:, 2]
    np.testing.assert_allclose(a_sharp, ks * d + kd * 0.3, rtol=1e-4)
    assert a_smooth[0] < 1e-6 * a_sharp[0]  # enters with (almost) zero force, the seed's law with K_D |v_n|
    np.testing.assert_allclose(a_smooth[2:], ks * (d[2:] - 0.25 * r0) + kd * 0.3, rtol=1e-4)
    assert np.all(np.diff(a_smooth) > 0)
    # (2) round the edge between the top (+z) and the +x face, half a layer out
    th = np.linspace(0.0, 0.5 * np.pi, 361)  # 0.25 degree apart
    edge = np.asarray(B.x[0]) + np.array([0.05, 0.0, 0.05])
    pts = edge + 0.5 * r0 * np.stack([np.cos(th), np.zeros_like(th), np.sin(th)], 1)
    n_sharp = acc_at(pts, config, v=(0.0, 0.0, 0.0))
    n_smooth = acc_at(pts, config.replace(coupling=penalty.Penalty(face_blend=0.05)), v=(0.0, 0.0, 0.0))
    ang = lambda a: np.degrees(np.arctan2(a[:, 2], a[:, 0]))
    assert np.max(np.abs(np.diff(ang(n_sharp)))) == pytest.approx(90.0, abs=1e-3)  # the face switch
    assert np.max(np.abs(np.diff(ang(n_smooth)))) < 3.0  # turns over ~ 4 degrees (tau / (0.5 r0 sqrt 2) rad)
    # on the faces' normals the other face weighs exp(-0.5 r0 / tau) = exp(-10) = 4.5e-5
    np.testing.assert_allclose(n_smooth[[0, -1]], n_sharp[[0, -1]], rtol=1e-4, atol=6e-5 * np.abs(n_sharp).max())
    with pytest.raises(ValueError, match="onset"):
        penalty.Penalty(onset=-1.0)


def test_dfsph_block_exchange_conserves_momentum():
    """DFSPH with boundary particles: a box moving and spinning inside a free cube of water (no
    gravity, no walls, no periodic axis). Over one step the fluid's momentum change plus the load
    the step gave the box (``state.coupling``: the solves' pressure, the viscous term and the
    guard) is zero, and so is the angular momentum about the box's centroid where the load's torque
    is taken (after the step's block update; the fluid forces act at the rows' start positions):
    fluid-fluid pair forces are central and equal and opposite. To float32 round-off of the sums."""
    from rockjax.scenes.base import lattice
    from rockjax.scenes.coupled import _blocks_api, coupled_scene

    blocks = _blocks_api()
    dx, L, side = 0.025, 0.3, 0.1
    centre = np.full(3, L / 2)
    water = lattice([0, 0, 0], [L, L, L], dx)
    water = water[np.max(np.abs(water - centre), axis=1) > side / 2 + 0.5 * dx]
    scene = coupled_scene(name="periodic_box", dx=dx, polyhedra=[blocks.geometry.box(side, side, side)],
                          positions=[centre], motion=(blocks.Motion.DYNAMIC,), block_density=[2500.0],
                          friction_angle_deg=30.0, fluid_x=water, wall_x=np.zeros((0, 3)), domain_lo=[-L, -L, -L],
                          domain_hi=[2 * L, 2 * L, 2 * L], coupling=Coupling.BOUNDARY_PARTICLES,
                          c0=10.0, scheme=rj.DFSPH())
    B = scene.state.blocks
    state = scene.state.replace(blocks=B.replace(v=B.v.at[0].set([0.3, -0.2, 0.4]),
                                                 omega=B.omega.at[0].set([1.0, 2.0, -1.5])))
    params = scene.params.replace(gravity=jnp.zeros(3, scene.params.gravity.dtype))
    config = scene.config
    state = rj.prime(state, params, config)
    new = advance(state, params, config)
    assert int(new.status) == 0, rj.Status.describe(int(new.status))
    nf = config.n_fluid
    P = state.particles
    f = (params.fluid.rho0 * P.vol[:nf])[:, None] * (new.particles.v[:nf] - P.v[:nf]) / config.dt
    scale = float(jnp.sum(jnp.linalg.norm(f, axis=1)))
    load = new.coupling
    assert float(jnp.linalg.norm(load.force[0])) > 0.05 * scale, "the box pushes the water"
    r = P.x[:nf] - new.blocks.x[0]
    np.testing.assert_allclose(np.asarray(load.force[0] + jnp.sum(f, 0)), 0.0, rtol=0, atol=1e-5 * scale)
    np.testing.assert_allclose(np.asarray(load.torque[0] + jnp.sum(jnp.cross(r, f), 0)), 0.0, rtol=0,
                               atol=1e-5 * scale * side)
