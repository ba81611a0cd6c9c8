"""The wave flume of any paddle motion (``scenes.wave_flume``) from Python and from scene files:
each generator reaches the paddle's path, a CSV record is read relative to its scene file, and
bad options are refused naming the key. Building only (no step is compiled)."""

from __future__ import annotations

import numpy as np
import pytest

import rockjax as rj
from rockjax.blocks import paths
from rockjax.scenes.scenefile import load_scene


@pytest.mark.parametrize("wave,paddle,cls", [("regular", "piston", paths.Table), ("regular", "flap", paths.Flap),
                                             ("solitary", "piston", paths.Table), ("focused", "piston", paths.Table),
                                             ("jonswap", "flap", paths.Flap)])
def test_wave_flume_builds_every_generator(wave, paddle, cls):
    s = rj.scenes.wave_flume(dx=0.1, wave=wave, paddle=paddle, wave_height=0.03, period=1.2, flat_length=2.0,
                             sponge_length=0.6)
    (path,) = s.config.blocks.paths
    assert isinstance(path, cls)
    assert s.config.blocks.path_stroke == pytest.approx(path.stroke)
    assert float(s.params.blocks.stroke) == pytest.approx(path.stroke)
    assert s.meta["wave"] == wave and s.meta["paddle"] == paddle and s.name == "wave_flume"
    assert len(s.config.absorbers) == 1
    assert isinstance(s.config.scheme.viscosity, rj.sph.Laminar)  # waves keep their height (RESULTS.md)
    if cls is paths.Flap:
        assert path.hinge[0] == 0.0 and path.hinge[2] == 0.0 and path.lever == pytest.approx(0.3)


def test_wave_flume_scene_file_table_and_csv(tmp_path):
    csv = tmp_path / "paddle.csv"
    t = np.linspace(0, 4, 81)
    csv.write_text("t,x\n" + "\n".join(f"{a:.3f},{0.02 * np.sin(np.pi * a / 4) ** 2:.6f}" for a in t))
    f = tmp_path / "flume.toml"
    f.write_text('[scene]\nbuiltin = "wave_flume"\n[scene.options]\ndx = 0.1\nwave = "csv"\nwave_file = "paddle.csv"\n'
                 'flat_length = 2.0\n')
    s = load_scene(str(f))
    (path,) = s.config.blocks.paths
    assert path.stroke == pytest.approx(0.02, rel=1e-3) and path.end == pytest.approx(4.0)
    f.write_text('[scene]\nbuiltin = "wave_flume"\n[scene.options]\ndx = 0.1\nwave = "table"\n'
                 'wave_times = [0.0, 1.0, 2.0, 3.0]\nwave_displacement = [0.0, 0.01, 0.03, 0.03]\nflat_length = 2.0\n')
    (path,) = load_scene(str(f)).config.blocks.paths
    assert path.stroke == pytest.approx(0.03)
    f.write_text('[scene]\nbuiltin = "wave_flume"\n[scene.options]\ndx = 0.1\nwave = "tsunami"\n')
    with pytest.raises(ValueError, match=r"scene\.options\.wave.*regular, solitary"):
        load_scene(str(f))
    f.write_text('[scene]\nbuiltin = "wave_flume"\n[scene.options]\ndx = 0.1\nwave = "table"\n'
                 'wave_times = [0.0, 2.0, 1.0]\nwave_displacement = [0.0, 0.01, 0.03]\n')
    with pytest.raises(ValueError, match="increasing"):
        load_scene(str(f))
    f.write_text('[scene]\nbuiltin = "wave_flume"\n[scene.options]\ndx = 0.1\nwave = "solitary"\npaddle = "flap"\n')
    with pytest.raises(ValueError, match="piston"):
        load_scene(str(f))


def test_signal_depth_must_match_the_flume():
    sig = paths.solitary(wave_height=0.03, water_depth=0.4)
    with pytest.raises(ValueError, match="water_depth"):
        rj.scenes.piston_wavemaker(dx=0.1, water_depth=0.3, signal=sig)


def test_wave_flume_config_goes_to_json():
    # the HDF5 writer stores the static config as JSON: paths (long tables by shape and digest)
    # and sponges included, within an HDF5 attribute's 64 KiB
    import json

    from rockjax.io.hdf5 import config_to_json

    s = rj.scenes.wave_flume(dx=0.1, wave="jonswap", duration=120.0, paddle="flap", sponge_length=0.5,
                             flat_length=2.0)
    text = config_to_json(s.config)
    assert len(text) < 64 * 1024
    d = json.loads(text)
    (p,) = d["blocks"]["paths"]
    assert p["times"]["shape"] == [len(s.config.blocks.paths[0].times)] and len(p["times"]["sha1"]) == 40
    assert d["absorbers"][0]["start"] == [1.5, 0.0, 0.0]


def test_water_depth_must_be_whole_layers():
    """The flume fills whole lattice layers: 0.3 m at dx 0.04 would be 0.28 m of water under gauges
    and a paddle signal that take 0.3 m. Refused early, naming the field and a dx that fits."""
    with pytest.raises(ValueError, match=r"water_depth = 0.3 m is not a whole number of dx = 0.04 m.*0.28 m.*dx = 0.0375"):
        rj.scenes.piston_wavemaker(dx=0.04, water_depth=0.3)
    with pytest.raises(ValueError, match="not a whole number of dx = 0.07 m"):
        rj.scenes.wave_flume(dx=0.07, water_depth=0.3, wave="solitary", wave_height=0.03)
    assert rj.scenes.piston_wavemaker(dx=0.1, water_depth=0.3).config.n_fluid > 0  # 0.3 / 0.1 rounds to 3
