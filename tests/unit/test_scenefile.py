"""Scene files (rockjax.scenes.scenefile) and meshes in (rockjax.scenes.meshes).

Every file in examples/ is loaded and built (coarse dx) without running; one (a water-only
built-in) runs 2 steps in the default set; the general box-off-ramp scene runs 0.3 s in the slow set
(the box slides as the closed form).
Errors must name the file, the line and the key. Meshes are tiny trimesh meshes written to tmp_path.
"""

from __future__ import annotations

import pathlib
import re

import jax
import numpy as np
import pytest
import trimesh

import rockjax as rj
from rockjax.scenes import BUILTIN
from rockjax.scenes import meshes
from rockjax.scenes.scenefile import RunOptions, load, load_builtin, load_scene

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))
# coarse spacings [m] that each example accepts (the builders' own limits: >= 4 layers of water, ...)
COARSE_DX = dict(sliding_wedge=0.08, dam_break=0.1, hydrostatic_tank=0.05, piston_wavemaker=0.1, wave_flume=0.1, floating_box=0.05,
                 block_drop=0.05, block_on_incline=None, fjord=6.0)


def _line(text: str, pattern: str, nth: int = 0) -> int:
    """1-based line of the nth line matching ``pattern`` (regex) in ``text``."""
    hits = [i + 1 for i, s in enumerate(text.splitlines()) if re.search(pattern, s)]
    return hits[nth]


# ---------------------------------------------------------------------------------------------
# examples/
# ---------------------------------------------------------------------------------------------


def test_every_builtin_has_an_example_file():
    names = {p.stem for p in EXAMPLES}
    assert set(BUILTIN) <= names
    assert {"box_off_ramp", "rock_mesh_slide"} <= names  # general-form scenes
    assert (ROOT / "examples" / "meshes" / "rock.obj").is_file()


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_example_builds(path):
    dx = COARSE_DX.get(path.stem, 0.05)
    sf = load(path, dx=dx)
    scene = sf.scene
    assert isinstance(sf.run, RunOptions) and sf.run.t_end > 0 and sf.run.frame_dt > 0
    assert sf.run.out == f"{path.stem}.h5"
    assert scene.meta["scene_file"] == str(path)
    assert scene.name == path.stem
    if dx is not None:
        assert scene.meta["dx"] == pytest.approx(dx)
        c = scene.counts()
        assert c["fluid"] > 0 and c["wall"] > 0 and c["pad"] == 0
    else:
        assert scene.state.particles is None and scene.config.blocks.n_blocks == 2


@pytest.fixture(scope="module")
def ramp():
    return load(ROOT / "examples" / "box_off_ramp.toml", dx=0.05).scene


