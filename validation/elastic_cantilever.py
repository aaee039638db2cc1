"""The case ``elastic-cantilever``: the bending of a cantilever of tetrahedra against the
referee's discrete modes and, under refinement, against Euler-Bernoulli (the figure:
:mod:`.elastic_bodies_figures`).

A beam L x b x t = 1 x 0.1 x 0.05 m of linear tetrahedra (E = 70 GPa, nu = 0, rho = 2700
kg/m^3; ``add_elastic(..., "beam")``, 6 tetrahedra per cell), its root face attached
(``attach(..., "x-min", ...)``) to a rigid box of edge 0.5 m and 1e6 times its mass, on meshes
nx x 1 x nz with the cell size halved in every direction (20 x 1 x 2 to 80 x 1 x 8 quick, to
160 x 1 x 16 full), and one run at nu = 0.3. The referee (:class:`CantileverReferee`)
assembles the linearised SVK stiffness K_(ai)(bj) = V (lam g_ai g_bj + mu g_aj g_bi +
mu delta_ij g_a . g_b) and the consistent mass rho V / 20 (1 + delta_ab) itself
(:func:`tet_stiffness_mass`), reduces them to the free nodes and the base's (U, theta) and
solves K phi = w^2 M phi with ``scipy.sparse.linalg.eigsh``. The first two bending modes
across t start at tip amplitude 1e-6 L.

Checks: emorbit's frequencies against the referee's through the midpoint rule (measured
4.3e-10 up to 80 x 1 x 8 cells; 3.8e-9 on 160 x 1 x 16, where the referee's own error is
3.2e-9); the order of convergence under refinement (1.72 quick, 1.91 full: linear tetrahedra
lock in bending and reach 2 from below); the Richardson extrapolation (order 2) of the two
finest meshes against Euler-Bernoulli (:func:`euler_bernoulli`)::

    w_k = (beta_k L)^2 sqrt(E I / (rho A L^4)),  1 + cos(beta L) cosh(beta L) = 0,
    beta_1 L = 1.875104, beta_2 L = 4.694091,  I = b t^3 / 12,

within Timoshenko's correction delta_k = -(r^2 / 2) (int w'^2 / int w^2 + E / (kappa G)
int w'''^2 / int w''^2), r^2 = I / A, kappa = 10 (1 + nu) / (12 + 11 nu) (Cowper), here
-1.65e-3 and -1.15e-2, plus the extrapolation's uncertainty. Measured (full): the
extrapolation lies 1.41e-3 and 1.10e-2 below Euler-Bernoulli, and 2.4e-4 and 4.6e-4 from
Euler-Bernoulli with the Timoshenko correction. nu = 0 makes the solid's bending stress
uniaxial as beam theory has it (no anticlastic curvature, nothing for the clamped root face
to restrain). The base moves the frequencies by 7.3e-6 against a clamped root (the referee
solves both); the checks compare with the referee of beam and base.

The data layout: every run is a :class:`~.body_case.Trajectory` with ``series`` ``eta`` (m, 2)
the modal coordinates, ``tip`` (m,) the tip's z displacement (m) and ``drift`` (m, 3); ``info``
holds the measured ``omega``, the referee's ``omega_ref`` and ``omega_clamped``.

References: K. F. Graff, *Wave Motion in Elastic Solids* (Ohio State 1975), ch. 3; R. D.
Blevins, *Formulas for Natural Frequency and Mode Shape* (Van Nostrand 1979), table 8-1 (beta
L); S. P. Timoshenko, Phil. Mag. 41 (1921) 744-746; G. R. Cowper, J. Appl. Mech. 33 (1966)
335-340 (the shear coefficient); O. C. Zienkiewicz, R. L. Taylor, *The Finite Element Method*,
vol. 1 (5th ed., Butterworth-Heinemann 2000) (the tetrahedron's matrices, locking); L. F.
Richardson, Phil. Trans. R. Soc. A 226 (1927) 299-361 (extrapolation).
"""

from __future__ import annotations

import math
import time

import numpy as np

from . import elastic_common as common
from .body_case import BodyCase, BodyRun, Trajectory

__all__ = [
    "CANTILEVER_FREQUENCY",
    "SAME_MASS",
    "tet_stiffness_mass",
    "euler_bernoulli",
    "cantilever_shape",
    "CantileverReferee",
    "run_cantilever",
    "CantileverRun",
    "cantilever_case",
]


