"""Checkpoint and resume: a resumed run is the uninterrupted run bit for bit (float32 and float64,
after a buffer regrow); a process killed mid-write (SIGKILL in a frame, in a checkpoint) leaves a
file that opens and resumes; Ctrl-C writes a checkpoint (``Interrupted``, CLI exit 130); a failed
write keeps the frames so far; a resume of another scene is refused naming the field."""

import errno
import os
import pathlib
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import jax
import numpy as np
import pytest

import rockjax as rj
from rockjax import driver

ROOT = pathlib.Path(__file__).resolve().parents[2]
CACHE = os.environ.get("ROCKJAX_JAX_CACHE", str(ROOT / ".jax_cache"))

#: a collapsing column (the list is rebuilt, particles re-sorted) with a neighbour buffer too small
#: for it, so the run regrows at its start: a resume must rebuild the grown config
SCENE = ("rj.scenes.dam_break(dx=0.1, column_length=0.3, column_width=0.3, column_height=0.5, tank_length=0.8, "
         "tank_width=0.3)")
FRAME_DT = 0.01
N_FRAMES = 6


def make_scene():
    scene = eval(SCENE)
    return scene.replace(config=scene.config.grown(neighbours=16))


def leaves_equal(a, b):
    la, lb = jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b)
    assert len(la) == len(lb)
    for x, y in zip(la, lb):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def file_frames(path):
    run = rj.io.read(str(path))
    return run, {k: v for k, v in run.frames.items()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted float32 run (file and Result)."""
    path = tmp_path_factory.mktemp("ref") / "ref.h5"
    res = rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, frame_dt=FRAME_DT, out=str(path), progress=False)
    assert res.stats["regrows"] >= 1  # the case "after a buffer regrow" is exercised
    return path, res


def assert_same_run(path, res, ref_path, ref_res):
    leaves_equal(res.state, ref_res.state)
    run, frames = file_frames(path)
    ref_run, ref_frames = file_frames(ref_path)
    np.testing.assert_array_equal(run.time, ref_run.time)
    assert sorted(frames) == sorted(ref_frames)
    for k in frames:
        np.testing.assert_array_equal(frames[k], ref_frames[k], err_msg=k)
    np.testing.assert_array_equal(res.times, ref_res.times)
    assert res.scene.config == ref_res.scene.config


def test_extend_a_finished_run_is_bit_identical(reference, tmp_path):
    ref_path, ref_res = reference
    path = tmp_path / "b.h5"
    first = rj.simulate(make_scene(), t_end=3 * FRAME_DT, frame_dt=FRAME_DT, out=str(path), progress=False)
    assert len(first.times) == 4 and first.stats["regrows"] >= 1
    res = rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, resume=str(path), progress=False)
    assert res.stats["steps"] == ref_res.stats["steps"] and res.stats["regrows"] == ref_res.stats["regrows"]
    assert float(np.max(np.abs(np.asarray(res.state.particles.v)))) > 0.3  # the column is collapsing
    assert_same_run(path, res, ref_path, ref_res)


def test_ctrl_c_writes_a_checkpoint_and_resumes_bit_identical(reference, tmp_path, monkeypatch):
    ref_path, ref_res = reference
    path = tmp_path / "c.h5"
    real = driver._compiled_chunk
    calls = []

    def interrupting(config, n_steps, period):
        fn = real(config, n_steps, period)

        def run(state, params):
            calls.append(1)
            if len(calls) == 4:
                raise KeyboardInterrupt
            return fn(state, params)

        return run

    monkeypatch.setattr(driver, "_compiled_chunk", interrupting)
    with pytest.raises(rj.Interrupted) as info:
        rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, frame_dt=FRAME_DT, out=str(path), progress=False)
    assert info.value.frame == 3 and "resume" in str(info.value)
    assert isinstance(info.value, KeyboardInterrupt)
    monkeypatch.setattr(driver, "_compiled_chunk", real)
    assert rj.io.hdf5.read_checkpoint(str(path)).frame == 3
    assert len(rj.io.read(str(path)).time) == 4
    res = rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, resume=str(path), progress=False)
    assert_same_run(path, res, ref_path, ref_res)


def test_a_failed_write_keeps_the_frames_so_far(reference, tmp_path, monkeypatch):
    """Disk full mid-frame: an OSError naming the frame; the frames before it read back intact."""
    ref_path, _ = reference
    path = tmp_path / "full.h5"
    real = h5py.Dataset.__setitem__
    writes = []

    def full_disk(self, key, value):
        if self.name == "/time" and key == 3:
            writes.append(1)
        if writes and self.name == "/x":
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, key, value)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", full_disk)
    with pytest.raises(OSError, match=r"writing frame 3 .* the 3 frames written before it are kept") as info:
        rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, frame_dt=FRAME_DT, out=str(path), progress=False)
    assert info.value.errno == errno.ENOSPC
    monkeypatch.setattr(h5py.Dataset, "__setitem__", real)
    run, frames = file_frames(path)
    _, ref_frames = file_frames(ref_path)
    with h5py.File(path, "r") as f:
        assert f["time"].shape[0] == 4  # the torn frame is in the file ...
    assert len(run.time) == 3  # ... and not read
    for k in ("x", "v", "rho", "p"):
        np.testing.assert_array_equal(frames[k], ref_frames[k][:3])


KILLED = textwrap.dedent("""
    import os, signal, sys
    import h5py, jax
    jax.config.update("jax_compilation_cache_dir", {cache!r})
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
    import rockjax as rj
    from rockjax.io import hdf5

    mode, path = sys.argv[1], sys.argv[2]
    armed = []

    def arm(method, when):
        real = getattr(hdf5.Writer, method)

        def wrapped(self, *args, **kw):
            if when(self, *args):
                armed.append(0)
            return real(self, *args, **kw)

        setattr(hdf5.Writer, method, wrapped)

    def count(real):
        def wrapped(*args, **kw):
            if armed:
                armed[0] += 1
                if armed[0] == 3:  # the third array written in the armed call
                    os.kill(os.getpid(), signal.SIGKILL)
            return real(*args, **kw)
        return wrapped

    if mode == "frame":  # killed inside the 5th frame's append (frame 4), after /time and /status
        arm("append", lambda self, *a: self.n_frames == 4)
    else:  # killed inside the checkpoint after frame 4, the one after frame 2 complete
        arm("write_checkpoint", lambda self, frame, *a: frame == 4)
    h5py.Dataset.__setitem__ = count(h5py.Dataset.__setitem__)
    h5py.Group.create_dataset = count(h5py.Group.create_dataset)
    scene = {scene}
    scene = scene.replace(config=scene.config.grown(neighbours=16))
    rj.simulate(scene, t_end={t_end}, frame_dt={frame_dt}, out=path, progress=False, checkpoint_every=2)
    print("NOT KILLED")
""")


@pytest.mark.parametrize("mode", ["frame", "checkpoint"])
def test_killed_mid_write_opens_and_resumes(reference, tmp_path, mode):
    ref_path, ref_res = reference
    path = tmp_path / "k.h5"
    script = tmp_path / "killed.py"
    script.write_text(KILLED.format(cache=CACHE, scene=SCENE, t_end=N_FRAMES * FRAME_DT, frame_dt=FRAME_DT))
    proc = subprocess.run([sys.executable, str(script), mode, str(path)], capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == -signal.SIGKILL, proc.stdout + proc.stderr
    with h5py.File(path, "r") as f:
        n_complete = int(f.attrs["frames_complete"])
        groups = {k: int(g.attrs.get("complete", 0)) for k, g in f["checkpoints"].items()}
        if mode == "frame":
            assert n_complete == 4 and f["time"].shape[0] == 5  # one torn frame
            assert groups == {"c00000002": 1}
        else:
            assert n_complete == 5
            assert groups == {"c00000002": 1, "c00000004": 0}  # the torn one beside the complete one
    assert len(rj.io.read(str(path)).time) == n_complete
    assert rj.io.hdf5.read_checkpoint(str(path)).frame == 2
    res = rj.simulate(make_scene(), t_end=N_FRAMES * FRAME_DT, resume=str(path), progress=False)
    with h5py.File(path, "r") as f:
        assert list(f["checkpoints"]) == [f"c{N_FRAMES:08d}"]  # the torn one is gone
    assert_same_run(path, res, ref_path, ref_res)


def test_resume_refuses_another_scene(reference, tmp_path):
    ref_path, _ = reference
    path = tmp_path / "r.h5"
    path.write_bytes(pathlib.Path(ref_path).read_bytes())
    scene = make_scene()
    other = scene.replace(params=scene.params.replace(fluid=scene.params.fluid.replace(
        alpha=scene.params.fluid.alpha * 2)))
    with pytest.raises(ValueError, match=r"other params \(Params\.fluid\.alpha"):
        rj.simulate(other, t_end=0.1, resume=str(path), progress=False)
    with pytest.raises(ValueError, match=r"another config \(fields skin differ\)"):
        rj.simulate(scene.replace(config=scene.config.replace(skin=scene.config.skin * 0.9)), t_end=0.1,
                    resume=str(path), progress=False)
    with pytest.raises(ValueError, match="frame_dt: resume"):
        rj.simulate(scene, t_end=0.1, frame_dt=2 * FRAME_DT, resume=str(path), progress=False)
    with pytest.raises(ValueError, match="t_end = 0.02 s is before the checkpoint"):
        rj.simulate(scene, t_end=0.02, resume=str(path), progress=False)
    with pytest.raises(ValueError, match="out = .* differs from resume"):
        rj.simulate(scene, t_end=0.1, resume=str(path), out=str(tmp_path / "o.h5"), progress=False)
    with pytest.raises(ValueError, match="is not a file"):
        rj.simulate(scene, t_end=0.1, resume=str(tmp_path / "none.h5"), progress=False)
    with h5py.File(path, "a") as f:
        del f["checkpoints"]
    with pytest.raises(ValueError, match="holds no complete checkpoint"):
        rj.simulate(scene, t_end=0.1, resume=str(path), progress=False)
    with pytest.raises(ValueError, match="checkpoint_every must be a positive number of frames"):
        rj.simulate(scene, t_end=0.1, checkpoint_every=2, progress=False)


def test_float64_resume_is_bit_identical(tmp_path):
    old = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    try:
        kw = dict(t_end=4 * FRAME_DT, frame_dt=FRAME_DT, progress=False)
        ref = rj.simulate(make_scene(), out=str(tmp_path / "a.h5"), **kw)
        assert np.asarray(ref.state.particles.x).dtype == np.float64
        rj.simulate(make_scene(), out=str(tmp_path / "b.h5"), **dict(kw, t_end=2 * FRAME_DT))
        res = rj.simulate(make_scene(), resume=str(tmp_path / "b.h5"), **dict(kw, frame_dt=None))
        assert_same_run(tmp_path / "b.h5", res, tmp_path / "a.h5", ref)
    finally:
        jax.config.update("jax_enable_x64", old)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_cli_ctrl_c_exits_130_and_resumes(tmp_path, sig):
    """Ctrl-C (SIGINT; SIGTERM alike) stops the CLI at the next frame with a checkpoint, exit
    128 + signal, no traceback; ``--resume`` continues the file."""
    out = tmp_path / "cli.h5"
    env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=CACHE)
    cmd = [sys.executable, "-m", "rockjax.cli", "run", "dam_break", "--dx", "0.1", "--quiet"]
    proc = subprocess.Popen(cmd + ["--t-end", "5", "--out", str(out)], stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.time() + 600
    while not out.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.2)
    time.sleep(1.0)
    proc.send_signal(sig)
    err = proc.communicate(timeout=600)[1]
    assert proc.returncode == 128 + sig, err
    assert "checkpoint written" in err and "--resume" in err and "Traceback" not in err
    frame = rj.io.hdf5.read_checkpoint(str(out)).frame
    run = rj.io.read(str(out))
    assert len(run.time) == frame + 1
    t_end = run.time[1] * (frame + 2)  # two frames more
    done = subprocess.run(cmd + ["--t-end", f"{t_end:.9g}", "--resume", str(out)], capture_output=True, text=True,
                          env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    run = rj.io.read(str(out))
    assert len(run.time) == frame + 3
    np.testing.assert_allclose(np.diff(run.time), run.time[1], rtol=1e-9)
