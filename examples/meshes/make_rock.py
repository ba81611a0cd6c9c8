"""Regenerate ``rock.obj``: a small convex rock (~0.24 x 0.18 x 0.14 m), the convex hull of a
seeded, radially jittered icosahedron stretched into an ellipsoid. Run: python make_rock.py"""

import pathlib

import numpy as np
import trimesh

rng = np.random.default_rng(7)
ico = trimesh.creation.icosahedron()
pts = ico.vertices * (1.0 + 0.12 * rng.uniform(-1.0, 1.0, (len(ico.vertices), 1)))
pts = pts * np.array([0.12, 0.09, 0.07]) / np.linalg.norm(ico.vertices, axis=1).max()
rock = trimesh.convex.convex_hull(pts)
rock.export(pathlib.Path(__file__).with_name("rock.obj"))
print(f"rock.obj: {len(rock.vertices)} vertices, {len(rock.faces)} faces, volume {rock.volume:.5f} m^3, "
      f"extents {np.round(rock.extents, 3).tolist()} m")