def tet_stiffness_mass(X, tets, young: float, poisson: float, density: float):
    """The referee's stiffness and mass of linear tetrahedra (its own assembly, not emorbit's).

    The St. Venant-Kirchhoff energy linearised at the reference configuration is linear
    elasticity: per element of volume V and shape-function gradients g_a,
    K_(ai)(bj) = V (lam g_ai g_bj + mu g_aj g_bi + mu delta_ij g_a . g_b), with Lame's
    lam = E nu / ((1 + nu)(1 - 2 nu)) and mu = E / (2 (1 + nu)); the consistent mass is
    rho V / 20 (1 + delta_ab) per node pair (Zienkiewicz & Taylor, vol. 1, ch. 16).

    Parameters
    ----------
    X : ndarray
        (n, 3) node coordinates, m.
    tets : ndarray
        (k, 4) node indices, positively oriented.
    young, poisson, density : float
        E (Pa), nu, rho (kg/m^3).

    Returns
    -------
    K : scipy.sparse.csr_matrix
        (3n, 3n), N/m, dof 3 i + d for node i and direction d.
    M : scipy.sparse.csr_matrix
        (n, n) scalar mass matrix, kg.
    """
    import scipy.sparse as sp

    X = np.asarray(X, float)
    T = np.asarray(tets, np.int64)
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    P = X[T]
    Dm = np.stack([P[:, 1] - P[:, 0], P[:, 2] - P[:, 0], P[:, 3] - P[:, 0]], axis=2)
    V = np.linalg.det(Dm) / 6
    g = np.zeros((len(T), 4, 3))
    g[:, 1:, :] = np.linalg.inv(Dm)  # rows: the gradients of N1..N3
    g[:, 0, :] = -g[:, 1:, :].sum(axis=1)
    Ke = (
        lam * np.einsum("e,eai,ebj->eaibj", V, g, g)
        + mu * np.einsum("e,eaj,ebi->eaibj", V, g, g)
        + mu * np.einsum("e,eak,ebk,ij->eaibj", V, g, g, np.eye(3))
    )
    dof = 3 * T[:, :, None] + np.arange(3)[None, None, :]
    rows = np.broadcast_to(dof[:, :, :, None, None], Ke.shape).ravel()
    cols = np.broadcast_to(dof[:, None, None, :, :], Ke.shape).ravel()
    n = X.shape[0]
    K = sp.coo_matrix((Ke.ravel(), (rows, cols)), shape=(3 * n, 3 * n)).tocsr()
    a = np.broadcast_to(T[:, :, None], (len(T), 4, 4)).ravel()
    b = np.broadcast_to(T[:, None, :], (len(T), 4, 4)).ravel()
    me = (density * V / 20)[:, None, None] * (np.ones((4, 4)) + np.eye(4))
    M = sp.coo_matrix((me.ravel(), (a, b)), shape=(n, n)).tocsr()
    return K, M


def euler_bernoulli(s: dict, young: float) -> dict:
    """The cantilever's first two bending frequencies by Euler-Bernoulli theory and the leading
    Timoshenko correction (shear and rotary inertia).

    w_k = (beta_k L)^2 sqrt(E I / (rho A L^4)), beta_1 L = 1.8751, beta_2 L = 4.6941 (roots of
    1 + cos(x) cosh(x) = 0), I = b t^3 / 12 for bending across the thickness t. To first order in
    r^2 = I / A the Timoshenko beam lowers w_k by the factor 1 + delta_k,

        delta_k = -(r^2 / 2) (int w'^2 / int w^2 + (E / (kappa G)) int w'''^2 / int w''^2)

    over the Euler-Bernoulli mode shape w (the Rayleigh quotient with rotary inertia rho I w'^2
    and shear flexibility; for a simply supported beam it gives the classical
    -(n pi r / L)^2 (1 + E / (kappa G)) / 2), with Cowper's kappa = 10 (1 + nu) / (12 + 11 nu)
    of a rectangle and E / G = 2 (1 + nu). The integrals are Gauss-Legendre sums (200 points).

    Parameters
    ----------
    s : dict
        The case's settings: ``length``, ``width``, ``thickness``, ``density``, ``poisson``.
    young : float
        E, Pa.

    Returns
    -------
    dict
        ``omega`` (2,) rad/s, ``delta`` (2,) the Timoshenko corrections, ``beta_L`` (2,).
    """
    from scipy.optimize import brentq

    L, t = s["length"], s["thickness"]
    A, I = s["width"] * t, s["width"] * t**3 / 12
    nu = s["poisson"]
    kappa = 10 * (1 + nu) / (12 + 11 * nu)
    e_kg = 2 * (1 + nu) / kappa
    x, w = np.polynomial.legendre.leggauss(200)
    x = 0.5 * (x + 1)
    w = 0.5 * w
    betas, omegas, deltas = [], [], []
    for lo, hi in ((1.0, 3.0), (4.0, 6.0)):
        bl = brentq(lambda z: 1 + math.cos(z) * math.cosh(z), lo, hi, xtol=1e-15)
        sig = (math.cosh(bl) + math.cos(bl)) / (math.sinh(bl) + math.sin(bl))
        z = bl * x
        ch, cs, sh, sn = np.cosh(z), np.cos(z), np.sinh(z), np.sin(z)
        d = [
            ch - cs - sig * (sh - sn),
            bl * (sh + sn - sig * (ch - cs)),
            bl**2 * (ch + cs - sig * (sh + sn)),
            bl**3 * (sh - sn - sig * (ch + cs)),
        ]
        ints = [float(w @ (f * f)) for f in d]
        r2 = I / A / L**2
        deltas.append(-0.5 * r2 * (ints[1] / ints[0] + e_kg * ints[3] / ints[2]))
        betas.append(bl)
        omegas.append(bl**2 * math.sqrt(young * I / (s["density"] * A * L**4)))
    return {"omega": np.array(omegas), "delta": np.array(deltas), "beta_L": np.array(betas)}


