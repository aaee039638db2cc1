"""The version of emorbit, read by the package metadata and written into every output file."""

__version__ = "0.1.0"
"""The version of this emorbit (PEP 440), stored as ``emorbit_version`` in run files."""
