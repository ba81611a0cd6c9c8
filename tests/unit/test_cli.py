"""The command line, in-process (``rockjax.cli.main([...])``): list, run NAME_OR_FILE --dry-run,
flags over file values, and errors that name the key and the line (exit status 2)."""

from __future__ import annotations

import json
import pathlib

import pytest

from rockjax.cli import build_parser, is_scene_file, main
from rockjax.scenes import BUILTIN

ROOT = pathlib.Path(__file__).resolve().parents[2]

SCENE = """\
[scene]
name = "tiny"

[domain]
lo = [0.0, 0.0, 0.0]
hi = [0.4, 0.2, 0.4]

[[water]]
level = 0.2

[[block]]
shape = "box"
size = [0.1, 0.1, 0.1]
position = [0.2, 0.1, 0.32]
density = 2500.0

[sph]
dx = 0.05

[run]
t_end = 0.5

[output]
frame_dt = 0.05
out = "tiny.h5"
"""


def _json(out: str) -> dict:
    return json.loads(out.strip().splitlines()[-1])


def test_list_prints_every_builtin(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in BUILTIN:
        assert name in out


def test_help_mentions_scene_files(capsys):
    with pytest.raises(SystemExit) as info:
        main(["run", "--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "NAME_OR_FILE" in out and ".toml" in out and "--dry-run" in out
    # one parser function per subcommand
    sub = next(a for a in build_parser()._actions if a.dest == "cmd")
    assert set(sub.choices) == {"list", "run", "plot"}


def test_dry_run_of_a_scene_file(tmp_path, capsys):
    path = tmp_path / "tiny.toml"
    path.write_text(SCENE)
    assert is_scene_file(str(path)) and is_scene_file("later.toml") and not is_scene_file("dam_break")
    assert main(["run", str(path), "--dry-run"]) == 0
    info = _json(capsys.readouterr().out)
    # 8 x 4 x 4 lattice cells below z = 0.2 in the 0.4 x 0.2 tank; the block is above the water
    assert info["scene"] == "tiny" and info["fluid"] == 8 * 4 * 4 and info["blocks"] == 1
    assert info["stages"] == "sph-wcsph,blocks,joint-water,coupling-penalty"  # [materials] joint_water: default
    assert info["t_end_s"] == 0.5 and info["frame_dt_s"] == 0.05 and info["out"] == "tiny.h5"
    assert info["steps"] * info["dt_s"] == pytest.approx(0.5, rel=1e-3)  # dt_s is printed to 4 digits
    # command-line flags win over the file
    assert main(["run", str(path), "--dry-run", "--t-end", "0.1", "--out", "x.h5", "--coupling",
                 "boundary_particles"]) == 0
    info2 = _json(capsys.readouterr().out)
    assert info2["t_end_s"] == 0.1 and info2["out"] == "x.h5"
    assert info2["stages"] == "sph-wcsph,blocks,joint-water,coupling-boundary_particles"
    assert info2["wall"] > info["wall"]  # boundary particles on the block


def test_dry_run_of_an_example_with_dx_override(capsys):
    assert main(["run", str(ROOT / "examples" / "dam_break.toml"), "--dx", "0.1", "--dry-run"]) == 0
    info = _json(capsys.readouterr().out)
    # the 0.5 x 0.5 x 1.0 m column at dx 0.1: 5 x 5 x 10 particles
    assert info["scene"] == "dam_break" and info["fluid"] == 250 and info["t_end_s"] == 1.0


def test_errors_name_key_and_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE.replace("density = 2500.0", "density = -2500.0"))
    assert main(["run", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert f"{path} line 15: key `block.density` ([[block]] #1): must be > 0 kg/m^3" in err
    path.write_text(SCENE.replace("[sph]\ndx = 0.05", "[sph]\ndx = 0.05\ndxx = 1"))
    assert main(["run", str(path), "--dry-run"]) == 2
    assert "line 19: key `sph.dxx`: unknown key" in capsys.readouterr().err
    assert main(["run", str(tmp_path / "missing.toml")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_unknown_name_and_option(capsys):
    assert main(["run", "nope"]) == 2
    assert "rockjax list" in capsys.readouterr().err
    assert main(["run", "block_on_incline", "--dx", "0.1", "--dry-run"]) == 2
    assert "has no option --dx" in capsys.readouterr().err


def test_run_with_rebuild_period(capsys):
    # a tiny run with the list rebuilt at least every 4 steps; the period reaches the driver
    assert main(["run", "hydrostatic_tank", "--dx", "0.05", "--t-end", "0.005", "--rebuild-period", "4",
                 "--quiet"]) == 0
    summary = _json(capsys.readouterr().out)
    assert summary["rebuild_period"] == 4 and summary["steps"] >= 1
    # a bad period is refused with the flag named (exit 2: bad input, one line, no traceback)
    assert main(["run", "hydrostatic_tank", "--dx", "0.05", "--t-end", "0.005", "--rebuild-period", "0",
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--rebuild-period" in err and len(err.strip().splitlines()) == 1


def test_run_with_settle(capsys):
    # the water settles first (a tank: no blocks), then runs; a scene with a DYNAMIC block is refused
    assert main(["run", "hydrostatic_tank", "--dx", "0.05", "--t-end", "0.005", "--settle", "0.005",
                 "--quiet"]) == 0
    assert _json(capsys.readouterr().out)["steps"] >= 1
    assert main(["run", "block_drop", "--dx", "0.05", "--t-end", "0.005", "--settle", "0.01", "--quiet"]) == 2
    assert "DYNAMIC" in capsys.readouterr().err