def test_box_off_ramp_geometry(ramp):
    """The water lies where the file says: below the level, above the floor, on the water side of
    the ramp and beach planes (by >= 0.3 dx, the lattice margin), outside the box block."""
    dx = 0.05
    P = ramp.state.particles
    x = np.asarray(P.x)[np.asarray(P.kind) == rj.Kind.FLUID]
    assert np.all(x[:, 2] < 0.3) and np.all(x[:, 2] > 0.0)
    for point, normal in (([0.5, 0, 0.3], [0.5, 0, 0.8660254]), ([1.7, 0, 0], [-0.3420201, 0, 0.9396926])):
        n = np.asarray(normal) / np.linalg.norm(normal)
        assert np.min((x - np.asarray(point)) @ n) > 0.3 * dx - 1e-6
    # every lattice point of the tank below the level and clear of the slopes is water (nothing lost)
    expected = 0
    for i in range(40):
        for j in range(8):
            for k in range(6):
                p = np.array([(i + 0.5) * dx, (j + 0.5) * dx, (k + 0.5) * dx])
                if (p - [0.5, 0, 0.3]) @ [0.5, 0, 0.8660254] > 0.3 * dx and \
                        (p - [1.7, 0, 0]) @ np.array([-0.3420201, 0, 0.9396926]) > 0.3 * dx:
                    expected += 1
    assert len(x) == expected
    B = ramp.config.blocks
    assert B.n_blocks == 4 and [m.name for m in B.motion] == ["DYNAMIC", "FIXED", "FIXED", "FIXED"]
    # the rock: 0.2 x 0.16 x 0.1 m box of 2500 kg/m^3, its centroid where the file puts it
    np.testing.assert_allclose(np.asarray(ramp.state.blocks.x)[0], [0.2755, 0.2, 0.4885], atol=1e-6)
    np.testing.assert_allclose(np.asarray(ramp.state.blocks.x)[3], [1.0, 0.2, -0.1], atol=1e-6)  # the floor box
    # every fixed block lies where its file entry puts it: the ramp's and beach's top faces on their planes
    from rockjax.blocks import world_planes
    n, d = (np.asarray(a) for a in world_planes(ramp.state.blocks))
    for b, (point, normal) in ((1, ([0.5, 0, 0.3], [0.5, 0, 0.8660254])), (2, ([1.7, 0, 0], [-0.3420201, 0, 0.9396926]))):
        f = np.argmax(n[b] @ np.asarray(normal))
        assert n[b, f] @ np.asarray(normal) == pytest.approx(1.0, abs=1e-6)
        assert d[b, f] == pytest.approx(n[b, f] @ np.asarray(point), abs=1e-5)
    vol = float(np.asarray(ramp.state.blocks.shape.volume)[0])
    assert vol == pytest.approx(0.2 * 0.16 * 0.1, rel=1e-5)
    assert float(np.asarray(ramp.params.blocks.density)[0]) == 2500.0
    assert np.degrees(float(ramp.params.blocks.friction_angle)) == pytest.approx(20.0, rel=1e-5)
    assert ramp.meta["gauges"]["names"] == ["near", "far"] and ramp.meta["gauges"]["bottom_z"] == [0.0, 0.0]
    assert ramp.meta["runup_slope"]["x_min"] == 1.7 and ramp.meta["still_level"] == 0.3
    assert ramp.config.coupling == rj.Coupling.PENALTY


@pytest.mark.parametrize("extra, guard", [("", True), ("guard = false\n", False)])
def test_coupling_guard_key(extra, guard):
    """``[coupling] guard`` (boundary particles: the seed Eq 22 penalty within dx/4 of a face as
    well, default on) reaches ``Config.coupling_guard``; the guard's distance defaults to dx/4, the
    penalty coupling's to dx/2."""
    text = (ROOT / "examples" / "box_off_ramp.toml").read_text()
    assert '[coupling]\nmethod = "penalty"\n' in text
    bp = text.replace('[coupling]\nmethod = "penalty"\n', '[coupling]\nmethod = "boundary_particles"\n' + extra)
    scene = load(bp, dx=0.05).scene
    assert scene.config.coupling == rj.Coupling.BOUNDARY_PARTICLES and scene.config.coupling_guard is guard
    assert scene.config.guard_fixed is False
    fixed = load(bp.replace('method = "boundary_particles"\n', 'method = "boundary_particles"\nguard_fixed = true\n'),
                 dx=0.05).scene
    assert fixed.config.guard_fixed is True
    assert float(scene.params.coupling.interaction_distance) == pytest.approx(0.25 * 0.05)
    pen = load(text.replace('[coupling]\nmethod = "penalty"\n', '[coupling]\nmethod = "penalty"\ninteraction_distance = 0.02\n'),
               dx=0.05).scene
    assert float(pen.params.coupling.interaction_distance) == pytest.approx(0.02)
    assert float(load(text, dx=0.05).scene.params.coupling.interaction_distance) == pytest.approx(0.5 * 0.05)


def test_builtin_form_equals_builder():
    text = '[scene]\nbuiltin = "hydrostatic_tank"\n[scene.options]\ndx = 0.05\ndepth = 0.2\nscheme = "seed"\n'
    a = load_scene(text)
    b = rj.scenes.hydrostatic_tank(dx=0.05, depth=0.2, scheme=rj.SeedScheme())
    assert a.config == b.config
    np.testing.assert_array_equal(np.asarray(a.state.particles.x), np.asarray(b.state.particles.x))
    assert load_builtin("hydrostatic_tank", dx=0.05, depth=0.2, scheme="seed").config == b.config


