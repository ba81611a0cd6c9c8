"""XDMF 3 sidecars so ParaView (and any XDMF reader) opens a run's HDF5 file as a time series.

This module owns the ``/xdmf`` group of a run file and the ``.xdmf`` XML files beside it.
``write_xdmf(h5_path)`` writes, next to ``run.h5``:

* ``run.xdmf``: the particles, one Polyvertex grid per frame (a temporal collection) with the
  node attributes ``v`` [m/s], ``rho`` [kg/m^3], ``p`` [Pa] and ``kind`` (``types.Kind``).
* ``run_blocks.xdmf``: the block surfaces, one triangle grid per frame with the cell attributes
  ``block`` (block index) and ``face`` (face index within the block).

Layout choices, made so that a real reader (meshio's ``TimeSeriesReader``, VTK/ParaView's XDMF
readers) reads the files as written:

* No particle data is copied. Each frame's arrays are HDF5 *virtual datasets*
  ``/xdmf/frames/{x,v,rho,p}/NNNNNN`` that map one frame of ``/x`` ``[F, N, 3]`` (etc.) with
  a same-file source (``"."``), so the pair of files can be moved together. Readers that do not
  resolve XDMF ``HyperSlab`` items (meshio) read them as plain datasets.
* Block vertices move with the block: their world positions are computed once here,
  ``x_world = R(q) x_body + centroid`` with ``q`` normalised, and stored as
  ``/xdmf/block_vertices`` ``[F, V_total, 3]`` m (only the real, unpadded vertices of each
  block, block after block; per frame ``/xdmf/frames/block_vertices/NNNNNN``);
  ``/xdmf/block_vertex_block`` and ``/xdmf/block_vertex_index``
  ``[V_total]`` say which block and which body vertex each row is.
* Faces are convex polygons; they are written as fan triangles ``/xdmf/block_triangles``
  ``[T, 3]`` (outward, counter-clockwise seen from outside, as the half-edge loops are), because
  meshio (and several other readers) cannot read XDMF polygons or Mixed topologies with polygons.
  The face loops come from the cycles of ``/blocks/he_next`` over ``/blocks/halfedge_mask``.
* Particles and blocks go into two files because meshio's ``TimeSeriesReader`` reads a single
  temporal collection per file; ParaView opens both at once.
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np

__all__ = ["write_xdmf", "block_world_vertices", "block_triangles"]

_PARTICLE_FIELDS = ("x", "v", "rho", "p")


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """[..., 3, 3] rotation matrices of quaternions [..., 4] (w, x, y, z), normalised first."""
    q = np.asarray(q, np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def block_world_vertices(vertices: np.ndarray, vertex_mask: np.ndarray, block_x: np.ndarray,
                         block_q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World positions of the real block vertices at every frame.

    Args:
        vertices: [B, V, 3] m body-frame vertices (about each centroid), padded.
        vertex_mask: [B, V] bool, True for real vertices.
        block_x: [F, B, 3] m centroids.
        block_q: [F, B, 4] quaternions (w, x, y, z), body -> world (normalised here).

    Returns:
        (world [F, V_total, 3] m float64, block [V_total] int32, index [V_total] int32): the real
        vertices block after block, which block each row belongs to and its body vertex index.
    """
    vertices = np.asarray(vertices, np.float64)
    vertex_mask = np.asarray(vertex_mask, bool)
    R = _quat_matrix(block_q)  # [F, B, 3, 3]
    world = np.einsum("fbij,bvj->fbvi", R, vertices) + np.asarray(block_x, np.float64)[:, :, None, :]
    b_idx, v_idx = np.nonzero(vertex_mask)  # row-major: block after block
    return world[:, b_idx, v_idx], b_idx.astype(np.int32), v_idx.astype(np.int32)


