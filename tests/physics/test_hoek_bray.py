"""A block on an inclined plane (blocks only, 3D-DDA) fails in the mode the Hoek & Bray criteria
give (``validation.hoek_bray_regime``): it slides when the dip exceeds the friction angle, at the
closed-form acceleration g (sin dip - cos dip tan phi), and topples when base / height < tan(dip);
stable otherwise."""

import math

import numpy as np
import pytest

import rockjax as rj
from rockjax.blocks import quat_matrix
from rockjax.validation import hoek_bray_regime

T_END = 0.25  # s

CASES = [  # dip, friction angle, base (along the dip), height: the four regimes
    (30.0, 20.0, 0.2, 0.1),
    (20.0, 35.0, 0.04, 0.2),
    (20.0, 35.0, 0.2, 0.1),
    (35.0, 20.0, 0.04, 0.2),
]


def run(dip, phi, b, h):
    scene = rj.scenes.block_on_incline(angle_deg=dip, friction_angle_deg=phi, block_size=(b, 0.1, h))
    res = rj.simulate(scene, t_end=T_END, frame_dt=T_END / 5, progress=False)
    x0 = np.asarray(scene.state.blocks.x)[0]
    x1 = np.asarray(res.state.blocks.x)[0]
    th = math.radians(dip)
    down = np.array([math.cos(th), 0.0, -math.sin(th)])
    q = np.asarray(res.state.blocks.q)[0]
    R = np.asarray(quat_matrix(q))
    tilt = math.degrees(math.atan2(R[0, 2] - R[2, 0], R[0, 0] + R[2, 2]))  # signed rotation about y
    return float((x1 - x0) @ down), tilt


@pytest.mark.parametrize("dip, phi, b, h", CASES)
def test_block_on_a_plane_fails_as_hoek_and_bray_predict(dip, phi, b, h):
    regime = hoek_bray_regime(plane_dip_deg=dip, friction_angle_deg=phi, base=b, height=h)
    slide, tilt = run(dip, phi, b, h)
    th, ph = math.radians(dip), math.radians(phi)
    a = 9.81 * (math.sin(th) - math.cos(th) * math.tan(ph))
    if regime == "sliding":
        # the closed form of a sliding block: s = a t^2 / 2; no rotation
        assert slide == pytest.approx(0.5 * a * T_END**2, rel=0.01)
        assert abs(tilt) < 0.5
    elif regime == "toppling":
        assert abs(tilt) > 10.0, tilt  # rotating about its lower edge
    elif regime == "stable":
        assert abs(slide) < 1e-4 and abs(tilt) < 0.1
    else:
        assert abs(tilt) > 10.0 and slide > 0.25 * 0.5 * a * T_END**2
