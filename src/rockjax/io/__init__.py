"""Files: HDF5 run output (``hdf5.Writer``, ``read``) and its XDMF sidecars for ParaView
(``xdmf.write_xdmf``)."""

from .hdf5 import Run, Writer, read
from .xdmf import write_xdmf

__all__ = ["Run", "Writer", "read", "write_xdmf"]
