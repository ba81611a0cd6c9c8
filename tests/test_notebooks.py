"""Execute every notebook in ``notebooks/`` with nbclient, failing on any cell error.

The notebooks are found by listing ``notebooks/*.ipynb``, so a new notebook is tested without
touching this file. Each runs in a fresh kernel, the ``python3`` kernelspec of this interpreter's
environment (``sys.prefix/share/jupyter/kernels/python3``, installed by ipykernel; jupyter_client
starts it with ``sys.executable``), in a temporary working directory: nothing is written into the
repository, and the executed copy goes to pytest's ``tmp_path``.

Environment of the kernel: ``ROCKJAX_NB_FAST=1`` (the notebooks' tiny CI resolution) unless set
already, and the same persistent JAX compilation cache as ``tests/conftest.py``
(``ROCKJAX_JAX_CACHE`` or ``.jax_cache/``), so a second run skips most of the compile.

A notebook whose metadata has ``"rockjax": {"slow": true}`` runs only in the slow set
(``pytest -m slow``). Per-cell timeout: ``ROCKJAX_NB_TIMEOUT`` seconds (default 900; a loaded
2-core machine compiles several times slower than a quiet one).
"""

from __future__ import annotations

import os
import pathlib
import sys

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

ROOT = pathlib.Path(__file__).resolve().parents[1]
NB_DIR = ROOT / "notebooks"
NOTEBOOKS = sorted(NB_DIR.glob("*.ipynb"))
KERNEL = "python3"


def _params():
    out = []
    for path in NOTEBOOKS:
        meta = nbformat.read(str(path), as_version=4).metadata.get("rockjax", {})
        marks = [pytest.mark.slow] if meta.get("slow") else []
        out.append(pytest.param(path, id=path.stem, marks=marks))
    return out


@pytest.fixture
def kernel_env(monkeypatch):
    """The kernel inherits this process's environment: the FAST switch and the compile cache."""
    if "ROCKJAX_NB_FAST" not in os.environ:
        monkeypatch.setenv("ROCKJAX_NB_FAST", "1")
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", os.environ.get("ROCKJAX_JAX_CACHE", str(ROOT / ".jax_cache")))
    monkeypatch.setenv("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")


def _run(nb, cwd: pathlib.Path, timeout: int):
    client = nbclient.NotebookClient(nb, kernel_name=KERNEL, timeout=timeout, allow_errors=False,
                                     resources={"metadata": {"path": str(cwd)}})
    return client.execute()


def test_notebooks_found_and_committed_without_outputs():
    assert NOTEBOOKS, f"no notebooks in {NB_DIR}"
    for path in NOTEBOOKS:
        nb = nbformat.read(str(path), as_version=4)
        nbformat.validate(nb)
        dirty = [i for i, c in enumerate(nb.cells)
                 if c.cell_type == "code" and (c.get("outputs") or c.get("execution_count") is not None)]
        assert not dirty, f"{path.name}: cells {dirty} carry outputs; rerun notebooks/make_notebooks.py"
        first_code = next(c.source for c in nb.cells if c.cell_type == "code")
        assert 'os.environ.get("ROCKJAX_NB_FAST", "1") == "1"' in first_code, \
            f"{path.name}: the first code cell must read the ROCKJAX_NB_FAST switch"


def test_kernel_is_this_environment(tmp_path, kernel_env):
    """The python3 kernelspec found is this environment's, and the kernel runs this interpreter."""
    from jupyter_client.kernelspec import KernelSpecManager

    spec_dir = pathlib.Path(KernelSpecManager().find_kernel_specs()[KERNEL]).resolve()
    assert spec_dir.is_relative_to(pathlib.Path(sys.prefix).resolve()), \
        f"kernelspec {KERNEL!r} found at {spec_dir}, outside {sys.prefix}: install ipykernel into this environment"
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(
        "import os, sys; print(sys.executable); print(os.environ['ROCKJAX_NB_FAST'])")])
    out = _run(nb, tmp_path, 120)
    text = "".join(o.get("text", "") for o in out.cells[0].outputs).split()
    assert pathlib.Path(text[0]).resolve() == pathlib.Path(sys.executable).resolve(), text
    assert text[1] == os.environ["ROCKJAX_NB_FAST"]


@pytest.mark.parametrize("path", _params())
def test_notebook_runs(path, tmp_path, kernel_env):
    nb = nbformat.read(str(path), as_version=4)
    timeout = int(os.environ.get("ROCKJAX_NB_TIMEOUT", "900"))
    try:
        _run(nb, tmp_path, timeout)
    finally:
        nbformat.write(nb, str(tmp_path / path.name))  # the executed copy, for a failure's post-mortem
    assert not list(NB_DIR.glob("*.nbconvert.ipynb"))
