"""The catalogue of bad inputs: every one is refused with a ``ValueError`` naming the field (or the
scene file's key, or the CLI flag) and what to change, before JAX compiles anything.

One parametrized case per input, grouped as the README's promise reads: meshes, materials,
geometry, resolution, time and files through the Python API and scene files; the CLI cases run
``rockjax.cli.main`` in-process and expect exit status 2 with one line on stderr. ``no_compile``
checks that the driver compiled no chunk while refusing (the refusals are host-side checks).
"""

from __future__ import annotations

import functools
import math
import re

import numpy as np
import pytest
import trimesh

import rockjax as rj
from rockjax import driver
from rockjax.blocks import Motion, box, make_blocks, slab
from rockjax.cli import main
from rockjax.scenes import meshes
from rockjax.scenes.base import Resolution
from rockjax.scenes.scenefile import load, load_builtin

# ---------------------------------------------------------------------------------------------
# small scenes and files, built once (host only: nothing here is compiled)
# ---------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=None)
def _incline():
    return rj.scenes.block_on_incline()


@functools.lru_cache(maxsize=None)
def _tank():
    return rj.scenes.hydrostatic_tank(dx=0.05)


def _with_blocks(**changes):
    s = _incline()
    return s.replace(params=s.params.replace(blocks=s.params.blocks.replace(**changes)))


def _with_fluid(**changes):
    s = _tank()
    return s.replace(params=s.params.replace(fluid=s.params.fluid.replace(**changes)))


TANK = """\
[scene]
name = "tank"
[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.4, 0.2, 0.4]
[[water]]
level = 0.2
[sph]
dx = 0.05
"""

BLOCKS = """\
[scene]
name = "two"
[[block]]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.0, 0.0, 0.5]
[[block]]
shape = "box"
size = [0.2, 0.2, 0.2]
position = [0.5, 0.0, 0.5]
"""

BUILTIN = '[scene]\nbuiltin = "block_on_incline"\n[scene.options]\n'


def _mesh_file(tmp_path, kind: str) -> str:
    """A small mesh file with one defect: open, non-convex, inverted, degenerate (flat), or two bodies."""
    m = trimesh.creation.box(extents=[0.1, 0.1, 0.1])
    if kind == "open":
        m = trimesh.Trimesh(m.vertices, m.faces[1:], process=False)
    elif kind == "nonconvex":
        s = trimesh.creation.icosphere(subdivisions=1, radius=0.1)
        v = s.vertices.copy()
        v[0] *= 0.4
        m = trimesh.Trimesh(v, s.faces, process=False)
    elif kind == "inverted":
        m = m.copy()
        m.invert()
    elif kind == "flat":
        m = trimesh.Trimesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float),
                            [[0, 1, 2], [1, 3, 2], [0, 2, 1], [1, 2, 3]], process=False)
    elif kind == "two":
        m = trimesh.util.concatenate([m, m.copy().apply_translation([1.0, 0.0, 0.0])])
    path = tmp_path / f"{kind}.obj"
    m.export(path)
    return str(path)


def _scene_file(tmp_path, text: str) -> str:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return str(path)


def _blocks_file_with(extra: str) -> str:
    return BLOCKS.replace('position = [0.5, 0.0, 0.5]\n', 'position = [0.5, 0.0, 0.5]\n' + extra)


# ---------------------------------------------------------------------------------------------
# the catalogue: (id, call(tmp_path), regex the message must match)
# ---------------------------------------------------------------------------------------------

