"""Rock masses in scene files: ``[rock_mass]`` (a box clipped by planes) cut along ``[[joint_set]]``
tables into blocks, the same blocks ``blocks.cutting.cut`` makes; the CLI dry run prints the block
count and sizes; bad tables are refused naming the key and line."""

import json

import numpy as np
import pytest

from rockjax.blocks.cutting import JointSet, cut, region
from rockjax.cli import main
from rockjax.scenes.scenefile import load

# blocks only: a 0.6 x 0.4 x 0.3 m rock mass on a floor, cut by bedding and two vertical sets,
# its top cut off by a plane dipping 20 degrees east
ROCK = """
[scene]
name = "pile"

[[fixed]]
type = "box"
lo = [-0.5, -0.5, -0.2]
hi = [1.1, 0.9, 0.0]

[rock_mass]
lo = [0.0, 0.0, 0.001]
hi = [0.6, 0.4, 0.301]
planes = [{ point = [0.0, 0.0, 0.301], normal = [0.342020143, 0.0, 0.939692621] }]
density = 2400.0

[[joint_set]]
dip_deg = 0.0
dip_direction_deg = 0.0
spacing = 0.1
offset = 0.001

[[joint_set]]
dip_deg = 90.0
dip_direction_deg = 90.0
spacing = 0.2

[[joint_set]]
dip_deg = 90.0
dip_direction_deg = 0.0
spacing = 0.2
jitter = 0.2
seed = 7

[run]
t_end = 0.1
"""


def test_rock_mass_is_cut_into_the_blocks_cut_makes(tmp_path):
    sf = load(ROCK)
    scene = sf.scene
    planes = [((0.0, 0.0, 0.301), (0.342020143, 0.0, 0.939692621))]
    rock = cut(region((0, 0, 0.001), (0.6, 0.4, 0.301), planes),
               [JointSet(0, 0, 0.1, offset=0.001), JointSet(90, 90, 0.2), JointSet(90, 0, 0.2, jitter=0.2, seed=7)])
    assert rock.n_blocks > 10
    cfg = scene.config.blocks
    assert cfg.n_blocks == rock.n_blocks + 1  # and the floor, a fixed block
    x = np.asarray(scene.state.blocks.x)
    np.testing.assert_allclose(x[:rock.n_blocks], rock.positions, atol=1e-6)
    # the density is the rock mass's: block masses are 2400 kg/m^3 x the cut volumes
    mass = np.asarray(scene.params.blocks.density)[:rock.n_blocks] * rock.volumes
    np.testing.assert_allclose(mass, 2400.0 * rock.volumes, rtol=1e-6)
    # the region's volume: the box less the wedge the plane cuts off (0.6 tan 20 / 2 x 0.6 x 0.4)
    wedge = 0.5 * 0.6 * 0.6 * np.tan(np.radians(20.0)) * 0.4
    assert rock.volumes.sum() + rock.dropped_volume == pytest.approx(0.6 * 0.4 * 0.3 - wedge, rel=1e-9)
    assert scene.meta["rock_mass"]["blocks"] == rock.n_blocks


def test_dry_run_prints_the_block_count_and_sizes(tmp_path, capsys):
    path = tmp_path / "pile.toml"
    path.write_text(ROCK)
    assert main(["run", str(path), "--dry-run"]) == 0
    info = json.loads(capsys.readouterr().out)
    n = load(ROCK).scene.meta["rock_mass"]["blocks"]
    assert info["rock_blocks"] == n and info["blocks"] == n + 1
    d10, d50, d90 = map(float, info["rock_d10_d50_d90_m"].split("/"))
    assert 0 < d10 <= d50 <= d90 < 0.3


@pytest.mark.parametrize("change, pattern", [
    (("dip_deg = 0.0", "dip_deg = 95.0"), r"line 17: key `joint_set\.dip_deg` \(\[\[joint_set\]\] #1\): must be >= 0 and <= 90 degrees"),
    (("spacing = 0.1", "spacing = 0.0"), r"key `joint_set\.spacing` \(\[\[joint_set\]\] #1\): must be > 0"),
    (("jitter = 0.2", "jitter = 1.5"), r"line 31: key `joint_set\.jitter` \(\[\[joint_set\]\] #3\): must be >= 0 and < 1"),
    (("normal = [0.342020143, 0.0, 0.939692621]", "normal = [0.0, 0.0, -1.0]"),
     r"key `rock_mass\.planes`: region: planes\[0\] .* leaves nothing"),
    (("density = 2400.0", "density = -1.0"), r"key `rock_mass\.density`: must be > 0"),
    (("[rock_mass]", "[rock_masses]"), r"unknown table"),
    (("lo = [0.0, 0.0, 0.001]", "lo = [0.0, 0.0, -0.05]"), r"inside fixed #1"),
])
def test_bad_rock_mass_tables_are_refused(change, pattern):
    with pytest.raises(ValueError, match=pattern):
        load(ROCK.replace(*change))


def test_joint_sets_need_a_rock_mass():
    start, end = ROCK.index("[rock_mass]"), ROCK.index("[[joint_set]]")
    block = '[[block]]\nshape = "box"\nsize = [0.1, 0.1, 0.1]\nposition = [0.3, 0.2, 0.5]\n\n'
    with pytest.raises(ValueError, match=r"table `\[joint_set\]` \(\[\[joint_set\]\] #1\): joint sets cut a rock mass"):
        load(ROCK[:start] + block + ROCK[end:])
