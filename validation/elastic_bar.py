"""The case ``elastic-bar-axial``: the axial vibration of a free-free bar of St. Venant-Kirchhoff
bars against the exact discrete chain and against the continuum's f_n = n c / (2 L) (the
figure: :mod:`.elastic_bodies_figures`).

The bar (c = sqrt(E / rho), length L, N equal bars of h = L / N), lumped or consistent mass
(emorbit offers both; consistent is its default). The free-free chain's exact modes are
u_j = cos(j theta), theta = n pi / N, j = 0 .. N, for both mass matrices, at
(:func:`chain_frequencies`)::

    lumped:     w_n = (2 c / h) sin(theta / 2)
    consistent: w_n = (c / h) sqrt(6 (1 - cos theta) / (2 + cos theta))

both tending to n pi c / L as (1 -+ theta^2 / 24) (Hughes 1987, ch. 7 and 9). Modes 1-3 start
at strain amplitude 1e-7 each (node velocities c eps cos(j theta) along the bar); the bar drifts
across its axis at 1 m/s (its angular momentum about the origin is not zero). emorbit's
frequencies (:func:`~.elastic_common.fit_frequency` on the modal coordinates) are checked
against the exact w_n carried by the midpoint rule (measured 5.5e-10 quick, 1.0e-10 full: the
fit's bias from the modes' coupling through the bar's quadratic nonlinearity, proportional to
the strain amplitude); with the step's error removed, against the continuum: the observed
order (worst |p - 2| 0.019) and the leading term -+theta^2 / 24 (the measured error over it
within 3 theta^2 / 80 of 1: measured 1.1e-3 quick, 2.7e-4 full).

The data layout: every run is a :class:`~.body_case.Trajectory` with ``series`` ``eta`` (m, 3)
the modal coordinates (m) and ``drift`` (m, 3); ``info`` holds the measured ``omega``.

References: T. J. R. Hughes, *The Finite Element Method* (Prentice-Hall 1987), ch. 7 and 9
(mass matrices, the chain's dispersion); K. F. Graff, *Wave Motion in Elastic Solids* (Ohio
State 1975), ch. 2 (the bar); J. C. Simo, N. Tarnow, Z. angew. Math. Phys. 43 (1992) 757-792.
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import elastic_common as common
from .body_case import BodyCase, BodyRun, Trajectory

__all__ = [
    "BAR_FREQUENCY",
    "chain_frequencies",
    "chain_mass",
    "run_bar",
    "BarRun",
    "bar_case",
]


def chain_frequencies(modes, elements: int, length: float, speed: float, mass_matrix: str) -> np.ndarray:
    """The exact axial frequencies of a free-free chain of ``elements`` equal linear bars.

    With theta = n pi / N and h = L / N, the free-free chain's modes are u_j = cos(j theta)
    (j = 0 .. N) for both mass matrices, at

    - lumped (m h / 2 at the ends, m h inside): w = (2 c / h) sin(theta / 2);
    - consistent (m h / 6 [[2, 1], [1, 2]] per bar): w = (c / h) sqrt(6 (1 - cos theta) / (2 + cos theta)).

    Both tend to the continuum's n pi c / L as (1 -+ theta^2 / 24).

    Parameters
    ----------
    modes : array_like of int
        Mode numbers n (1 <= n <= N).
    elements : int
        N.
    length : float
        L, m.
    speed : float
        c = sqrt(E / rho), m/s.
    mass_matrix : str
        ``"lumped"`` or ``"consistent"``.

    Returns
    -------
    ndarray
        rad/s, one per mode.

    Raises
    ------
    ValueError
        An unknown mass matrix.
    """
    n = np.asarray(modes, float)
    h = length / elements
    theta = n * math.pi / elements
    if mass_matrix == "lumped":
        return 2 * speed / h * np.sin(theta / 2)
    if mass_matrix == "consistent":
        return speed / h * np.sqrt(6 * (1 - np.cos(theta)) / (2 + np.cos(theta)))
    raise ValueError(f"mass_matrix must be 'lumped' or 'consistent', got {mass_matrix!r}")


def chain_mass(elements: int, length: float, density: float, area: float, mass_matrix: str) -> np.ndarray:
    """The chain's (N + 1, N + 1) scalar mass matrix, kg: rho A h / 6 [[2, 1], [1, 2]] per bar
    (consistent) or rho A h / 2 on each of its two nodes (lumped), as emorbit builds them."""
    mb = density * area * length / elements
    e = np.array([[2.0, 1.0], [1.0, 2.0]]) * mb / 6 if mass_matrix == "consistent" else np.eye(2) * mb / 2
    M = np.zeros((elements + 1, elements + 1))
    for k in range(elements):
        M[k : k + 2, k : k + 2] += e
    return M


def run_bar(s: dict, elements: int, mass_matrix: str) -> Trajectory:
    """emorbit's em on the free-free bar: ``elements`` bars, the modes of ``s["modes"]`` excited
    by their initial velocities, recorded at every step; their modal coordinates and frequencies.

    The bar lies on the x axis centred on ``s["centre"]`` and drifts at ``s["drift"]`` (across
    the bar: the angular momentum about the origin is not zero). Mode n starts with the node
    velocities eps_n c cos(n pi j / N) along the bar (a standing wave of strain amplitude eps_n),
    set through ``Simulation.state_arrays`` / ``set_state_arrays`` after the structure is laid out.

    Parameters
    ----------
    s : dict
        The case's settings.
    elements : int
        N.
    mass_matrix : str
        ``"lumped"`` or ``"consistent"``.

    Returns
    -------
    Trajectory
        ``series``: ``eta`` (m, k) the modal coordinates phi_n^T M u / phi_n^T M phi_n (m),
        ``drift`` (m, 3) emorbit's invariant drift; ``info``: the measured frequencies
        ``omega`` and the fits' ``residual``, the step, the invariants' drift in eps.
    """
    import emorbit

    L, c = s["length"], math.sqrt(s["young"] / s["density"])
    dt = 2 * L / c / s["steps_per_period"]
    sim = emorbit.Simulation(None, method="em", order=2, dt=dt)
    sim.add_elastic(
        "bar", "chain", start=[-L / 2, 0, 0], end=[L / 2, 0, 0], elements=elements, young=s["young"],
        area=s["area"], density=s["density"], mass_matrix=mass_matrix, position=s["centre"], velocity=s["drift"],
    )  # fmt: skip
    arrays = common.laid_out_state(sim)
    body = next(b for b in sim.structure.bodies if b["name"] == "bar")
    slots = np.asarray(body["free_slots"])
    j = np.arange(elements + 1)
    phi = np.cos(np.outer(j, s["modes"]) * math.pi / elements)  # (N + 1, k)
    arrays["structure/v"][slots, 0] += c * phi @ np.asarray(s["strain"], float)
    sim.set_state_arrays(arrays, 0)
    steps = s["steps_per_period"] * s["periods"]
    start = time.perf_counter()
    res = sim.run(steps=steps, every=1, progress=False).si
    wall = time.perf_counter() - start
    X = s["centre"][0] + np.linspace(-L / 2, L / 2, elements + 1)
    u = res.bodies["bar"]["nodes/position"][..., 0] - X
    M = chain_mass(elements, L, s["density"], s["area"], mass_matrix)
    Mphi = M @ phi
    eta = u @ Mphi / np.einsum("jk,jk->k", phi, Mphi)
    fits = [common.fit_frequency(res.time, eta[:, k]) for k in range(len(s["modes"]))]
    return Trajectory(
        f"{mass_matrix} mass, N = {elements}",
        res.time,
        {"eta": eta, "drift": np.asarray(res.invariant_drift, float)},
        wall,
        {
            "method": "em",
            "order": 2,
            "elements": elements,
            "mass_matrix": mass_matrix,
            "dt_s": dt,
            "steps": steps,
            "omega": [f["omega"] for f in fits],
            "amplitude_m": [f["amplitude"] for f in fits],
            "fit_residual": [f["residual"] for f in fits],
            "drift_eps": common.drift_eps(res).tolist(),
            "newton_iterations": res.mean_newton_iterations(),
        },
    )


#: |w_em / w_h - 1| of the bar's modes, w_h the exact chain's frequency carried by the midpoint
#: rule: the quadratic nonlinearity of the SVK bar couples the modes at first order in the strain
#: amplitude eps, and the sinusoid fitted to a modal coordinate is biased by that coupling;
#: measured over 4 periods at eps = 1e-5, 1e-6, 1e-7: 4.0e-8, 4.0e-9, 4.0e-10 (the fits' residuals
#: 3.8e-5, 3.8e-6, 3.8e-7 of the amplitude); at eps = 1e-7 at most 5.5e-10 (quick, 3 periods) and
#: 1.0e-10 (full, 8 periods); 3.6 times the quick
BAR_FREQUENCY = 2e-9


class BarRun(BodyRun):
    """The runs and checks of ``elastic-bar-axial`` (what its figure reads).

    ``omega[(mass_matrix, N)]`` holds emorbit's measured frequencies, ``exact`` the chain's
    exact ones, ``carried`` those through the midpoint rule, ``spatial`` emorbit's with the
    time step's error removed (:func:`~.elastic_common.spatial_frequency`), ``continuum`` n pi c / L (all from
    the referee's Young's modulus, ``young_factor`` times the case's).
    """

    def __init__(self, case, mode, scale, outdir, young_factor: float = 1.0):
        super().__init__(case, mode, scale, outdir)
        self.young_factor = young_factor
        self.omega, self.exact, self.carried, self.spatial = {}, {}, {}, {}

    def run(self):
        """Run emorbit on every mesh and mass matrix, then the checks."""
        s = self.case.settings
        c_ref = math.sqrt(self.young_factor * s["young"] / s["density"])
        self.continuum = np.asarray(s["modes"], float) * math.pi * c_ref / s["length"]
        t0 = time.perf_counter()
        for mm in s["mass_matrices"]:
            for N in s["elements"]:
                tr = self.add(run_bar(s, N, mm))
                key = (mm, N)
                dt = tr.info["dt_s"]
                self.omega[key] = np.asarray(tr.info["omega"])
                self.exact[key] = chain_frequencies(s["modes"], N, s["length"], c_ref, mm)
                self.carried[key] = common.midpoint_frequency(self.exact[key], dt)
                self.spatial[key] = common.spatial_frequency(self.omega[key], dt)
        self.timing["em_s"] = time.perf_counter() - t0
        for mm in s["mass_matrices"]:
            self._discrete(mm)
            self._convergence(mm)
        common.invariant_checks(self, s["drift_tolerance"])

    def _discrete(self, mm):
        s = self.case.settings
        dev = {N: np.abs(self.omega[(mm, N)] / self.carried[(mm, N)] - 1) for N in s["elements"]}
        worst = max(float(d.max()) for d in dev.values())
        shift = max(float(np.abs(self.carried[(mm, N)] / self.exact[(mm, N)] - 1).max()) for N in s["elements"])
        self.check(
            f"frequency-{mm}",
            f"{mm} mass: emorbit's frequencies of modes {', '.join(map(str, s['modes']))} (sinusoids fitted to the "
            f"modal coordinates), N = {', '.join(map(str, s['elements']))} bars, worst |w / w_h - 1|",
            "the exact chain's frequencies carried by the midpoint rule, w_h = (2 / h) atan(w_N h / 2)",
            worst,
            BAR_FREQUENCY,
            "1",
            f"the fit's bias from the modes' coupling through the bar's quadratic nonlinearity, proportional to the "
            f"strain amplitude {s['strain'][0]:g} (measured 5.5e-10 quick, 1.0e-10 full; 4e-8 at 1e-5); the time "
            f"step moves w by up to {shift:.2g} (em linearised is the midpoint rule), the referee's E 1e-3 off by 5e-4",
            "; ".join(f"N = {N}: " + ", ".join(f"{x:.2g}" for x in d) for N, d in dev.items()),
        )

    def _convergence(self, mm):
        s = self.case.settings
        Ns = s["elements"]
        sign = -1.0 if mm == "lumped" else 1.0
        errs = {N: self.spatial[(mm, N)] / self.continuum - 1 for N in Ns}
        orders = np.array([np.log2(errs[a] / errs[b]) for a, b in zip(Ns[:-1], Ns[1:])])  # (pairs, modes)
        self.convergence[mm] = {
            "elements": list(Ns),
            "error": [errs[N].tolist() for N in Ns],
            "observed": orders.tolist(),
        }
        theta0 = max(s["modes"]) * math.pi / Ns[0]
        self.check(
            f"order-{mm}",
            f"{mm} mass: observed order of emorbit's frequency error against the continuum n pi c / L (time step's "
            "error removed: (2 / h) tan(w h / 2)), from N to 2N bars, worst |p - 2| over modes and N",
            "order 2",
            float(np.abs(orders - 2).max()) if np.all(np.isfinite(orders)) else math.inf,
            0.05,
            "1 (order)",
            f"the chain's error is -+theta^2 / 24 (1 + O(theta^2)), theta = n pi / N: the closed form's own order "
            f"from N to 2N is 2 - {2 - math.log2(_ratio(theta0, mm)):.3f} at theta = {theta0:.3f} (mode "
            f"{max(s['modes'])}, N = {Ns[0]}); 2.5 times the largest",
            "; ".join(
                f"N = {a} to {b}: " + ", ".join(f"{p:.4f}" for p in row) for a, b, row in zip(Ns[:-1], Ns[1:], orders)
            ),
        )
        N = Ns[-1]
        theta = np.asarray(s["modes"], float) * math.pi / N
        lead = errs[N] / (sign * theta**2 / 24)
        self.check(
            f"leading-error-{mm}",
            f"{mm} mass: emorbit's relative frequency error against the continuum at N = {N}, over the leading term "
            f"of the chain's error {'-' if sign < 0 else '+'}(n pi / N)^2 / 24, worst |ratio - 1| over the modes",
            "1 (the sign and size of the leading discretisation error)",
            float(np.abs(lead - 1).max()),
            3 * float(theta.max() ** 2) / 80,
            "1",
            f"the closed form's next term is about theta^2 / 80 of the leading one for either mass matrix; 3 times it "
            f"at theta = {theta.max():.3f}; a wrong mass matrix (lumped for consistent) or a wrong sign gives 2",
            ", ".join(f"mode {n}: {x:.6f}" for n, x in zip(s["modes"], lead)),
        )


def _ratio(theta: float, mm: str) -> float:
    """The exact chain's relative error at theta over its error at theta / 2."""

    def err(th):
        if mm == "lumped":
            return 2 * math.sin(th / 2) / th - 1
        return math.sqrt(6 * (1 - math.cos(th)) / (2 + math.cos(th))) / th - 1

    return err(theta) / err(theta / 2)


