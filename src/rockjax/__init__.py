"""rockjax: a differentiable 3D simulator of rock slides into water (SPH + explicit 3D-DDA) in JAX."""
