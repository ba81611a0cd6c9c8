"""Shared test set-up: a persistent compilation cache (compiles are slow on 2 cores), and the
``x64`` fixture: float64 for a test module (build scenes after it; the previous setting is
restored afterwards)."""

import os
import pathlib

import jax
import pytest

_cache = pathlib.Path(__file__).resolve().parents[1] / ".jax_cache"
jax.config.update("jax_compilation_cache_dir", os.environ.get("ROCKJAX_JAX_CACHE", str(_cache)))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


@pytest.fixture(scope="module")
def x64():
    old = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)