CASES = [
    # ---- meshes --------------------------------------------------------------------------------
    ("mesh-open-block", lambda t: meshes.block_from_mesh(_mesh_file(t, "open")), r"open\.obj.*not closed"),
    ("mesh-open-fixed", lambda t: meshes.fixed_from_mesh(_mesh_file(t, "open")), r"open\.obj.*closed solid"),
    ("mesh-nonconvex-block", lambda t: meshes.block_from_mesh(_mesh_file(t, "nonconvex")),
     r"nonconvex\.obj.*not convex.*hull"),
    ("mesh-inverted-block", lambda t: meshes.block_from_mesh(_mesh_file(t, "inverted")),
     r"inverted\.obj.*inside-out"),
    ("mesh-inverted-fixed", lambda t: meshes.fixed_from_mesh(_mesh_file(t, "inverted")),
     r"inverted\.obj.*inside-out"),
    ("mesh-degenerate-block", lambda t: meshes.block_from_mesh(_mesh_file(t, "flat")),
     r"flat\.obj.*(coplanar|zero volume)"),
    ("mesh-two-bodies", lambda t: meshes.block_from_mesh(_mesh_file(t, "two")), r"two\.obj.*several bodies"),
    ("mesh-missing-file", lambda t: meshes.block_from_mesh(t / "missing.stl"), r"missing\.stl.*does not exist"),
    ("mesh-bad-suffix", lambda t: meshes.load_mesh(_scene_file(t, "x")), r"scene\.toml.*unsupported format"),
    ("mesh-scale-zero", lambda t: meshes.load_mesh(_mesh_file(t, "box"), scale=0.0), r"scale must be a positive"),
    ("file-mesh-missing", lambda t: load(_scene_file(t, '[[block]]\nshape = "mesh"\nfile = "nope.stl"\n')),
     r"line 3: key `block\.file`.*does not exist"),
    ("file-mesh-nonconvex", lambda t: (_mesh_file(t, "nonconvex"), load(_scene_file(
        t, '[[block]]\nshape = "mesh"\nfile = "nonconvex.obj"\n')))[1], r"key `block\.file`.*not convex"),
    # ---- materials -----------------------------------------------------------------------------
    ("density-nan", lambda t: make_blocks([box(1, 1, 1)], density=math.nan), r"density"),
    ("density-negative", lambda t: make_blocks([box(1, 1, 1)], density=-2500.0), r"density"),
    ("density-absurd", lambda t: make_blocks([box(1, 1, 1)], density=1e-6), r"density must be in \[100, 25000\]"),
    ("friction-90", lambda t: make_blocks([box(1, 1, 1)], friction_angle_deg=90.0), r"friction_angle_deg must be <"),
    ("cohesion-negative", lambda t: make_blocks([box(1, 1, 1)], cohesion=-1.0), r"cohesion must be >= 0"),
    ("damping-negative", lambda t: make_blocks([box(1, 1, 1)], damping_ratio=-0.1), r"damping_ratio must be >= 0"),
    ("stiffness-zero", lambda t: make_blocks([box(1, 1, 1)], normal_stiffness=0.0), r"normal_stiffness must be >"),
    ("builder-density-absurd", lambda t: rj.scenes.block_on_incline(block_density=1e-6), r"block_density must be in"),
    ("floating-box-sinks", lambda t: rj.scenes.floating_box(dx=0.05, box_density=1500.0), r"box_density"),
    ("file-friction-95", lambda t: load(BLOCKS + "[materials]\nfriction_angle_deg = 95.0\n"),
     r"key `materials\.friction_angle_deg`: must be >= 0 and < 90"),
    ("file-density-nan", lambda t: load(_blocks_file_with("density = nan\n")), r"key `block\.density`.*finite"),
    ("file-builtin-density-nan", lambda t: load(BUILTIN + "block_density = nan\n"),
     r"line 4: key `scene\.options\.block_density`: must be finite"),
    ("params-block-density-nan", lambda t: rj.simulate(_with_blocks(density=_incline().params.blocks.density * np.nan),
                                                       t_end=0.01), r"Params\.blocks\.density"),
    ("params-friction-negative", lambda t: rj.simulate(_with_blocks(friction_angle=-_incline().params.blocks.friction_angle),
                                                       t_end=0.01), r"Params\.blocks\.friction_angle"),
    ("params-fluid-c0-nan", lambda t: rj.simulate(_with_fluid(c0=_tank().params.fluid.c0 * np.nan), t_end=0.01),
     r"Params\.fluid\.c0"),
    ("params-fluid-nu-negative", lambda t: rj.simulate(_with_fluid(nu=-_tank().params.fluid.nu - 1e-6), t_end=0.01),
     r"Params\.fluid\.nu"),
    ("params-gravity-inf", lambda t: rj.simulate(_tank().replace(params=_tank().params.replace(
        gravity=_tank().params.gravity * np.inf)), t_end=0.01), r"Params\.gravity"),
    ("rollout-params-nan", lambda t: rj.rollout(_incline().config, _incline().state, _with_blocks(
        density=_incline().params.blocks.density * np.nan).params, 1), r"Params\.blocks\.density"),
    # ---- geometry ------------------------------------------------------------------------------
    ("block-inside-floor", lambda t: make_blocks([slab(2, 2, 0.3), box(0.2, 0.2, 0.1)],
                                                 positions=[[0, 0, -0.15], [0, 0, 0.02]],
                                                 motion=[Motion.FIXED, Motion.DYNAMIC]),
     r"positions: block 0 \(FIXED\) and block 1 \(DYNAMIC\) start 0\.03 m inside"),
    ("blocks-overlap", lambda t: make_blocks([box(1, 1, 1), box(1, 1, 1)], positions=[[0, 0, 0], [0.5, 0, 0]]),
     r"positions: block 0 .* block 1 .* inside each other"),
    ("file-moving-blocks-overlap", lambda t: load(BLOCKS.replace("[0.5, 0.0, 0.5]", "[0.05, 0.0, 0.6]")),
     r"line 10: key `block\.position` \(\[\[block\]\] #2\): the block starts 0\.1 m inside block #1"),
    ("file-block-inside-fixed", lambda t: load(TANK + '[[fixed]]\ntype = "box"\nlo = [0.0, 0.0, 0.0]\n'
                                                      'hi = [0.4, 0.2, 0.1]\n[[block]]\nshape = "box"\n'
                                                      'size = [0.1, 0.1, 0.1]\nposition = [0.2, 0.1, 0.1]\n'),
     r"key `block\.position`.*inside fixed #1"),
    ("file-water-outside-tank", lambda t: load(TANK.replace("level = 0.2", "lo = [1.0, 0.0, 0.0]\nhi = [2.0, 0.2, 0.2]")),
     r"table `\[water\]` \(\[\[water\]\] #1\): holds no water particle"),
    ("file-block-zero-size", lambda t: load(BLOCKS.replace("size = [0.2, 0.2, 0.2]", "size = [0.2, 0.0, 0.2]", 1)),
     r"key `block\.size`.*must be > 0"),
    ("file-domain-inverted", lambda t: load(TANK.replace("hi = [0.4, 0.2, 0.4]", "hi = [0.4, 0.2, -0.4]")),
     r"key `domain\.hi`: must exceed lo"),
    ("file-fixed-box-inverted", lambda t: load(TANK + '[[fixed]]\ntype = "box"\nlo = [0.0, 0.0, 0.1]\n'
                                                      'hi = [0.4, 0.2, 0.0]\n'), r"key `fixed\.hi`.*must exceed lo"),
    ("builder-block-size-2", lambda t: rj.scenes.block_on_incline(block_size=(0.2, 0.2)),
     r"block_size must be 3 positive lengths"),
    ("builder-block-size-zero", lambda t: rj.scenes.block_on_incline(block_size=(0.2, 0.0, 0.1)), r"block_size"),
    ("box-zero-edge", lambda t: box(0.0, 1.0, 1.0), r"lx must be a positive"),
    ("block-drop-box-wider-than-tank", lambda t: rj.scenes.block_drop(dx=0.05, box_size=(0.6, 0.1, 0.1)),
     r"tank_size|box_size"),
    # ---- resolution ----------------------------------------------------------------------------
    ("dx-zero", lambda t: Resolution(0.0), r"dx must be a positive"),
    ("dx-negative", lambda t: rj.scenes.dam_break(dx=-0.1), r"dx"),
    ("dx-nan", lambda t: load_builtin("hydrostatic_tank", dx=math.nan), r"scene\.options\.dx.*finite"),
    ("file-dx-zero", lambda t: load(TANK.replace("dx = 0.05", "dx = 0.0")), r"key `sph\.dx`: must be > 0"),
    ("file-dx-too-large", lambda t: load(TANK.replace("dx = 0.05", "dx = 0.2")),
     r"key `domain\.hi`: the domain must be at least 4 dx"),
    ("dam-break-dx-too-coarse", lambda t: rj.scenes.dam_break(dx=0.4), r"dx .*too coarse"),
    ("tank-dx-too-coarse", lambda t: rj.scenes.hydrostatic_tank(dx=0.1), r"use dx <="),
    ("builtin-too-many-particles", lambda t: load_builtin("dam_break", dx=1e-4),
     r"scene\.options\.dx`: dx = 0\.0001 m is too fine.*lattice points, ~[0-9.e+]+ GiB"),
    ("file-too-many-particles", lambda t: load(TANK.replace("dx = 0.05", "dx = 0.00002")),
     r"key `sph\.dx`: dx = 2e-05 m is too fine.*GiB"),
    ("dfsph-relaxation-above-1", lambda t: rj.DFSPH(relaxation=1.0), r"DFSPH: relaxation must be in \(0, 1\)"),
    ("dfsph-iterations-zero", lambda t: rj.DFSPH(iterations=0), r"DFSPH: iterations must be None"),
    ("dfsph-wall-pressure", lambda t: rj.DFSPH(wall_pressure="mirror"), r"DFSPH: wall_pressure must be"),
    ("dfsph-gradient", lambda t: rj.DFSPH(gradient="adjoint"), r"DFSPH: gradient must be 'unrolled'"),
    ("dfsph-adjoint-iterations-zero", lambda t: rj.DFSPH(adjoint_iterations=0), r"DFSPH: adjoint_iterations must be"),
    ("dfsph-tolerance-negative", lambda t: rj.DFSPH(tolerance=-1e-3), r"DFSPH: tolerance must be a positive"),
    ("dfsph-min-divergence-iterations-zero", lambda t: rj.DFSPH(min_divergence_iterations=0),
     r"DFSPH: need an integer 1 <= min_divergence_iterations"),
    ("dfsph-penalty-coupling", lambda t: rj.scenes.sliding_wedge(dx=0.05, scheme="dfsph"),
     r"sliding_wedge: coupling = penalty needs the acoustic time step.*BOUNDARY_PARTICLES"),
    ("block-substeps-zero", lambda t: rj.scenes.sliding_wedge(dx=0.05, block_substeps=0),
     r"sliding_wedge: block_substeps must be an integer >= 1"),
    ("wedge-depth-not-whole-layers", lambda t: rj.scenes.sliding_wedge(dx=0.03),
     r"sliding_wedge: water_depth = 0.4 m is not a whole number of dx = 0.03 m.*0.39 m deep.*still level"),
    # ---- time ----------------------------------------------------------------------------------
    ("t-end-nan", lambda t: rj.simulate(_incline(), t_end=math.nan), r"t_end must be a positive finite"),
    ("t-end-inf", lambda t: rj.simulate(_incline(), t_end=math.inf), r"t_end must be a positive finite"),
    ("t-end-negative", lambda t: rj.simulate(_incline(), t_end=-1.0), r"t_end"),
    ("frame-dt-zero", lambda t: rj.simulate(_incline(), t_end=0.01, frame_dt=0.0), r"frame_dt must be a positive"),
    ("frame-dt-past-end", lambda t: rj.simulate(_incline(), t_end=0.002, frame_dt=0.02),
     r"frame_dt = 0\.02 s exceeds t_end = 0\.002 s"),
    ("dt-above-fluid-limit", lambda t: rj.simulate(_tank().replace(config=_tank().config.replace(
        dt=10 * _tank().config.dt)), t_end=0.1), r"Config\.dt = .* exceeds the stability limit"),
    ("dt-above-block-limit", lambda t: rj.simulate(_incline().replace(config=_incline().config.replace(
        dt=10 * _incline().config.dt)), t_end=0.1), r"Config\.dt = .* exceeds the block stability limit"),
    ("rebuild-period-zero", lambda t: rj.simulate(_incline(), t_end=0.01, rebuild_period=0), r"rebuild_period"),
    ("out-unwritable", lambda t: rj.simulate(_incline(), t_end=0.01, out=str(t / "no" / "run.h5")),
     r"out = .*run\.h5.*does not exist"),
    ("out-is-folder", lambda t: rj.simulate(_incline(), t_end=0.01, out=str(t)), r"out = .* is a folder"),
    ("file-t-end-negative", lambda t: load(BLOCKS + "[run]\nt_end = -1.0\n"), r"key `run\.t_end`: must be > 0"),
    ("file-frame-dt-zero", lambda t: load(BLOCKS + "[output]\nframe_dt = 0.0\n"),
     r"key `output\.frame_dt`: must be > 0"),
    # ---- files ---------------------------------------------------------------------------------
    ("file-unknown-key", lambda t: load(TANK.replace("dx = 0.05", "dx = 0.05\ndxx = 1")),
     r"line 10: key `sph\.dxx`: unknown key"),
    ("file-unknown-table", lambda t: load(TANK + "[wind]\nspeed = 1.0\n"), r"table `\[wind\]`: unknown table"),
    ("file-wrong-type", lambda t: load(TANK.replace("dx = 0.05", 'dx = "fine"')),
     r"key `sph\.dx`: expected a number"),
    ("file-wrong-length", lambda t: load(TANK.replace("lo = [0.0, 0.0, 0.0]", "lo = [0.0, 0.0]")),
     r"key `domain\.lo`: expected an array of 3 numbers"),
    ("file-missing-required", lambda t: load(BLOCKS.replace('shape = "box"\n', "", 1)),
     r"\[\[block\]\] #1\): the key `shape` is required"),
    ("file-array-as-table", lambda t: load(TANK.replace("[[water]]", "[water]")), r"write it as \[\[water\]\]"),
    ("file-builtin-unknown-option", lambda t: load(BUILTIN + "speed = 1.0\n"),
     r"key `scene\.options\.speed`: unknown option"),
    ("file-builtin-wrong-length", lambda t: load(BUILTIN + "block_size = [0.2, 0.2]\n"),
     r"key `scene\.options\.block_size`: expected an array of 3"),
    ("file-not-toml", lambda t: load("[scene\nname = 1\n"), r"not valid TOML"),
    ("file-missing", lambda t: load(t / "missing.toml"), r"missing\.toml.* does not exist"),
]


