"""Shared test set-up: a persistent compilation cache (compiles are slow on 2 cores)."""

import os
import pathlib

import jax

_cache = pathlib.Path(__file__).resolve().parents[1] / ".jax_cache"
jax.config.update("jax_compilation_cache_dir", os.environ.get("ROCKJAX_JAX_CACHE", str(_cache)))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