def bar_case(mode: str) -> BodyCase:
    """The case ``elastic-bar-axial`` of a mode (quick: N = 8, 16, 32 over 3 periods; full: to 64 over 8)."""
    E, rho, L = 70e9, 2700.0, 2.0
    c = math.sqrt(E / rho)
    elements = (8, 16, 32) if mode == "quick" else (8, 16, 32, 64)
    periods = 3 if mode == "quick" else 8
    settings = {
        "young": E,
        "density": rho,
        "length": L,
        "area": 1e-4,
        "centre": [0.3, -0.2, 0.1],
        "drift": [0.0, 1.0, 0.0],
        "modes": (1, 2, 3),
        "strain": (1e-7, 1e-7, 1e-7),
        "steps_per_period": 100,
        "periods": periods,
        "elements": elements,
        "mass_matrices": ("lumped", "consistent"),
        "drift_tolerance": {"energy": 25.0, "momentum": 7e-3, "angular-momentum": 12.0, "measured": (2.7, 7e-4, 1.35)},
    }
    return BodyCase(
        name="elastic-bar-axial",
        module="elastic_bodies",
        title="Axial vibration of a free-free SVK bar against the exact chain and c / 2L",
        description=(
            f"A free-free bar of {L:g} m (E = {E / 1e9:g} GPa, rho = {rho:g} kg/m3: c = sqrt(E / rho) = {c:.6g} m/s, "
            f"f_n = n c / (2 L) = {c / (2 * L):.6g} n Hz), meshed into N = {', '.join(map(str, elements))} St. "
            'Venant-Kirchhoff bars (`add_elastic(..., "chain")`) with the lumped and the consistent mass matrix, '
            "drifting across its axis at 1 m/s. Its modes 1, 2, 3 start at strain amplitude 1e-7 each (node "
            "velocities set through `Simulation.set_state_arrays`). Sinusoids fitted to the modal coordinates give "
            "emorbit's frequencies, checked against the exact frequencies of the discrete chain carried by the "
            "midpoint rule (em linearised), and, with the step's error removed, against the continuum n pi c / L: "
            "the order 2 of the discretisation error and its leading term -+(n pi / N)^2 / 24."
        ),
        period=2 * L / c,
        params={
            "E, rho, L, A": f"{E:g} Pa, {rho:g} kg/m3, {L:g} m, 1e-4 m2",
            "c, f_1": f"{c:.8g} m/s, {c / (2 * L):.8g} Hz",
            "bars N": ", ".join(map(str, elements)),
            "mass matrices": "lumped, consistent",
            "modes, strain amplitude": "1, 2, 3; 1e-7 each",
            "step, run": f"T_1 / 100, {periods} T_1 (T_1 = 2 L / c = {2 * L / c:.6g} s), em order 2",
        },
        settings=settings,
    )