def test_two_steps_of_an_example():
    """A scene file runs: 2 jitted steps of examples/hydrostatic_tank.toml (coarse), status OK."""
    scene = load(ROOT / "examples" / "hydrostatic_tank.toml", dx=0.05).scene
    step = jax.jit(rj.make_step(scene.config))
    s = step(step(scene.state, scene.params), scene.params)
    assert int(s.step) == 2 and int(s.status) == 0
    assert np.all(np.isfinite(np.asarray(s.particles.x)))


@pytest.mark.slow
def test_general_example_box_slides_as_closed_form(ramp):
    """examples/box_off_ramp.toml (dx 0.05) run to 0.3 s, before the box reaches the water: it slides
    down the 30 degree ramp with a = g (sin 30 - cos 30 tan 20) = 1.81 m/s^2 (Coulomb friction,
    closed form). Tolerance 1 mm + 1 %: the box starts 1 mm above the ramp, and its ~1.15 mm
    vertical drop adds ~0.6 mm along the slope. Measured: 0.0834 m vs 0.0829 m.
    The frames are whole numbers of steps and ``simulate`` rounds t_end up to a whole frame, so the
    run asks for 6 frames of the step count nearest 0.05 s (a plain t_end = 0.3 ran a 7th frame,
    to 0.349 s, since 6 such frames end 0.5 ms short of 0.3 s)."""
    k = round(0.05 / ramp.config.dt)
    frame = k * ramp.config.dt
    res = rj.simulate(ramp, t_end=6 * frame * (1 - 1e-9), frame_dt=frame, progress=False,
                      observe=rj.observables.scene_observer(ramp.meta))
    th, phi = np.radians(30.0), np.radians(20.0)
    down = np.array([np.cos(th), 0.0, -np.sin(th)])
    x = np.asarray(res.observed["block_x"])[:, 0]
    s = (x - x[0]) @ down
    expected = 0.5 * 9.81 * (np.sin(th) - np.cos(th) * np.tan(phi)) * np.asarray(res.times) ** 2
    assert res.times[-1] == pytest.approx(0.3, abs=0.01)
    np.testing.assert_allclose(s, expected, atol=1e-3, rtol=1e-2)
    np.testing.assert_allclose(x[:, 1], 0.2, atol=1e-4)  # no sideways drift


# ---------------------------------------------------------------------------------------------
# errors: file, line, key, what to change
# ---------------------------------------------------------------------------------------------

GENERAL = """\
[scene]
name = "t"

[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.4, 0.2, 0.4]

[[water]]
level = 0.2

[[block]]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0.2, 0.1, 0.3]
density = 2500.0

[[block]]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0.2, 0.1, 0.6]
density = DENSITY

[materials]
friction_angle_deg = FRICTION

[sph]
dx = DX
"""


def _general(density="2400.0", friction="30.0", dx="0.05"):
    return GENERAL.replace("DENSITY", density).replace("FRICTION", friction).replace("DX", dx)


@pytest.mark.parametrize("density,message", [("-5.0", "must be > 0 kg/m^3"), ('"heavy"', "expected a number"),
                                             ("true", "expected a number")])
def test_bad_block_density_names_line_and_key(tmp_path, density, message):
    path = tmp_path / "scene.toml"
    text = _general(density=density)
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        load(path)
    msg = str(info.value)
    assert msg.startswith(f"{path} line {_line(text, '^density', 1)}: key `block.density` ([[block]] #2): ")
    assert message in msg


@pytest.mark.parametrize("friction", ["90.0", "-1.0", "95"])
def test_friction_out_of_range(friction):
    text = _general(friction=friction)
    with pytest.raises(ValueError, match=rf"line {_line(text, '^friction')}: key `materials.friction_angle_deg`: "
                                         r"must be >= 0 and < 90 degrees"):
        load(text)