def cantilever_shape(beta_l: float, x) -> np.ndarray:
    """The Euler-Bernoulli cantilever's mode shape at x / L, scaled to 1 at the tip.

    w = cosh(z) - cos(z) - sigma (sinh(z) - sin(z)), z = beta L x / L, sigma = (cosh(beta L) +
    cos(beta L)) / (sinh(beta L) + sin(beta L)) (clamped at x = 0, free at x = L).

    Parameters
    ----------
    beta_l : float
        beta L of the mode.
    x : array_like
        x / L in [0, 1].

    Returns
    -------
    ndarray
        w(x) / w(L).
    """
    sig = (math.cosh(beta_l) + math.cos(beta_l)) / (math.sinh(beta_l) + math.sin(beta_l))

    def w(z):
        return np.cosh(z) - np.cos(z) - sig * (np.sinh(z) - np.sin(z))

    return w(beta_l * np.asarray(x, float)) / w(beta_l)


class CantileverReferee:
    """The linearised cantilever and its base, as emorbit discretises them: modes and frequencies.

    The beam, ``size`` (L, b, t) meshed by ``emorbit.bodies.meshes.beam_mesh`` into
    ``elements`` cells of 6 tetrahedra, spans x = 0 .. L; its root nodes (x = 0) ride on a rigid
    box of edge ``base_size`` centred at (-base_size / 2, 0, 0): u_i = U + theta x r_i, with U,
    theta the base's translation and rotation and r_i the node's offset from its centre of mass.
    The generalised coordinates q are the free nodes' displacements and (U, theta); with T the
    map from q to all nodes' displacements, K_q = T^T K T and M_q = T^T (M x I3) T + diag(m_b I3,
    J_b) (J_b the box's inertia as emorbit's ``box`` mass points give it), and
    K_q phi = w^2 M_q phi (``scipy.sparse.linalg.eigsh``, shift-invert) gives the modes. The
    clamped beam (root nodes fixed) is solved as well: the difference is the base's
    mass-ratio effect.

    Parameters
    ----------
    s : dict
        The case's settings.
    elements : sequence of int
        (nx, ny, nz).
    poisson : float
        nu of this mesh's run.
    young_factor : float
        The referee's E over the case's.
    """

    def __init__(self, s: dict, elements, poisson: float, young_factor: float = 1.0):
        import scipy.sparse as sp

        from emorbit.bodies.meshes import beam_mesh
        from emorbit.bodies.shapes import box

        L = s["length"]
        self.elements = tuple(int(k) for k in elements)
        X0, self.tets = beam_mesh([L, s["width"], s["thickness"]], self.elements)
        self.X = X0 + np.array([L / 2, 0.0, 0.0])
        self.K, self.M = tet_stiffness_mass(self.X, self.tets, young_factor * s["young"], poisson, s["density"])
        root = np.abs(self.X[:, 0]) <= 1e-9 * L
        self.free, self.root = np.flatnonzero(~root), np.flatnonzero(root)
        nf = self.free.size
        self.base_centre = np.array([-s["base_size"] / 2, 0.0, 0.0])
        self.base_mass = s["base_ratio"] * s["density"] * L * s["width"] * s["thickness"]
        self.base_inertia = box([s["base_size"]] * 3, mass=self.base_mass).inertia
        rows, cols, vals = [], [], []
        for k, i in enumerate(self.free):
            rows += [3 * i + d for d in range(3)]
            cols += [3 * k + d for d in range(3)]
            vals += [1.0] * 3
        for i in self.root:
            r = self.X[i] - self.base_centre
            cross = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])  # [r]x: theta x r = -[r]x theta
            for d in range(3):
                rows += [3 * i + d] * 4
                cols += [3 * nf + d, 3 * nf + 3, 3 * nf + 4, 3 * nf + 5]
                vals += [1.0, *(-cross[d])]
        n = self.X.shape[0]
        self.T = sp.coo_matrix((vals, (rows, cols)), shape=(3 * n, 3 * nf + 6)).tocsr()
        M3 = sp.kron(self.M, sp.eye(3)).tocsr()
        self.M3 = M3
        self.Kq = (self.T.T @ self.K @ self.T).tocsc()
        extra = sp.block_diag([sp.csr_matrix((3 * nf, 3 * nf)), self.base_mass * sp.eye(3), self.base_inertia])
        self.Mq = (self.T.T @ M3 @ self.T + extra).tocsc()
        self.nf = nf

    def _z_modes(self, K, M, nodes, shift, count=2):
        from scipy.sparse.linalg import eigsh

        w2, V = eigsh(K, k=12, M=M, sigma=-shift, which="LM")
        order = np.argsort(w2)
        w2, V = w2[order], V[:, order]
        u = V[: 3 * nodes].reshape(nodes, 3, -1)
        frac = (u**2).sum(axis=0) / (u**2).sum(axis=(0, 1))
        pick = [k for k in range(w2.size) if w2[k] > 1e-2 * shift and frac[2, k] > 0.8][:count]
        if len(pick) < count:
            raise RuntimeError(f"mesh {self.elements}: fewer than {count} bending modes across the thickness found")
        V = V[:, pick]
        rayleigh = np.einsum("ik,ik->k", V, K @ V) / np.einsum("ik,ik->k", V, M @ V)
        return np.sqrt(w2[pick]), V, frac[2, pick], np.abs(np.sqrt(rayleigh / w2[pick]) - 1)

    def modes(self, omega_guess: float):
        """The two lowest bending modes across the thickness (z) of beam and base.

        Parameters
        ----------
        omega_guess : float
            A frequency below the first bending mode's, rad/s (sets the shift, -(w/10)^2).

        Returns
        -------
        omega : ndarray
            (2,) rad/s.
        phi : ndarray
            (3 nf + 6, 2) mode shapes in q, M_q-orthonormal.
        z_fraction : ndarray
            (2,) the share of each mode's beam displacement along z.
        uncertainty : ndarray
            (2,) the referee's own error of w, relative: |sqrt(R(phi) / w^2) - 1| with R the
            Rayleigh quotient of the computed mode (its round-off grows with the mesh's
            stiffness ratio: measured 3e-10 on 80 x 1 x 8 cells, 3e-9 on 160 x 1 x 16, where
            changing the shift moves w by 2e-9 as well).
        """
        return self._z_modes(self.Kq, self.Mq, self.nf, (omega_guess / 10) ** 2)

    def clamped(self, omega_guess: float) -> np.ndarray:
        """The two lowest bending frequencies (z) of the beam with its root nodes fixed, rad/s."""
        keep = np.repeat(np.isin(np.arange(self.X.shape[0]), self.free), 3)
        return self._z_modes(
            self.K[keep][:, keep].tocsc(), self.M3[keep][:, keep].tocsc(), self.nf, (omega_guess / 10) ** 2
        )[0]


