"""The kernel layer: Numba-compiled functions that take a step, and the arithmetic under them.

Kernels are plain functions of float64 arrays and scalars (no objects, closures or units), so
that Numba compiles them once and caches them on disk. They import nothing of emorbit outside
``emorbit.kernels`` and no astropy, h5py, tqdm or matplotlib: the model (``emorbit.bodies``,
``emorbit.simulation``) calls them, never the other way round (an import-linter contract in
pyproject.toml and tests/test_house.py check it).

- :mod:`.jit` owns the Numba options (``kernel``: cached, ``fastmath=False``, numpy error model,
  no GIL) and clears the cache when a kernel source changes;
- :mod:`.codes` holds the integer codes every kernel shares (``METHOD_*``, ``STATUS_*``,
  ``GRAVITY_*``);
- :mod:`.eft`: error-free transformations, double-double arithmetic, the explicit ``fma``;
- :mod:`.atomic`: an atomic counter, the shared work queue of the parallel point-mass kernels;
- :mod:`.gravity`: the field of the central mass and the energy-momentum acceleration ``g_em``;
- :mod:`.pointmass`: test particles (the packed CPU kernels, the reference, adaptive steps, CUDA);
- :mod:`.rigid`: rigid bodies in the director formulation;
- :mod:`.elastic` and :mod:`.coupled`: finite elements and the sparse Jacobian of a structure;
- :mod:`.invariants`: energy, momentum and angular momentum of recorded states (plain numpy).

Which kernel runs a simulation is decided by :mod:`emorbit.integrators.dispatch`; the methods
and their round-off treatment are described in docs/methods.md.
"""
