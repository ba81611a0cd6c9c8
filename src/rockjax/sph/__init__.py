"""The fluid: SPH kernels, neighbour search, equations of state, wall particles, and the two
schemes (``seed``: Mikola & Sitar 2013; ``wcsph``: the accurate default)."""