def run_cantilever(s: dict, ref: CantileverReferee, poisson: float, omega, phi, dt: float, steps: int) -> Trajectory:
    """emorbit's em on the cantilever of ``ref``'s mesh: the base (``add_rigid(..., "box")``), the
    beam (``add_elastic(..., "beam")``) with its x-min face attached to the base, both modes of
    ``phi`` excited by initial velocities (tip amplitude ``s["tip"]`` L each), recorded at every
    step; the modal coordinates eta_k = phi_k^T M_q q(t) of the recorded nodes and base.

    Returns
    -------
    Trajectory
        ``series``: ``eta`` (m, 2) m kg^(1/2), ``tip`` (m,) the mean z displacement of the tip
        nodes (m), ``drift``; ``info``: measured ``omega``, fits, step, emorbit's mass matrix
        against the referee's, invariants' drift in eps.
    """
    import emorbit
    from emorbit.bodies.rotations import quaternion_to_matrix

    L = s["length"]
    nf = ref.nf
    tip = np.flatnonzero(np.abs(ref.X[ref.free, 0] - L) <= 1e-9 * L)
    amp = [s["tip"] * L / np.abs(phi[: 3 * nf, k].reshape(nf, 3)[tip, 2]).max() for k in range(2)]
    qdot = sum(amp[k] * omega[k] * phi[:, k] for k in range(2))
    sim = emorbit.Simulation(None, method="em", order=2, dt=dt)
    size = [s["base_size"]] * 3
    sim.add_rigid("base", "box", size=size, mass=ref.base_mass, position=ref.base_centre, velocity=[0, 0, 0])
    sim.add_elastic(
        "beam", "beam", size=[L, s["width"], s["thickness"]], elements=list(ref.elements), young=s["young"],
        poisson=poisson, density=s["density"], position=[L / 2, 0, 0], velocity=[0, 0, 0],
    )  # fmt: skip
    sim.attach("beam", "x-min", "base")
    arrays = common.laid_out_state(sim)
    bodies = {b["name"]: b for b in sim.structure.bodies}
    spec = bodies["beam"]["spec"]
    mass_dev = float(abs(spec.node_mass - ref.M).max() / abs(ref.M).max())
    slots = np.asarray(bodies["beam"]["free_slots"])
    u, v = arrays["structure/u"], arrays["structure/v"]
    if slots.size != nf or not np.array_equal(u[slots], ref.X[ref.free]):
        raise RuntimeError("emorbit's free nodes are not the referee's (order or positions differ)")
    v[slots] = qdot[: 3 * nf].reshape(nf, 3)
    base = bodies["base"]["slots"]
    v[base[0]] = qdot[3 * nf : 3 * nf + 3]
    for k in range(3):
        v[base[1 + k]] = np.cross(qdot[3 * nf + 3 :], u[base[1 + k]])
    sim.set_state_arrays(arrays, 0)
    start = time.perf_counter()
    res = sim.run(steps=steps, every=1, progress=False).si
    wall = time.perf_counter() - start
    P = res.bodies["beam"]["nodes/position"]
    R = quaternion_to_matrix(res.attitudes["base"])
    theta = 0.5 * np.stack([R[:, 2, 1] - R[:, 1, 2], R[:, 0, 2] - R[:, 2, 0], R[:, 1, 0] - R[:, 0, 1]], axis=1)
    q = np.hstack(
        [(P[:, ref.free] - ref.X[ref.free]).reshape(len(res.time), -1), res.positions["base"] - ref.base_centre, theta]
    )
    eta = q @ (ref.Mq @ phi)
    fits = [common.fit_frequency(res.time, eta[:, k]) for k in range(2)]
    nx, ny, nz = ref.elements
    return Trajectory(
        f"{nx} x {ny} x {nz} cells, nu = {poisson:g}",
        res.time,
        {
            "eta": eta,
            "tip": (P[:, ref.free[tip], 2] - ref.X[ref.free[tip], 2]).mean(axis=1),
            "drift": np.asarray(res.invariant_drift, float),
        },
        wall,
        {
            "method": "em",
            "order": 2,
            "elements": list(ref.elements),
            "poisson": poisson,
            "nodes": int(ref.X.shape[0]),
            "tetrahedra": int(ref.tets.shape[0]),
            "dt_s": dt,
            "steps": steps,
            "omega": [f["omega"] for f in fits],
            "fit_residual": [f["residual"] for f in fits],
            "mass_matrix_deviation": mass_dev,
            "drift_eps": common.drift_eps(res).tolist(),
            "newton_iterations": res.mean_newton_iterations(),
        },
    )


