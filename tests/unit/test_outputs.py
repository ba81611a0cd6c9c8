"""Results out: the XDMF sidecars (read back with meshio, a reader independent of rockjax),
the PNG figures of ``rockjax.plots`` and the driver's progress bar.

One tiny coupled run (the sliding wedge at dx = 0.05 m: 2192 fluid + 10004 wall particles,
3 blocks, 6 frames of 0.0097 s) is shared by the module.
"""

import argparse
import re
import shutil

import h5py
import numpy as np
import pytest
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

import rockjax as rj
from rockjax.io.xdmf import write_xdmf
from rockjax.observables import scene_observer

meshio = pytest.importorskip("meshio")
pytest.importorskip("matplotlib")

FRAME_DT = 0.01
T_END = 0.05


@pytest.fixture(scope="module")
def scene():
    return rj.scenes.sliding_wedge(dx=0.05)


@pytest.fixture(scope="module")
def run(scene, tmp_path_factory):
    """The run file, its XDMF files, and the ``Result``."""
    d = tmp_path_factory.mktemp("run")
    h5 = d / "wedge.h5"
    result = rj.simulate(scene, t_end=T_END, frame_dt=FRAME_DT, out=str(h5), observe=scene_observer(scene.meta),
                         progress=False)
    files = write_xdmf(h5)
    return h5, files, result


def _frames(path):
    """Every frame of an XDMF time series as meshio reads it: (t, points, cells, point_data, cell_data).

    meshio's TimeSeriesReader assumes a mesh fixed in time (it reads Geometry/Topology once, from
    the first grid); our points move, so its ``mesh_grid`` is pointed at each frame's grid in
    turn, and meshio itself parses that grid's Geometry and Topology items."""
    out = []
    with meshio.xdmf.TimeSeriesReader(str(path)) as reader:
        for k in range(reader.num_steps):
            reader.mesh_grid = reader.collection[k]
            points, cells = reader.read_points_cells()
            t, point_data, cell_data = reader.read_data(k)
            out.append((t, points, cells, point_data, cell_data))
    return out


def test_xdmf_particles_read_by_meshio(run, tmp_path):
    h5, files, result = run
    assert [p.name for p in files] == ["wedge.xdmf", "wedge_blocks.xdmf"]
    # the pair (h5 + xdmf) still reads after being moved together (virtual datasets point at ".")
    moved = tmp_path / "moved"
    moved.mkdir()
    for p in (h5, files[0]):
        shutil.copy(p, moved / p.name)
    for path in (files[0], moved / files[0].name):
        frames = _frames(path)
        with h5py.File(h5, "r") as f:
            F, N = f["x"].shape[:2]
            assert len(frames) == F == len(result.times) >= 5
            for k, (t, points, cells, pd, cd) in enumerate(frames):
                assert t == pytest.approx(f["time"][k], rel=1e-15, abs=0)
                # exact: the reader returns the stored float32 values themselves
                np.testing.assert_array_equal(points, f["x"][k])
                np.testing.assert_array_equal(pd["v"], f["v"][k])
                np.testing.assert_array_equal(pd["rho"], f["rho"][k])
                np.testing.assert_array_equal(pd["p"], f["p"][k])
                np.testing.assert_array_equal(pd["kind"], f["kind"][()])
                assert [c.type for c in cells] == ["vertex"] and len(cells[0].data) == N
                # no copy of particle data: each frame is a view of /x
                assert f[f"xdmf/frames/x/{k:06d}"].is_virtual
    # and the frames are those the driver produced (not all equal to frame 0)
    assert not np.array_equal(frames[0][1], frames[-1][1])


def _expected_block_vertices(f, k):
    """World vertices of frame k, block after block (real vertices only), from scipy's Rotation."""
    verts = f["blocks/vertices"][()].astype(np.float64)
    mask = f["blocks/vertex_mask"][()]
    q = f["block_q"][k].astype(np.float64)
    x = f["block_x"][k].astype(np.float64)
    rows = []
    for b in range(verts.shape[0]):
        R = Rotation.from_quat(q[b], scalar_first=True)  # (w, x, y, z), normalised by scipy
        rows.append(R.apply(verts[b][mask[b]]) + x[b])
    return np.concatenate(rows)


def test_xdmf_blocks_read_by_meshio(run):
    h5, files, _ = run
    frames = _frames(files[1])
    with h5py.File(h5, "r") as f:
        F = f["time"].shape[0]
        assert len(frames) == F
        verts = f["blocks/vertices"][()].astype(np.float64)
        mask = f["blocks/vertex_mask"][()]
        B = verts.shape[0]
        moved = 0.0
        for k, (t, points, cells, pd, cd) in enumerate(frames):
            assert t == pytest.approx(f["time"][k], rel=1e-15, abs=0)
            # float32 storage of coordinates below 3 m: rounding <= 1.2e-7 m; 1e-6 m leaves room for
            # the float32 quaternion being normalised in a different order
            np.testing.assert_allclose(points, _expected_block_vertices(f, k), rtol=0, atol=1e-6)
            moved = max(moved, float(np.abs(points - frames[0][1]).max()))
            assert [c.type for c in cells] == ["triangle"]
            tri = cells[0].data
            block = cd["block"][0]
            # each block's triangles form a closed, outward surface equal to the convex hull of its
            # body vertices (independently from scipy's Qhull): same area, same enclosed volume
            p = points.astype(np.float64)
            a, b_, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
            cross = np.cross(b_ - a, c - a)
            start = 0
            for b in range(B):
                nv = int(mask[b].sum())
                sel = block == b
                assert np.all((tri[sel] >= start) & (tri[sel] < start + nv)), f"block {b} triangle uses another block"
                hull = ConvexHull(verts[b][mask[b]])
                area = 0.5 * np.linalg.norm(cross[sel], axis=1).sum()
                centre = p[start:start + nv].mean(axis=0)
                volume = np.einsum("ij,ij->i", a[sel] - centre, cross[sel]).sum() / 6.0
                # float32 coordinates: relative error ~1e-6; 1e-5 is ten times that
                assert area == pytest.approx(hull.area, rel=1e-5), (k, b)
                assert volume == pytest.approx(hull.volume, rel=1e-5), (k, b)  # > 0: outward faces
                start += nv
            assert start == len(points)
    assert moved > 1e-4  # the wedge moved between the first and the last frame (m)


