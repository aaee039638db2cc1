"""Files: the HDF5 run output (:mod:`.hdf5`)."""

from .hdf5 import Writer, read

__all__ = ["Writer", "read"]