#: |w_em / w_h - 1| of the cantilever's two bending modes, w_h the referee's discrete frequency
#: carried by the midpoint rule, where the referee's own error is small: measured at tip
#: amplitude 1e-6 L at most 4.3e-10 up to 80 x 1 x 8 cells (at 1e-7 L round-off in the strain
#: raises it to 2e-9, at 1e-5 L the beam's geometric nonlinearity to 1e-9); 4.7 times that. The
#: check adds twice the referee's own error (3.2e-9 on 160 x 1 x 16 cells, where emorbit's
#: frequency is 3.8e-9 from the referee's)
CANTILEVER_FREQUENCY = 2e-9
#: the referee's consistent mass matrix against emorbit's ``node_mass``, max |dM| / max |M|: the
#: same products rho V / 20 summed in another order; measured 4.1e-16
SAME_MASS = 2e-15


class CantileverRun(BodyRun):
    """The runs and checks of ``elastic-cantilever`` (what its figure reads).

    ``meshes`` maps each mesh of the convergence study (nu of the case) to its record:
    ``omega_ref`` (the referee's discrete frequencies with the base), ``omega_clamped``,
    ``omega`` (emorbit's, measured), ``spatial`` (emorbit's with the time step's error removed),
    ``h`` (the cell size along the beam, m); ``poisson_run`` the same for the run at another nu.
    """

    def __init__(self, case, mode, scale, outdir, young_factor: float = 1.0):
        super().__init__(case, mode, scale, outdir)
        self.young_factor = young_factor
        self.meshes: dict = {}
        self.poisson_run: dict | None = None

    def _one(self, elements, poisson):
        s = self.case.settings
        ref = CantileverReferee(s, elements, poisson, self.young_factor)
        guess = self.theory["omega"][0]
        omega, phi, zfrac, unc = ref.modes(guess)
        clamped = ref.clamped(guess)
        dt = 2 * math.pi / omega[1] / s["steps_per_period"]
        steps = int(round(s["periods"] * 2 * math.pi / omega[0] / dt))
        tr = self.add(run_cantilever(s, ref, poisson, omega, phi, dt, steps))
        measured = np.asarray(tr.info["omega"])
        tr.info.update(
            omega_ref=omega.tolist(),
            omega_clamped=clamped.tolist(),
            z_fraction=zfrac.tolist(),
            referee_error=unc.tolist(),
        )
        xs = ref.X[ref.free, 0]
        stations = np.unique(np.round(xs / s["length"], 12))
        z = phi[: 3 * ref.nf].reshape(ref.nf, 3, 2)[:, 2, :]
        shape = np.array([z[np.isclose(xs / s["length"], x)].mean(axis=0) for x in stations])
        return {
            "shape_x": np.concatenate([[0.0], stations]),
            "shape": np.vstack([np.zeros((1, 2)), shape / shape[-1]]),
            "label": tr.label,
            "elements": tuple(elements),
            "poisson": poisson,
            "h": s["length"] / elements[0],
            "omega_ref": omega,
            "referee_error": unc,
            "omega_clamped": clamped,
            "carried": common.midpoint_frequency(omega, dt),
            "omega": measured,
            "spatial": common.spatial_frequency(measured, dt),
        }

    def run(self):
        """Solve the referee and run emorbit on every mesh (and at the other nu), then the checks."""
        s = self.case.settings
        self.theory = euler_bernoulli(s, self.young_factor * s["young"])
        t0 = time.perf_counter()
        for el in s["meshes"]:
            self.meshes[tuple(el)] = self._one(el, s["poisson"])
        if s.get("poisson_run"):
            el, nu = s["poisson_run"]
            self.poisson_run = self._one(el, nu)
        self.timing["em_s"] = time.perf_counter() - t0
        records = list(self.meshes.values()) + ([self.poisson_run] if self.poisson_run else [])
        worst = max(float(abs(tr.info["mass_matrix_deviation"])) for tr in self.runs.values())
        self.check(
            "mass-matrix",
            "emorbit's consistent mass matrix of the beam (ElasticSpec.node_mass) against the referee's rho V / 20 "
            "(1 + delta_ab), max |dM| / max |M|, every mesh",
            "the referee's assembly",
            worst,
            SAME_MASS,
            "1",
            "the same products summed in another order: a few eps (measured 4.1e-16); the referee's modes "
            "project emorbit's records through this matrix",
        )
        dev = {r["label"]: np.abs(r["omega"] / r["carried"] - 1) for r in records}
        own = max(float(r["referee_error"].max()) for r in records)
        self.check(
            "frequency-discrete",
            "emorbit's first two bending frequencies (sinusoids fitted to the modal coordinates of the recorded "
            "nodes and base) against the referee's discrete modes of the same mesh and base, every mesh, worst "
            "|w / w_h - 1|",
            "the referee's eigenfrequencies carried by the midpoint rule, w_h = (2 / h) atan(w h / 2)",
            max(float(d.max()) for d in dev.values()),
            CANTILEVER_FREQUENCY + 2 * own,
            "1",
            "the fits' precision at tip amplitude 1e-6 L (round-off in the strain below it, the beam's geometric "
            "nonlinearity above: measured 4.3e-10 up to 80 x 1 x 8 cells, 2e-9 at 1e-7 L, 1e-9 at 1e-5 L; "
            f"{CANTILEVER_FREQUENCY:g}) plus twice the referee's own error (its Rayleigh quotient against its "
            f"eigenvalue, worst mesh: {own:.2g}); the referee's E 1e-3 off moves w by 5e-4",
            "; ".join(f"{k}: " + ", ".join(f"{x:.2g}" for x in d) for k, d in dev.items()),
        )
        self._convergence()
        self.metric(
            "base.mass_ratio_effect",
            max(float(np.abs(r["omega_clamped"] / r["omega_ref"] - 1).max()) for r in records),
            "1",
            f"the referee's clamped beam against beam and base (base {s['base_ratio']:g} times the beam's mass, "
            "a box of edge 0.5 m): |w_clamped / w_base - 1|, worst mode and mesh",
        )
        common.invariant_checks(self, s["drift_tolerance"])

    def _convergence(self):
        s = self.case.settings
        recs = list(self.meshes.values())
        th = self.theory
        errs = np.array([r["spatial"] / th["omega"] - 1 for r in recs])  # (meshes, 2)
        self.convergence = {
            "h": [r["h"] for r in recs],
            "elements": [list(r["elements"]) for r in recs],
            "error_vs_euler_bernoulli": errs.tolist(),
            "delta_timoshenko": th["delta"].tolist(),
        }
        if len(recs) < 3:
            return
        w = np.array([r["spatial"] for r in recs[-3:]])  # (3, 2): coarse, middle, fine
        p = np.log2((w[0] - w[1]) / (w[1] - w[2]))
        self.convergence["observed"] = p.tolist()
        labels = ", ".join(r["label"].split(",")[0] for r in recs[-3:])
        self.check(
            "order",
            f"observed order of emorbit's bending frequencies under refinement (cell size halved in every "
            f"direction: {labels}), |p - 2| worst of the two modes, p = log2((w1 - w2) / (w2 - w3))",
            "order 2 (linear tetrahedra: frequency error O(h^2))",
            float(np.abs(p - 2).max()),
            s["order_tolerance"],
            "1 (order)",
            "linear tetrahedra lock in bending and reach their rate 2 from below as the thickness fills with "
            f"elements: measured {s['order_measured']}; the tolerance is about 2 times that",
            ", ".join(f"mode {k + 1}: {x:.3f}" for k, x in enumerate(p)),
        )
        fine, middle = w[2], w[1]
        rich2 = fine + (fine - middle) / 3
        richp = fine + (fine - middle) / (2.0**p - 1)
        spread = np.abs(rich2 - richp)
        self.convergence.update(richardson=rich2.tolist(), richardson_observed=richp.tolist())
        for k in range(2):
            dev = rich2[k] / th["omega"][k] - 1
            timo = rich2[k] / (th["omega"][k] * (1 + th["delta"][k])) - 1
            self.check(
                f"euler-bernoulli-mode{k + 1}",
                f"bending mode {k + 1}: emorbit's frequencies on the two finest meshes extrapolated to h = 0 "
                "(Richardson at order 2), |w_R / w_EB - 1|",
                f"Euler-Bernoulli, (beta L)^2 sqrt(E I / (rho A L^4)), beta L = {th['beta_L'][k]:.6f}: "
                f"{th['omega'][k]:.6g} rad/s",
                abs(dev),
                abs(th["delta"][k]) + spread[k] / th["omega"][k],
                "1",
                f"the theory's truncation, Timoshenko's shear and rotary-inertia correction {th['delta'][k]:.3g} "
                f"(slenderness L / t = {s['length'] / s['thickness']:g}), plus the extrapolation's uncertainty "
                f"{spread[k] / th['omega'][k]:.3g} (order 2 against the observed order {p[k]:.3f})",
                f"w_R = {rich2[k]:.8g} rad/s (observed order: {richp[k]:.8g}); against Euler-Bernoulli with the "
                f"Timoshenko correction: {timo:.3g}",
            )
            self.metric(f"timoshenko.mode{k + 1}", abs(timo), "1", "|w_R / (w_EB (1 + delta)) - 1|")