@pytest.mark.parametrize("dx", ["0.0", "-0.01"])
def test_dx_must_be_positive(dx):
    text = _general(dx=dx)
    with pytest.raises(ValueError, match=rf"line {_line(text, '^dx')}: key `sph.dx`: must be > 0 m"):
        load(text)
    with pytest.raises(ValueError, match="sph.dx"):
        load(_general(), dx=float(dx))  # the --dx override is checked as well


def test_unknown_key_lists_accepted_keys():
    text = _general().replace("density = 2500.0", "densty = 2500.0")
    with pytest.raises(ValueError) as info:
        load(text)
    msg = str(info.value)
    assert f"line {_line(text, '^densty')}: key `block.densty` ([[block]] #1): unknown key" in msg
    assert "density" in msg and "position" in msg and "shape" in msg


def test_unknown_table_and_wrong_shape_keys():
    with pytest.raises(ValueError, match=r"line 1: table `\[bloks\]`: unknown table"):
        load("[bloks]\nshape = 'box'\n")
    text = _general().replace('shape = "box"\nsize = [0.1, 0.1, 0.1]\nposition = [0.2, 0.1, 0.3]',
                              'shape = "box"\nsize = [0.1, 0.1, 0.1]\nhull = true\nposition = [0.2, 0.1, 0.3]', 1)
    with pytest.raises(ValueError, match=rf"line {_line(text, '^hull')}: key `block.hull` .*does not apply to "
                                         r"shape = 'box'"):
        load(text)
    with pytest.raises(ValueError, match=r"`\[block\]`.*write it as \[\[block\]\]"):
        load('[block]\nshape = "box"\n')


def test_missing_required_and_cross_checks():
    text = _general().replace('size = [0.1, 0.1, 0.1]\nposition = [0.2, 0.1, 0.3]\n', "", 1)
    with pytest.raises(ValueError, match=r"table `\[block\]` \(\[\[block\]\] #1\): shape = 'box' needs the key `size`"):
        load(text)
    with pytest.raises(ValueError, match=r"\[sph\].*needs the particle spacing"):
        load(_general().replace("[sph]\ndx = 0.05\n", ""))
    with pytest.raises(ValueError, match=r"key `domain.hi`: must exceed lo"):
        load(_general().replace("hi = [0.4, 0.2, 0.4]", "hi = [0.4, 0.0, 0.4]"))
    # a block that starts inside fixed geometry
    bad = _general() + '\n[[fixed]]\ntype = "box"\nlo = [0.0, 0.0, 0.0]\nhi = [0.4, 0.2, 0.3]\n'
    with pytest.raises(ValueError, match=r"key `block.position` \(\[\[block\]\] #1\): the block starts 0.05 m inside"):
        load(bad)


def test_builtin_form_errors():
    text = '[scene]\nbuiltin = "sliding_wedge"\n\n[scene.options]\ndx = 0.05\nslope_angel_deg = 30.0\n'
    with pytest.raises(ValueError) as info:
        load(text)
    msg = str(info.value)
    assert "line 6: key `scene.options.slope_angel_deg`: unknown option of built-in scene 'sliding_wedge'" in msg
    assert "slope_angle_deg" in msg and "block_density" in msg  # the accepted keys
    with pytest.raises(ValueError, match=r"line 5: key `scene.options.coupling`: must be one of 'none', 'penalty'"):
        load('[scene]\nbuiltin = "sliding_wedge"\n\n[scene.options]\ncoupling = "glue"\n')
    with pytest.raises(ValueError, match=r"line 4: key `scene.options.dx`: expected a number"):
        load('[scene]\nbuiltin = "dam_break"\n[scene.options]\ndx = "fine"\n')
    # the builder's own range check, with the line of the option it names
    with pytest.raises(ValueError, match=r"line 4: key `scene.options.column_length`: dam_break: column_length"):
        load('[scene]\nbuiltin = "dam_break"\n[scene.options]\ncolumn_length = 3.0\n')
    with pytest.raises(ValueError, match=r"line 2: key `scene.builtin`: unknown built-in scene 'nope'"):
        load('[scene]\nbuiltin = "nope"\n')
    with pytest.raises(ValueError, match=r"table `\[sph\]`: not used with `builtin`"):
        load('[scene]\nbuiltin = "dam_break"\n[sph]\ndx = 0.1\n')
    with pytest.raises(ValueError, match=r"has no option --dx"):
        load('[scene]\nbuiltin = "block_on_incline"\n', dx=0.1)


