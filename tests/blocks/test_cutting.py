"""Block cutting from joint sets (``rockjax.blocks.cutting``): volumes add up to the domain's,
counts of regular sets match the closed form, every block is a closed convex polyhedron with
outward faces, sets at 90 degrees give the expected prisms, bad inputs are refused."""

import math

import numpy as np
import pytest
import trimesh

from rockjax.blocks import Motion, initial_overlaps, make_blocks, slope
from rockjax.blocks.cutting import JointSet, cut, joint_normal

OBLIQUE = [JointSet(60, 30, 0.17, offset=0.05), JointSet(80, 200, 0.23), JointSet(20, 110, 0.19, jitter=0.3, seed=3)]


def assert_closed_convex_outward(p, rel=1e-10):
    V, E, F = p.n_vertices, len(p.edges), p.n_faces
    assert V - E + F == 2  # one closed genus-0 surface
    size = 2 * p.bounding_radius
    # every vertex on the inner side of every face plane: convex
    assert np.all(p.vertices @ p.face_normal.T <= p.face_offset + rel * size)
    # outward: the centroid (the body origin) is inside every face plane by a finite margin
    assert np.all(p.face_offset > 1e-6 * size)
    # each face's vertices lie on its plane
    for f in range(F):
        verts = p.vertices[p.he_vert[p.he_face == f]]
        np.testing.assert_allclose(verts @ p.face_normal[f], p.face_offset[f], atol=rel * size)


def test_orthogonal_sets_give_the_closed_form_count_of_equal_boxes():
    rock = cut(((0, 0, 0), (1, 1, 1)), [JointSet(90, 90, 0.25), JointSet(90, 0, 0.5), JointSet(0, 0, 1 / 3)])
    assert rock.n_blocks == 4 * 2 * 3 and rock.dropped == 0
    np.testing.assert_allclose(rock.volumes, 1 / 24, rtol=1e-12)
    for p in rock.polyhedra:
        assert p.n_faces == 6 and p.n_vertices == 8
        np.testing.assert_allclose(np.ptp(p.vertices, axis=0), [0.25, 0.5, 1 / 3], rtol=1e-12)
    # the layers' count for a set alone: ceil(H / s) (offset 0 at the box's base)
    for s in (0.3, 0.25, 0.4):
        assert cut(((0, 0, 0), (2, 1, 1)), [JointSet(0, 0, s)]).n_blocks == math.ceil(1 / s - 1e-12)


def test_oblique_jittered_sets_conserve_volume_and_give_convex_blocks():
    domain = ((0, 0, 0), (2.0, 1.0, 1.0))
    rock = cut(domain, OBLIQUE)
    assert rock.n_blocks > 100
    total = rock.volumes.sum() + rock.dropped_volume
    assert abs(total / rock.domain_volume - 1) < 1e-9 and rock.domain_volume == pytest.approx(2.0, rel=1e-12)
    assert rock.dropped_volume / rock.domain_volume < 1e-4  # the slivers are small
    assert np.all(rock.volumes >= 1e-3 * 0.17**3)
    for p in rock.polyhedra:
        assert_closed_convex_outward(p)
    # blocks tile the domain without overlapping (touching faces only, to round-off)
    assert all(depth < 1e-9 for _, _, depth in initial_overlaps(rock.polyhedra, rock.positions))
    # the jitter is seeded: the same seed cuts the same blocks, another seed others
    again = cut(domain, OBLIQUE)
    np.testing.assert_array_equal(again.volumes, rock.volumes)
    other = cut(domain, OBLIQUE[:2] + [JointSet(20, 110, 0.19, jitter=0.3, seed=4)])
    assert other.n_blocks != rock.n_blocks or not np.array_equal(other.volumes, rock.volumes)
    sizes = rock.size_distribution()
    assert sizes["blocks"] == rock.n_blocks and sizes["d10_m"] < sizes["d50_m"] < sizes["d90_m"]


