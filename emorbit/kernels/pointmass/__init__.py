"""Point-mass (test-particle) kernels: every point moves in the central field on its own.

- :mod:`.packed` runs point-mass scenes on the CPU: blocks of points in packed SIMD
  loops, on one thread or all of them;
- :mod:`.reference` is the scalar reference the packed kernels are tested against (and the
  per-point steps the adaptive and GPU paths reuse);
- :mod:`.adaptive` steps each point by a fraction of its local Kepler time;
- :mod:`.cuda` runs the packed kernels' per-point path on an NVIDIA GPU.

Which one runs a simulation is decided by :mod:`emorbit.integrators.dispatch`. The
submodules are imported on use, so that a scene pays only for the kernels it runs.
"""
