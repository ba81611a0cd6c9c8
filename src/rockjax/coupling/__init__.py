"""Fluid-block coupling: the seed's penalty force (``penalty``, seed Eq 22) and boundary particles
carried by the blocks (``boundary_particles``). Only this package and ``step`` see both the
fluid (``sph``) and the blocks (``blocks``)."""
