"""Files: HDF5 run output (``hdf5.Writer``, ``read``)."""

from .hdf5 import Run, Writer, read

__all__ = ["Run", "Writer", "read"]
