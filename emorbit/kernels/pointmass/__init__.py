"""Point-mass (test-particle) kernels: every point moves in the central field on its own.

- :mod:`.packed` runs point-mass scenes on the CPU: blocks of points in packed SIMD loops, on
  one thread or all of them (its entry kernels); it is built from :mod:`.roots` (the em and
  midpoint steps reduced to one scalar unknown, and its solves), :mod:`.point_step` (one point's
  sub-step), :mod:`.block` (a block's work array and the passes over it) and :mod:`.chunk`
  (every step of a chunk for a block or a point);
- :mod:`.reference` is the scalar reference the packed kernels are tested against (and the
  per-point steps the adaptive path and the packed kernels' fallback reuse);
- :mod:`.adaptive` steps each point by a fraction of its local Kepler time;
- :mod:`.cuda` runs the packed kernels' per-point path on an NVIDIA GPU.

Which one runs a simulation is decided by :mod:`emorbit.integrators.dispatch`. The
submodules are imported on use, so that a scene pays only for the kernels it runs.
"""
