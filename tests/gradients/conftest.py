"""Float64 for the gradient tests: the ``x64`` fixture turns ``jax_enable_x64`` on for a module
(scenes must be built after it) and restores the previous setting afterwards."""

import jax
import pytest


@pytest.fixture(scope="module")
def x64():
    old = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    yield
    jax.config.update("jax_enable_x64", old)