def test_two_sets_at_90_degrees_give_prisms():
    # vertical sets striking N-S and E-W: square columns the box's height
    rock = cut(((0, 0, 0), (1.0, 0.6, 0.7)), [JointSet(90, 90, 0.2), JointSet(90, 0, 0.2)])
    assert rock.n_blocks == 5 * 3
    for p in rock.polyhedra:
        assert p.n_faces == 6
        np.testing.assert_allclose(np.ptp(p.vertices, axis=0), [0.2, 0.2, 0.7], rtol=1e-12)
    # inclined sets dipping 45 degrees east and west (normals at 90 degrees): prisms along y whose
    # cross-section is an s x s square turned 45 degrees, where they do not reach the box's faces
    s, W = 0.2, 0.5
    n1, n2 = joint_normal(45, 90), joint_normal(45, 270)
    assert abs(n1 @ n2) < 1e-12
    rock = cut(((0, 0, 0), (2.0, W, 1.0)), [JointSet(45, 90, s), JointSet(45, 270, s)])
    inner = [p for p, x in zip(rock.polyhedra, rock.positions)
             if np.all((p.vertices + x)[:, [0, 2]].min(axis=0) > 1e-9)
             and (p.vertices + x)[:, 0].max() < 2 - 1e-9 and (p.vertices + x)[:, 2].max() < 1 - 1e-9]
    assert len(inner) >= 5
    for p in inner:
        assert p.n_faces == 6 and p.n_vertices == 8
        assert p.volume == pytest.approx(s * s * W, rel=1e-12)
        np.testing.assert_allclose(np.ptp(p.vertices[:, 1]), W, rtol=1e-12)


def test_convex_parts_meshes_and_make_blocks():
    # a slope (an inclined slab) and its toe as two convex parts; a convex mesh alike
    part = slope(2.0, 1.0, 0.5, 30.0)
    toe = ((2.0, -0.5, -0.5), (3.0, 0.5, 0.0))
    rock = cut([part, toe], [JointSet(30, 90, 0.25), JointSet(85, 270, 0.3)])
    assert abs((rock.volumes.sum() + rock.dropped_volume) / (part.volume + 0.5) - 1) < 1e-9
    mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))  # centred: planes at z = -0.25, 0.25
    np.testing.assert_allclose(sorted(cut(mesh, [JointSet(0, 0, 0.5, offset=0.25)]).volumes), [0.25, 0.25, 0.5],
                               rtol=1e-12)
    # the blocks build as they are (touching faces are not an overlap) ...
    cfg, _, st = make_blocks(list(rock.polyhedra), positions=rock.positions, motion=[Motion.DYNAMIC] * rock.n_blocks)
    assert cfg.n_blocks == rock.n_blocks
    np.testing.assert_allclose(np.asarray(st.x), rock.positions, atol=1e-6)


@pytest.mark.parametrize("call, pattern", [
    (lambda: JointSet(95, 0, 0.1), r"JointSet\.dip_deg"),
    (lambda: JointSet(30, 0, 0.0), r"JointSet\.spacing must be a positive"),
    (lambda: JointSet(30, 0, 0.1, jitter=1.0), r"JointSet\.jitter"),
    (lambda: JointSet(30, 0, math.nan), r"JointSet\.spacing"),
    (lambda: cut(((0, 0, 0), (1, -1, 1)), [JointSet(0, 0, 0.1)]), r"domain: a box"),
    (lambda: cut(trimesh.creation.annulus(0.2, 0.5, 0.3), [JointSet(0, 0, 0.1)]), r"domain: the mesh is not"),
    (lambda: cut(((0, 0, 0), (1, 1, 1)), [(30, 0, 0.1)]), r"joint_sets\[0\] is tuple"),
    (lambda: cut(((0, 0, 0), (1, 1, 1)), [JointSet(0, 0, 0.1)], min_volume=-1.0), r"min_volume"),
])
def test_bad_inputs_are_refused(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()
