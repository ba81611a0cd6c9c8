"""The scene builders' typed hand-overs (``rockjax.scenes.base``): ``Resolution`` decides h, the
kernel support and the wall layers from dx and h_factor, and refuses bad values by name."""

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