def test_wedge_block_with_velocity_blocks_only():
    """A blocks-only scene (no [[water]]): a wedge (right angle at its origin) given an initial
    velocity above a fixed floor box; volume L W H / 2, centroid where placed, velocity as given."""
    scene = load('[[block]]\nshape = "wedge"\nsize = [0.3, 0.2, 0.1]\nposition = [0.0, 0.0, 0.2]\n'
                 'velocity = [1.0, 0.0, -0.5]\ndensity = 2000.0\n'
                 '[[fixed]]\ntype = "box"\nlo = [-1.0, -1.0, -0.2]\nhi = [1.0, 1.0, 0.0]\n'
                 '[materials]\nfriction_angle_deg = 35.0\n').scene
    assert scene.state.particles is None and scene.config.n_fluid == 0
    assert [m.name for m in scene.config.blocks.motion] == ["DYNAMIC", "FIXED"]
    assert float(np.asarray(scene.state.blocks.shape.volume)[0]) == pytest.approx(0.3 * 0.2 * 0.1 / 2, rel=1e-6)
    np.testing.assert_allclose(np.asarray(scene.state.blocks.x), [[0.0, 0.0, 0.2], [0.0, 0.0, -0.1]], atol=1e-6)
    np.testing.assert_allclose(np.asarray(scene.state.blocks.v)[0], [1.0, 0.0, -0.5])
    assert np.degrees(float(scene.params.blocks.friction_angle)) == pytest.approx(35.0, rel=1e-5)


def test_guided_block_key():
    """``locked`` on a [[block]] reaches ``BlockConfig.locked`` (the fixed floor after it unlocked);
    an unknown name, all six, or a fixed block are refused at the key's line."""
    base = ('[[block]]\nshape = "box"\nsize = [0.2, 0.2, 0.1]\nposition = [0.0, 0.0, 0.2]\nLOCK\n'
            '[[fixed]]\ntype = "box"\nlo = [-1.0, -1.0, -0.2]\nhi = [1.0, 1.0, 0.0]\n')
    scene = load(base.replace("LOCK", 'locked = "y, rx rz"')).scene
    assert scene.config.blocks.locked == ((False, True, False, True, False, True), (False,) * 6)
    for lock, message in (('locked = "y side"', "unknown degrees of freedom \\['side'\\]"),
                          ('locked = "x y z rx ry rz"', "all six degrees of freedom"),
                          ('locked = "y"\nmotion = "fixed"', "only a dynamic block can be guided")):
        text = base.replace("LOCK", lock)
        with pytest.raises(ValueError, match=rf"line {_line(text, '^locked')}: key `block.locked`.*{message}"):
            load(text)


def test_toml_syntax_error_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match=r"not valid TOML: .*line 2"):
        load('[scene]\nname = \n')
    with pytest.raises(ValueError, match="does not exist"):
        load(tmp_path / "nope.toml")
    with pytest.raises(ValueError, match="scene file 'nope' does not exist"):
        load("nope")


def test_line_index_skips_multiline_arrays():
    text = ('[scene]\nname = "x"\n[[water]]\nplanes = [\n  { point = [0, 0, 0], normal = [1, 0, 0] },\n'
            '  [1, 2],\n]\nlevel = "high"  # [not a table]\n')
    with pytest.raises(ValueError, match=r"line 8: key `water.level` \(\[\[water\]\] #1\): expected a number"):
        load(text)