def test_hdf5_read_ignores_xdmf_group(run):
    h5, _, result = run
    back = rj.io.read(str(h5))
    assert "xdmf" not in back.frames
    np.testing.assert_array_equal(back.x[-1], np.asarray(result.state.particles.x)[np.argsort(
        np.asarray(result.state.particles.pid))])


def test_write_xdmf_refuses_bad_input(tmp_path, run):
    with pytest.raises(ValueError, match="h5_path"):
        write_xdmf(tmp_path / "missing.h5")
    with pytest.raises(ValueError, match="xdmf_path"):
        write_xdmf(run[0], tmp_path / "out.txt")
    empty = tmp_path / "empty.h5"
    with h5py.File(empty, "w") as f:
        f.create_dataset("time", shape=(0,), dtype="f8")
    with pytest.raises(ValueError, match="no frames"):
        write_xdmf(empty)


def _check_png(path):
    import matplotlib.image as mpimg

    img = mpimg.imread(path)  # raises on a file that is not a PNG
    assert img.ndim == 3 and img.shape[0] >= 300 and img.shape[1] >= 500
    rgb = (img[..., :3] * 255).round().astype(np.uint8).reshape(-1, 3)
    colours = np.unique(rgb, axis=0)
    not_white = np.mean(np.any(rgb < 250, axis=1))
    saturated = np.ptp(rgb.astype(int), axis=1) > 60  # coloured (not grey) pixels: the data lines
    # measured on an empty 7x4 in axes with a title and labels (anti-aliased text): 248 colours,
    # 2.4 % non-white, 0 coloured pixels; the four figures of the wedge run: 504-1985 colours,
    # 6.2-9.0 % non-white, 2365-6709 coloured pixels. The coloured-pixel count is what tells a
    # figure with data from empty axes.
    assert len(colours) > 300, (path.name, len(colours))
    assert not_white > 0.04, (path.name, not_white)
    assert saturated.sum() > 500, (path.name, int(saturated.sum()))


def test_plot_run_writes_four_figures(run, tmp_path):
    from rockjax.plots import plot_run

    h5 = run[0]
    written = plot_run(h5, tmp_path / "figs")
    assert [p.name for p in written] == [f"wedge_{n}.png" for n in ("gauges", "runup", "blocks", "energy")]
    for p in written:
        _check_png(p)


def test_plot_skips_absent_data_and_cli_main(run, tmp_path, capsys):
    from rockjax import plots

    bare = tmp_path / "bare.h5"
    shutil.copy(run[0], bare)
    with h5py.File(bare, "a") as f:
        del f["observed"]
    written, skipped = plots.plot_run_report(bare)
    assert [p.name for p in written] == ["bare_blocks.png"] and written[0].parent == tmp_path
    assert set(skipped) == {"gauges", "runup", "energy"} and "observed" in skipped["gauges"]
    capsys.readouterr()
    assert plots.main(argparse.Namespace(run=str(bare), out_dir=None)) == 0
    out, err = capsys.readouterr()
    assert "bare_blocks.png" in out and "skipped gauges" in err
    assert plots.main(argparse.Namespace(run=str(tmp_path / "nope.h5"), out_dir=None)) == 2
    assert "does not exist" in capsys.readouterr().err


def test_progress_bar_shows_eta_and_is_quiet_off_terminal(scene, run, capsys):
    # same config and frame cadence as the fixture: the compiled chunk is reused
    capsys.readouterr()
    rj.simulate(scene, t_end=FRAME_DT, frame_dt=FRAME_DT, progress=None)  # stderr is captured: not a terminal
    assert capsys.readouterr().err == ""
    rj.simulate(scene, t_end=FRAME_DT, frame_dt=FRAME_DT, progress=True)
    err = capsys.readouterr().err
    assert re.search(r"\d\d:\d\d<\d\d:\d\d", err), err  # elapsed<remaining (ETA)
    assert "frame" in err and "steps/s=" in err and "t=" in err


def test_write_xdmf_fluid_only_blocks_only_and_rewrite(run, tmp_path):
    h5 = run[0]
    fluid, rocks = tmp_path / "fluid.h5", tmp_path / "rocks.h5"
    shutil.copy(h5, fluid)
    shutil.copy(h5, rocks)
    with h5py.File(fluid, "a") as f:
        del f["blocks"]
    with h5py.File(rocks, "a") as f:
        for name in ("x", "v", "rho", "p", "kind"):
            del f[name]
    assert [p.name for p in write_xdmf(fluid)] == ["fluid.xdmf"]
    assert [p.name for p in write_xdmf(rocks, tmp_path / "r.xdmf")] == ["r_blocks.xdmf"]
    # writing again replaces the /xdmf group and gives the same reading
    first = _frames(tmp_path / "r_blocks.xdmf")
    write_xdmf(rocks, tmp_path / "r.xdmf")
    for a, b in zip(first, _frames(tmp_path / "r_blocks.xdmf")):
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_array_equal(a[2][0].data, b[2][0].data)
