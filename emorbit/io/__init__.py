"""Files and records: the HDF5 run file's layout and reading it (:mod:`.reader`), writing it
(:mod:`.hdf5`), the records of a running simulation
(:mod:`.recorder`), a set-up written back as a scene (:mod:`.scene_toml`) and the
continuation of a run file (:mod:`.resume`, imported on use: it builds on the scene parser).
"""

from .hdf5 import Writer
from .reader import read

__all__ = ["Writer", "read"]