# ---------------------------------------------------------------------------------------------
# meshes in
# ---------------------------------------------------------------------------------------------


def _dented_sphere() -> trimesh.Trimesh:
    """A closed, outward-wound, non-convex mesh: an icosphere with one vertex pushed to 40 % radius."""
    m = trimesh.creation.icosphere(subdivisions=1, radius=0.1)
    v = m.vertices.copy()
    v[0] *= 0.4
    return trimesh.Trimesh(v, m.faces, process=False)


def test_block_from_stl_box(tmp_path):
    path = tmp_path / "box.stl"
    trimesh.creation.box(extents=[0.2, 0.1, 0.08]).export(path)
    poly = meshes.block_from_mesh(path, scale=2.0, offset=(1.0, 0.0, 0.0))
    assert poly.volume == pytest.approx(0.4 * 0.2 * 0.16, rel=1e-6)
    assert poly.n_faces == 6 and poly.n_vertices == 8
    np.testing.assert_allclose(poly.centroid_world, [1.0, 0.0, 0.0], atol=1e-7)


def test_non_convex_block_is_refused_unless_hull(tmp_path):
    path = tmp_path / "dented.obj"
    mesh = _dented_sphere()
    mesh.export(path)
    with pytest.raises(ValueError) as info:
        meshes.block_from_mesh(path)
    msg = str(info.value)
    assert str(path) in msg and "not convex" in msg and "hull = true" in msg
    hull = meshes.block_from_mesh(path, hull=True)
    assert hull.volume == pytest.approx(mesh.convex_hull.volume, rel=1e-6)
    assert hull.volume > mesh.volume * 1.01  # the dent is gone
    # from a scene file: the error names the file key and its line
    toml = tmp_path / "s.toml"
    toml.write_text('[[block]]\nshape = "mesh"\nfile = "dented.obj"\n')
    with pytest.raises(ValueError, match=r"s.toml line 3: key `block.file` \(\[\[block\]\] #1\): mesh file "
                                         r"'.*dented.obj' is not a valid convex block"):
        load(toml)
    toml.write_text('[[block]]\nshape = "mesh"\nfile = "dented.obj"\nhull = true\n')
    scene = load(toml).scene  # blocks only: one dynamic block, nothing else
    assert float(np.asarray(scene.state.blocks.shape.volume)[0]) == pytest.approx(hull.volume, rel=1e-5)


def test_open_mesh_is_refused(tmp_path):
    m = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    open_mesh = trimesh.Trimesh(m.vertices, m.faces[1:], process=False)
    path = tmp_path / "open.stl"
    open_mesh.export(path)
    with pytest.raises(ValueError, match=r"open.stl.*not closed"):
        meshes.block_from_mesh(path)
    with pytest.raises(ValueError, match=r"open.stl.*closed solid"):
        meshes.fixed_from_mesh(path)
    with pytest.raises(ValueError, match="does not exist"):
        meshes.load_mesh(tmp_path / "missing.obj")


def test_signed_distance_exact_on_a_box_and_signed_on_a_dent():
    m = trimesh.creation.box(extents=[1.0, 0.6, 0.4])
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1, 1, (500, 3))
    q = np.abs(pts) - np.array([0.5, 0.3, 0.2])
    exact = -(np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0))
    np.testing.assert_allclose(meshes.signed_distance(m.vertices[m.faces], pts), exact, atol=1e-12)
    d = _dented_sphere()
    sd = meshes.signed_distance(d.vertices[d.faces], np.array([[0.0, 0.0, 0.0], d.vertices[0] * 1.5, [0.2, 0, 0]]))
    assert sd[0] > 0 and sd[1] < 0 and sd[2] < 0  # centre inside; inside the dent and far away outside


def _water_tank(fixed: str) -> str:
    return ('[domain]\nlo = [0.0, 0.0, 0.0]\nhi = [0.6, 0.3, 0.4]\n[[water]]\nlevel = 0.25\n[sph]\ndx = 0.05\n'
            + fixed)