def block_triangles(he_vert: np.ndarray, he_next: np.ndarray, halfedge_mask: np.ndarray,
                    vertex_mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fan triangles of every block face, indexed into the rows of ``block_world_vertices``.

    Faces are the cycles of ``he_next`` over the real half-edges; each face loop
    ``(v0, v1, ..., vk)`` becomes ``(v0, vi, vi+1)`` for ``i = 1 .. k-1``, keeping the loop's
    orientation.

    Args:
        he_vert, he_next: [B, E] int half-edge vertex and next half-edge (local to each block).
        halfedge_mask: [B, E] bool. vertex_mask: [B, V] bool.

    Returns:
        (triangles [T, 3] int32, block [T] int32, face [T] int32).

    Raises:
        ValueError: a ``he_next`` cycle leaves the real half-edges (the stored geometry is corrupt).
    """
    he_vert = np.asarray(he_vert)
    he_next = np.asarray(he_next)
    halfedge_mask = np.asarray(halfedge_mask, bool)
    vertex_mask = np.asarray(vertex_mask, bool)
    row = np.cumsum(vertex_mask.reshape(-1)).reshape(vertex_mask.shape) - 1  # global row of (b, v)
    tris, tri_block, tri_face = [], [], []
    for b in range(he_vert.shape[0]):
        seen = np.zeros(he_vert.shape[1], bool)
        face = 0
        for start in np.nonzero(halfedge_mask[b])[0]:
            if seen[start]:
                continue
            loop, e = [], int(start)
            while not seen[e]:
                if not halfedge_mask[b, e] or not vertex_mask[b, he_vert[b, e]]:
                    raise ValueError(f"write_xdmf: block {b}: half-edge cycle from {start} reaches a padded "
                                     f"half-edge or vertex ({e}); /blocks/he_next is corrupt")
                seen[e] = True
                loop.append(int(row[b, he_vert[b, e]]))
                e = int(he_next[b, e])
            if e != start or len(loop) < 3:
                raise ValueError(f"write_xdmf: block {b}: he_next from half-edge {start} does not close a face "
                                 f"loop of >= 3 half-edges; /blocks/he_next is corrupt")
            for i in range(1, len(loop) - 1):
                tris.append((loop[0], loop[i], loop[i + 1]))
                tri_block.append(b)
                tri_face.append(face)
            face += 1
    return (np.asarray(tris, np.int32).reshape(-1, 3), np.asarray(tri_block, np.int32),
            np.asarray(tri_face, np.int32))


# --------------------------------------------------------------------------------------------
# XML helpers
# --------------------------------------------------------------------------------------------

def _number_type(dtype) -> tuple[str, str]:
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return "Float", str(dtype.itemsize)
    if dtype.kind == "i":
        return "Int", str(dtype.itemsize)
    if dtype.kind == "u":
        return "UInt", str(dtype.itemsize)
    raise ValueError(f"write_xdmf: cannot describe dtype {dtype} in XDMF")


def _data_item(parent, h5_ref: str, shape, dtype, name: str):
    number, precision = _number_type(dtype)
    item = ET.SubElement(parent, "DataItem", Dimensions=" ".join(str(d) for d in shape), NumberType=number,
                         Precision=precision, Format="HDF")
    item.text = f"{h5_ref}:{name}"
    return item


def _attribute(grid, name: str, center: str, h5_ref: str, shape, dtype, path: str):
    kind = "Scalar" if len(shape) == 1 else "Vector"
    a = ET.SubElement(grid, "Attribute", Name=name, AttributeType=kind, Center=center)
    _data_item(a, h5_ref, shape, dtype, path)


def _document(collection_name: str):
    root = ET.Element("Xdmf", Version="3.0")
    domain = ET.SubElement(root, "Domain")
    coll = ET.SubElement(domain, "Grid", Name=collection_name, GridType="Collection", CollectionType="Temporal")
    return root, coll


def _save(root, path: Path) -> None:
    ET.indent(root)
    body = ET.tostring(root, encoding="unicode")
    path.write_text('<?xml version="1.0" ?>\n<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>\n' + body + "\n")


def _virtual_frames(f: h5py.File, src: str, dest: str) -> list[str]:
    """Virtual datasets ``dest/NNNNNN`` = ``src[k]`` for every frame k, all in the same file
    (source file "."). Low-level h5py: the high-level ``VirtualLayout`` costs ~10 ms a dataset."""
    ds = f[src]
    inner = ds.shape[1:]
    g = f.require_group(dest)
    vspace = h5py.h5s.create_simple(inner)
    tid = ds.id.get_type()
    names = []
    for k in range(ds.shape[0]):
        sel = ds.id.get_space()
        sel.select_hyperslab((k,) + (0,) * len(inner), (1,) + inner)
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_virtual(vspace, b".", src.encode(), sel)
        h5py.h5d.create(g.id, f"{k:06d}".encode(), tid, vspace, dcpl=dcpl)
        names.append(f"{dest}/{k:06d}")
    return names


# --------------------------------------------------------------------------------------------
# public
# --------------------------------------------------------------------------------------------

def write_xdmf(h5_path, xdmf_path=None) -> list[Path]:
    """Write the XDMF sidecar(s) of a run file written by ``io.hdf5.Writer``.

    Adds (or replaces) the ``/xdmf`` group of ``h5_path`` (virtual per-frame datasets, world
    block vertices, triangles; see the module docstring) and writes the XML files. Cost, measured
    on a loaded 2-core machine: 1000 frames took 6 s and added ~3 kB of HDF5 metadata a frame;
    replacing the group leaves the old one's space unreclaimed (``h5repack`` compacts).

    Args:
        h5_path: the run's HDF5 file (closed by its writer).
        xdmf_path: the particles' XDMF file (default ``h5_path`` with suffix ``.xdmf``); the
            blocks go to ``<stem>_blocks.xdmf`` in the same folder. A blocks-only run writes only
            the blocks file.

    Returns:
        The XDMF files written (particles first when present).

    Raises:
        ValueError: the file has no frames, neither particles nor blocks, or inconsistent
            block arrays (the message names the dataset).
    """
    h5_path = Path(h5_path)
    if not h5_path.is_file():
        raise ValueError(f"write_xdmf: h5_path {str(h5_path)!r} is not a file; pass the run's HDF5 output")
    xdmf_path = h5_path.with_suffix(".xdmf") if xdmf_path is None else Path(xdmf_path)
    if xdmf_path.suffix != ".xdmf":
        raise ValueError(f"write_xdmf: xdmf_path must end in .xdmf (got {str(xdmf_path)!r})")
    blocks_path = xdmf_path.with_name(xdmf_path.stem + "_blocks.xdmf")
    ref = Path(os.path.relpath(h5_path.resolve(), xdmf_path.resolve().parent)).as_posix()
    if ":" in ref:
        raise ValueError(f"write_xdmf: the HDF5 path {ref!r} (relative to the XDMF file) may not contain ':'")
    written: list[Path] = []
    with h5py.File(h5_path, "a") as f:
        if "time" not in f or f["time"].shape[0] == 0:
            raise ValueError(f"write_xdmf: {str(h5_path)!r} has no frames (/time is missing or empty)")
        times = f["time"][()]
        F = len(times)
        has_particles = all(k in f for k in _PARTICLE_FIELDS) and "kind" in f
        has_blocks = "blocks" in f and "block_x" in f and "block_q" in f
        if not (has_particles or has_blocks):
            raise ValueError(f"write_xdmf: {str(h5_path)!r} has neither particles (/x, /v, /rho, /p, /kind) "
                             "nor blocks (/blocks, /block_x, /block_q)")
        if "xdmf" in f:
            del f["xdmf"]
        g = f.create_group("xdmf")
        g.attrs["about"] = "views for the XDMF sidecars (rockjax.io.xdmf); virtual datasets, no copied particle data"
        for name in _PARTICLE_FIELDS + ("block_x", "block_q"):
            if name in f and f[name].shape[0] != F:
                raise ValueError(f"write_xdmf: /{name} has {f[name].shape[0]} frames but /time has {F}")

        if has_particles:
            N = f["x"].shape[1]
            cells = g.create_dataset("particle_cells", data=np.arange(N, dtype=np.int32)[:, None])
            views = {name: _virtual_frames(f, f"/{name}", f"/xdmf/frames/{name}") for name in _PARTICLE_FIELDS}
            meta = {name: (f[name].shape[1:], f[name].dtype) for name in _PARTICLE_FIELDS}
            kind = (f["kind"].shape, f["kind"].dtype)
            root, coll = _document("particles")
            for k, t in enumerate(times):
                grid = ET.SubElement(coll, "Grid", Name=f"particles_{k:06d}", GridType="Uniform")
                ET.SubElement(grid, "Time", Value=repr(float(t)))
                topo = ET.SubElement(grid, "Topology", TopologyType="Polyvertex", NumberOfElements=str(N),
                                     NodesPerElement="1")
                _data_item(topo, ref, cells.shape, cells.dtype, "/xdmf/particle_cells")
                geo = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
                _data_item(geo, ref, *meta["x"], views["x"][k])
                for name in ("v", "rho", "p"):
                    _attribute(grid, name, "Node", ref, *meta[name], views[name][k])
                _attribute(grid, "kind", "Node", ref, *kind, "/kind")
            _save(root, xdmf_path)
            written.append(xdmf_path)

        if has_blocks:
            gb = f["blocks"]
            for name in ("vertices", "vertex_mask", "he_vert", "he_next", "halfedge_mask"):
                if name not in gb:
                    raise ValueError(f"write_xdmf: /blocks/{name} is missing; the block surfaces need it")
            world, vb, vi = block_world_vertices(gb["vertices"][()], gb["vertex_mask"][()], f["block_x"][()],
                                                 f["block_q"][()])
            tri, tb, tf = block_triangles(gb["he_vert"][()], gb["he_next"][()], gb["halfedge_mask"][()],
                                          gb["vertex_mask"][()])
            bv = g.create_dataset("block_vertices", data=world.astype(np.float32), chunks=(1,) + world.shape[1:])
            bv.attrs["units"] = "m"
            g.create_dataset("block_vertex_block", data=vb)
            g.create_dataset("block_vertex_index", data=vi)
            dtri = g.create_dataset("block_triangles", data=tri)
            dtb = g.create_dataset("block_triangle_block", data=tb)
            dtf = g.create_dataset("block_triangle_face", data=tf)
            views = _virtual_frames(f, "/xdmf/block_vertices", "/xdmf/frames/block_vertices")
            root, coll = _document("blocks")
            for k, t in enumerate(times):
                grid = ET.SubElement(coll, "Grid", Name=f"blocks_{k:06d}", GridType="Uniform")
                ET.SubElement(grid, "Time", Value=repr(float(t)))
                topo = ET.SubElement(grid, "Topology", TopologyType="Triangle", NumberOfElements=str(len(tri)),
                                     NodesPerElement="3")
                _data_item(topo, ref, dtri.shape, dtri.dtype, "/xdmf/block_triangles")
                geo = ET.SubElement(grid, "Geometry", GeometryType="XYZ")
                _data_item(geo, ref, bv.shape[1:], bv.dtype, views[k])
                _attribute(grid, "block", "Cell", ref, dtb.shape, dtb.dtype, "/xdmf/block_triangle_block")
                _attribute(grid, "face", "Cell", ref, dtf.shape, dtf.dtype, "/xdmf/block_triangle_face")
            _save(root, blocks_path)
            written.append(blocks_path)
    return written
