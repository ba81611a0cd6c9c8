"""Shared test set-up: a persistent compilation cache (compiles are slow on 2 cores), unoptimised
compiles for the default suite, and the ``x64`` fixture: float64 for a test module (build scenes
after it; the previous setting is restored afterwards)."""

import os
import pathlib

import jax
import pytest

_cache = pathlib.Path(__file__).resolve().parents[1] / ".jax_cache"
jax.config.update("jax_compilation_cache_dir", os.environ.get("ROCKJAX_JAX_CACHE", str(_cache)))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


#: the default suite's mark expression (pyproject's addopts)
DEFAULT_MARKS = "not slow and not stress"


def pytest_configure(config):
    """The default suite compiles with XLA's expensive passes off (``jax_disable_most_optimizations``).

    Its tests are many small programs run a few times each: most of its time is compiling, and
    unoptimised compiles took 303 s where optimised ones took 521 s (two compile-heavy files, cold
    cache, 2026-11-27). The slow and stress suites (long runs) keep optimised compiles, and so
    does any run with ``ROCKJAX_TEST_OPTIMIZE=1``. The flag is part of the compilation cache key.
    The tests hold under both: none may depend on how a compile rounds (an unoptimised compile
    found the FCP tie that made a blocks gradient depend on it, fixed in ``blocks.fcp``).
    """
    if config.option.markexpr == DEFAULT_MARKS and os.environ.get("ROCKJAX_TEST_OPTIMIZE", "0") != "1":
        jax.config.update("jax_disable_most_optimizations", True)


@pytest.fixture(scope="module")
def x64():
    old = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)