def cantilever_case(mode: str) -> BodyCase:
    """The case ``elastic-cantilever`` of a mode (quick: 20 x 1 x 2 to 80 x 1 x 8 cells; full: to 160 x 1 x 16)."""
    E, rho, L, b, t = 70e9, 2700.0, 1.0, 0.1, 0.05
    meshes = [(20, 1, 2), (40, 1, 4), (80, 1, 8)] + ([(160, 1, 16)] if mode == "full" else [])
    settings = {
        "young": E,
        "density": rho,
        "poisson": 0.0,
        "length": L,
        "width": b,
        "thickness": t,
        "base_size": 0.5,
        "base_ratio": 1e6,
        "tip": 1e-6,
        "steps_per_period": 16 if mode == "quick" else 24,
        "periods": 1.5 if mode == "quick" else 2,
        "meshes": meshes,
        "poisson_run": ((20, 1, 2), 0.3),
        "order_tolerance": 0.5 if mode == "quick" else 0.2,
        "order_measured": "1.72 and 1.71 from 2 to 8 elements across the thickness"
        if mode == "quick"
        else "1.91 and 1.90 from 4 to 16",
        "drift_tolerance": {
            "energy": 250.0 if mode == "quick" else 4000.0,
            "momentum": 0.2,
            "angular-momentum": 0.4,
            "measured": (31.0 if mode == "quick" else 447.0, 0.036, 0.048),
            "note": "the scale counts a rounding of eps in the strain, but coordinates rounded at eps of the beam's "
            "1 m move an element of size h by eps L / h: the drift grows under refinement (measured up to 1.8, 2.4, 31 "
            "and 447 eps from 20 x 1 x 2 to 160 x 1 x 16 cells)",
        },
    }
    theory = euler_bernoulli(settings, E)
    return BodyCase(
        name="elastic-cantilever",
        module="elastic_bodies",
        title="Bending of a cantilever of tetrahedra against Euler-Bernoulli, under refinement",
        description=(
            f"A beam {L:g} x {b:g} x {t:g} m (E = {E / 1e9:g} GPa, nu = 0, rho = {rho:g} kg/m3) of linear tetrahedra "
            '(`add_elastic(..., "beam")`, 6 per cell), its root face attached (`attach(..., "x-min", ...)`) to a '
            "rigid box of edge 0.5 m and 1e6 times its mass, in free space; meshes of "
            + ", ".join(f"{nx} x {ny} x {nz}" for nx, ny, nz in meshes)
            + " cells (the cell size halved in every direction at each step). Its first two bending modes across "
            "the thickness start at tip amplitude 1e-6 L each. emorbit's frequencies (fitted to the modal "
            "coordinates of the recorded nodes and base) are checked against the referee's discrete modes of the "
            "same mesh and base (its own assembly of the linearised SVK stiffness and consistent mass, "
            "scipy's eigsh), a run at nu = 0.3 included; then, with the step's error removed, their order of "
            "convergence and their Richardson extrapolation against Euler-Bernoulli, (beta L)^2 sqrt(E I / (rho A "
            f"L^4)) = {theory['omega'][0]:.6g} and {theory['omega'][1]:.6g} rad/s, within Timoshenko's shear and "
            "rotary-inertia correction. nu = 0 makes the solid's bending stress uniaxial, as beam theory assumes."
        ),
        period=2 * math.pi / theory["omega"][0],
        params={
            "beam L x b x t": f"{L:g} x {b:g} x {t:g} m",
            "E, nu, rho": f"{E:g} Pa, 0 (and 0.3 on the coarsest mesh), {rho:g} kg/m3",
            "base": "rigid box, edge 0.5 m, 1e6 times the beam's mass",
            "meshes (cells)": ", ".join(f"{nx} x {ny} x {nz}" for nx, ny, nz in meshes),
            "Euler-Bernoulli w_1, w_2": f"{theory['omega'][0]:.8g}, {theory['omega'][1]:.8g} rad/s",
            "Timoshenko delta_1, delta_2": f"{theory['delta'][0]:.4g}, {theory['delta'][1]:.4g}",
            "step, run": f"T_2 / {settings['steps_per_period']} of each mesh's second mode, "
            f"{settings['periods']} periods of its first, em order 2",
        },
        settings=settings,
    )