def test_fixed_mesh_matches_fixed_box(tmp_path):
    """A convex STL obstacle gives exactly the particles of the same `type = "box"` obstacle."""
    trimesh.creation.box(extents=[0.2, 0.3, 0.15]).export(tmp_path / "step.stl")
    as_box = load(_water_tank('[[fixed]]\ntype = "box"\nlo = [0.2, 0.0, 0.0]\nhi = [0.4, 0.3, 0.15]\n')).scene
    toml = tmp_path / "s.toml"
    toml.write_text(_water_tank('[[fixed]]\ntype = "mesh"\nfile = "step.stl"\noffset = [0.3, 0.15, 0.075]\n'))
    as_mesh = load(toml).scene
    assert as_box.counts() == as_mesh.counts()
    np.testing.assert_allclose(np.asarray(as_mesh.state.particles.x), np.asarray(as_box.state.particles.x),
                               atol=1e-6)
    x = np.asarray(as_box.state.particles.x)[np.asarray(as_box.state.particles.kind) == rj.Kind.FLUID]
    in_step = np.all((x > [0.2, 0.0, 0.0]) & (x < [0.4, 0.3, 0.15]), axis=1)
    assert not np.any(in_step) and as_box.config.blocks is None  # no moving block: water and walls only


def test_non_convex_fixed_mesh_is_walls_only(tmp_path):
    """A non-convex obstacle is sampled by its signed distance: no water inside it, walls in a band
    of ceil(2 h_factor) = 3 layers inside its surface; with a moving block it makes no block (warned)."""
    d = _dented_sphere()
    d.export(tmp_path / "dent.obj")
    toml = tmp_path / "s.toml"
    fixed = '[[fixed]]\ntype = "mesh"\nfile = "dent.obj"\nscale = 1.5\noffset = [0.3, 0.15, 0.12]\n'
    toml.write_text(_water_tank(fixed))
    scene = load(toml).scene
    P = scene.state.particles
    x, kind = np.asarray(P.x), np.asarray(P.kind)
    tris = (d.vertices * 1.5 + [0.3, 0.15, 0.12])[d.faces]
    sd = meshes.signed_distance(tris, x)
    assert np.all(sd[kind == rj.Kind.FLUID] < -0.3 * 0.05 + 1e-9)
    near = (kind == rj.Kind.WALL) & (sd >= 0)
    assert near.sum() > 0 and np.all(sd[near] < 3 * 0.05)
    toml.write_text(_water_tank(fixed) + '[[block]]\nshape = "box"\nsize = [0.1, 0.1, 0.1]\n'
                                         'position = [0.1, 0.15, 0.33]\n')
    with pytest.warns(UserWarning, match="not convex"):
        coupled = load(toml).scene
    assert coupled.config.blocks.n_blocks == 1 and coupled.meta["fixed_walls_only"]


def test_seed_gradient_key():
    """``[sph] seed_gradient`` sets the seed scheme's gradient kernel (``SeedScheme.gradient``, the
    paper's spiky kernel by default); an unknown value, or the key with the WCSPH scheme (where it
    would do nothing), is refused naming the key."""
    base = _water_tank("").replace("dx = 0.05\n", 'dx = 0.05\nscheme = "seed"\n')
    assert load(base).scene.config.scheme.gradient == rj.sph.SpikyGradient()
    poly6 = load(base.replace('scheme = "seed"\n', 'scheme = "seed"\nseed_gradient = "poly6"\n')).scene
    assert poly6.config.scheme == rj.SeedScheme(gradient=rj.sph.Poly6Gradient())
    with pytest.raises(ValueError, match=r"key `sph.seed_gradient`.*poly6"):
        load(base.replace('scheme = "seed"\n', 'scheme = "seed"\nseed_gradient = "cubic"\n'))
    with pytest.raises(ValueError, match=r"key `sph.seed_gradient`.*does not apply to scheme = \"wcsph\""):
        load(base.replace('scheme = "seed"\n', 'seed_gradient = "poly6"\n'))
