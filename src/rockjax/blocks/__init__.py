"""The rock blocks: convex polyhedra (host geometry in ``geometry``); the 3D-DDA dynamics are an open issue."""