@pytest.fixture
def no_compile():
    """The driver compiles no chunk while an input is refused."""
    before = driver._compiled_chunk.cache_info().misses
    yield
    assert driver._compiled_chunk.cache_info().misses == before, "a chunk was compiled before the refusal"


@pytest.mark.parametrize("call, pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_refused_naming_the_field(call, pattern, tmp_path, no_compile):
    with pytest.raises(ValueError) as info:
        call(tmp_path)
    assert re.search(pattern, str(info.value)), str(info.value)


# ---------------------------------------------------------------------------------------------
# the CLI: exit status 2, one line on stderr (no traceback), also with --dry-run
# ---------------------------------------------------------------------------------------------

CLI_CASES = [
    ("t-end-nan-dry", ["block_on_incline", "--t-end", "nan", "--dry-run"], r"--t-end must be a positive finite"),
    ("t-end-inf-dry", ["block_on_incline", "--t-end", "inf", "--dry-run"], r"--t-end"),
    ("t-end-negative-dry", ["block_on_incline", "--t-end", "-1", "--dry-run"], r"--t-end .*got -1"),
    ("t-end-zero-dry", ["block_on_incline", "--t-end", "0", "--dry-run"], r"--t-end .*got 0"),
    ("t-end-negative-run", ["block_on_incline", "--t-end", "-1", "--quiet"], r"--t-end"),
    ("frame-dt-zero-dry", ["block_on_incline", "--frame-dt", "0", "--dry-run"], r"--frame-dt"),
    ("frame-dt-past-end-run", ["block_on_incline", "--t-end", "0.002", "--frame-dt", "0.02", "--quiet"],
     r"frame_dt \(--frame-dt\) = 0\.02 s exceeds t_end"),
    ("out-missing-folder-dry", ["block_on_incline", "--out", "/nonexistent/run.h5", "--dry-run"],
     r"out = '/nonexistent/run\.h5'.*does not exist"),
    ("out-missing-folder-run", ["block_on_incline", "--out", "/nonexistent/run.h5", "--t-end", "0.01", "--quiet"],
     r"/nonexistent"),
    ("dx-zero-dry", ["hydrostatic_tank", "--dx", "0", "--dry-run"], r"--dx"),
    ("dx-too-fine-dry", ["dam_break", "--dx", "0.0001", "--dry-run"], r"dx = 0\.0001 m is too fine.*GiB"),
    ("rebuild-period-zero-dry", ["block_on_incline", "--rebuild-period", "0", "--dry-run"], r"--rebuild-period"),
    ("unknown-scene", ["no_such_scene", "--dry-run"], r"unknown scene 'no_such_scene'.*rockjax list"),
    ("checkpoint-every-zero", ["block_on_incline", "--checkpoint-every", "0", "--dry-run"], r"--checkpoint-every"),
    ("resume-missing-file", ["block_on_incline", "--resume", "/nonexistent/run.h5", "--quiet"],
     r"resume = '/nonexistent/run\.h5' is not a file"),
    ("resume-with-settle", ["block_on_incline", "--resume", "run.h5", "--settle", "1"], r"--settle cannot be combined"),
]


@pytest.mark.parametrize("argv, pattern", [c[1:] for c in CLI_CASES], ids=[c[0] for c in CLI_CASES])
def test_cli_refuses_with_exit_2_and_one_line(argv, pattern, capsys, no_compile):
    assert main(["run", *argv]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rockjax: "), captured.err
    assert re.search(pattern, lines[0]), lines[0]
    assert captured.out == ""  # no dry-run JSON for a refused input


def test_catalogue_size():
    """The issue asks for at least 40 bad inputs across meshes, materials, geometry, resolution,
    time and files (plus the CLI's)."""
    assert len(CASES) + len(CLI_CASES) >= 40 and len({c[0] for c in CASES + CLI_CASES}) == len(CASES) + len(CLI_CASES)
