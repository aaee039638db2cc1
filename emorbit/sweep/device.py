"""Where a sweep's runs put their point masses: the CPU or the GPU.

::

    sim = emorbit.load_scene("cloud.toml").build()
    use_device(sim, "gpu")          # InputError at once if no CUDA device is present
    sim.run(...)

Only the point masses move to the device (em, midpoint and leapfrog, every order); rigid
and elastic bodies of the same scene stay on the CPU. Worth it for large ensembles of test
particles: each chunk copies the state to the device and the records back. The kernel is
chosen by :mod:`emorbit.integrators.dispatch`, like every other kernel.
"""

from __future__ import annotations

from ..integrators import DEVICES

__all__ = ["use_device", "DEVICES"]


def use_device(sim, device: str = "gpu") -> None:
    """Advance a simulation's point masses on a device.

    The same as setting :attr:`emorbit.Simulation.device`.

    Parameters
    ----------
    sim : Simulation
        The simulation.
    device : str
        ``"gpu"`` or ``"cpu"`` (the default path).

    Raises
    ------
    InputError
        No usable CUDA device, or adaptive steps (CPU only).
    """
    sim.device = device
