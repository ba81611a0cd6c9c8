"""The scene builders' typed hand-overs (``rockjax.scenes.base``, ``.meta``): ``Resolution`` decides h,
the kernel support and the wall layers from dx and h_factor, and refuses bad values by name;
``particle_layout`` returns a ``ParticleLayout``; ``SceneMeta`` types the observers' keys and reads
as the dict it replaced (same keys, order and JSON)."""

from __future__ import annotations

import math

import pytest

from rockjax.scenes.base import Resolution
from rockjax.sph.kernels import SUPPORT_FACTOR


def test_resolution_derives_h_support_and_layers():
    r = Resolution(0.02, 1.3)
    assert r.h == 1.3 * 0.02
    assert r.support == SUPPORT_FACTOR * 1.3 * 0.02
    assert r.wall_layers == 3 == math.ceil(SUPPORT_FACTOR * 1.3)
    assert Resolution(0.02, 1.5).wall_layers == 3
    assert Resolution(0.02, 1.6).wall_layers == 4
    # the piston flume's narrowest periodic width: 8 dx at h = 1.5 dx, 7 dx at 1.3 (skin 0.6 dx)
    assert Resolution(0.02, 1.5).narrowest_period(0.6) == 8 * 0.02
    assert Resolution(0.02, 1.3).narrowest_period(0.6) == 7 * 0.02


@pytest.mark.parametrize("field, kwargs", [("dx", dict(dx=0.0)), ("dx", dict(dx=float("nan"))),
                                           ("h_factor", dict(dx=0.02, h_factor=-1.0)),
                                           ("h_factor", dict(dx=0.02, h_factor="1.3"))])
def test_resolution_refuses_by_name(field, kwargs):
    with pytest.raises(ValueError, match=rf"^{field} must be a positive finite number"):
        Resolution(**kwargs)


def test_particle_layout_is_typed():
    import numpy as np

    from rockjax.scenes.base import ParticleLayout, Resolution, lattice, particle_layout, tank_walls
    from rockjax.sph.schemes import WCSPH

    res = Resolution(0.05, 1.3)
    fluid = lattice([0, 0, 0], [0.3, 0.3, 0.2], res.dx)
    walls = tank_walls([0, 0, 0], [0.3, 0.3, 0.4], res.dx, res.wall_layers)
    pad = res.wall_layers * res.dx
    L = particle_layout(res, fluid_x=fluid, wall_x=walls, domain_lo=[-pad] * 3, domain_hi=[0.3 + pad, 0.3 + pad, 0.6],
                        periodic=(False, False, False), surface_z=0.2, c0=20.0, scheme=WCSPH(), skin_factor=0.3)
    assert isinstance(L, ParticleLayout)
    assert L.cutoff == res.support and L.skin == 0.3 * res.dx
    assert L.x.shape == (len(fluid) + len(walls), 3) and L.kind.shape == L.vol.shape == L.rho.shape == (len(L.x),)
    assert np.all(L.rho[: len(fluid)] >= 1000.0)  # hydrostatic below the surface
    assert min(L.neighbour_capacity, L.cell_capacity, L.wall_pair_capacity) > 0


def test_scene_meta_reads_as_the_dict_it_replaced():
    import json

    from rockjax.io.hdf5 import _jsonable
    from rockjax.scenes.meta import Gauges, RunupSlope, SceneMeta

    d = dict(water_depth=0.3, still_level=0.3, runup_slope=dict(point=[1.0, 0.2, 0.0], normal=[0.0, 0.0, 1.0], x_min=None),
             gauges=dict(names=["a"], xy=[[0.5, 0.2]], bottom_z=[0.0]), name="s", dx=0.02)
    m = SceneMeta.from_dict(d)
    assert m.name == "s" and m.dx == 0.02 and m.still_level == 0.3 and m.extra == {"water_depth": 0.3}
    assert isinstance(m.gauges, Gauges) and m.gauges.xy == [[0.5, 0.2]] and isinstance(m.runup_slope, RunupSlope)
    assert list(m) == list(d) and m == d and m.as_dict() == d and dict(m)["gauges"] == d["gauges"]
    assert m["gauges"]["names"] == ["a"] and m.get("runup_slope").get("x_min") is None and "depth" not in m
    assert json.dumps(_jsonable(m)) == json.dumps(_jsonable(d))
    m2 = m.with_items(scene_file="f.toml")
    assert list(m2)[-1] == "scene_file" and m2["scene_file"] == "f.toml" and "scene_file" not in m
    bare = SceneMeta.from_dict(dict(name="b", dx=None))
    assert "gauges" not in bare and "still_level" not in bare and bare.get("gauges") is None and list(bare) == ["name", "dx"]
    with pytest.raises(ValueError, match="gauges"):
        SceneMeta.from_dict(dict(gauges=dict(names=["a"], where=[0, 0])))


def test_scenes_carry_scene_meta():
    from rockjax.scenes import SceneMeta, hydrostatic_tank

    scene = hydrostatic_tank(dx=0.04)
    assert isinstance(scene.meta, SceneMeta) and scene.name == "hydrostatic_tank" and scene.meta.dx == 0.04
    assert scene.meta.extra["depth"] == 0.2 and list(scene.meta)[-2:] == ["name", "dx"]
    plain = scene.replace(meta=dict(scene.meta, note=1))  # a dict is converted
    assert isinstance(plain.meta, SceneMeta) and plain.meta.extra["note"] == 1


def test_scene_file_parses_to_a_typed_spec_then_builds():
    import numpy as np

    from rockjax.scenes import scenefile as sf
    from rockjax.types import Coupling

    source, text, base = sf._read("examples/box_off_ramp.toml")
    spec = sf.parse(sf._Ctx(source, text, base), sf._parse(source, text), {"dx": 0.05})
    assert isinstance(spec, sf.SceneSpec) and spec.name == "box_off_ramp" and spec.sph.dx == 0.05
    assert isinstance(spec.domain, sf.DomainSpec) and spec.coupling.method == Coupling.PENALTY
    assert [f.name for f in spec.fixed] == ["ramp", "beach", "floor"] and len(spec.moving) == 1
    assert [g.name for g in spec.gauges] == ["near", "far"] and spec.runup.x_min == 1.7
    scene, loaded = sf.build(spec), sf.load("examples/box_off_ramp.toml", dx=0.05).scene
    assert scene.config == loaded.config and np.array_equal(scene.state.particles.x, loaded.state.particles.x)
