"""The force models of the ``perturbed`` bench section (:mod:`.perturbed`), for the engines
that are not emorbit: one set of formulas, evaluated on floats (scipy's DOP853, REBOUND's
IAS15 through a Python callback) and on heyoka's expressions (its Taylor integrator).

Every constant is read from the emorbit simulation of the case, after its effects have
sampled their tables (:meth:`Model.from_simulation`): GM and the centre of the central field;
the zonal effect's pole, radius and J_2..J_N; the drag effect's rotation vector, sphere
radius and its single exponential band (h0, rho0, H); the radiation pressure's P at 1 au,
the au, the occulting radius and the cylindrical shadow; the rotating gravity field's GM,
radius, degree N, order M, its fully normalised C_nm and S_nm as the effect loaded them
(:mod:`emorbit.io.icgem`), its frame B and P, its angle at time 0 and its rate; each third
body's GM and indirect flag; and the Sun's and the Moon's sampled paths themselves (the
effects' tables), which every engine interpolates with the same cubic Hermite polynomials as
:func:`emorbit.kernels.effects.third_body.table_position`. The forces, per unit mass, at a
position x (d = x - c) and velocity v at time t:

* central: ``-GM d / r^3``;
* zonal: ``-grad (GM / r) sum_n J_n (R / r)^n P_n(z / r)``, ``z = d . p``, with Legendre's
  recursions for P_n and P_n';
* rotating field (degrees 1..N, orders 0..M, uniform rotation): ``g = Q^T grad_y U(y)``,
  ``y = Q d``, ``Q = P Rz(theta)^T B^T``, ``theta = theta0 + w t``, with ``U = (mu / R) sum
  (C_nm V_nm + S_nm W_nm)`` and its gradient by Cunningham's recursions of the solid harmonics
  V_nm, W_nm (Montenbruck and Gill, section 3.2; C, S unnormalised by
  ``sqrt((2 - delta_m0) (2n + 1) (n - m)! / (n + m)!)``), on floats and on heyoka's expressions
  (theta of ``heyoka.time``);
* drag: ``-1/2 rho B |u| u``, ``u = v - w x d``, ``rho = rho0 exp(-(r - R - h0) / H)``;
* radiation pressure: ``nu P_au (au / q)^2 C (d - s) / q``, ``q = |d - s|``, ``nu`` 0 in the
  cylinder behind the central body (``d . s < 0`` and the distance from the Sun's line below
  the occulting radius), else 1;
* a third body at s(t): ``gm ((s - d) / |s - d|^3 - s / |s|^3)`` (the indirect term where the
  effect has it), from the potential ``U = -gm (1 / |s - d| - 1 / |s| - d . s / |s|^3)``.

The energy per unit mass is ``E = v^2 / 2 - GM / r + V_zonal - U_field + sum U``; its rate is
the power of drag and radiation pressure, plus the field's turning, ``-dU_field/dt = w e3 . (d x
g)`` (the work_<label> emorbit records for it), plus ``sum dU/dt = grad_s U . s'(t)``
(:meth:`Model.power`),
which the peers integrate as a seventh state, the work W, so that ``E - E0 - W`` is their
energy balance as emorbit's is its own. heyoka's expressions take the paths' Hermite rows
and the shadow as runtime parameters, set per sample interval and at the shadow's edges
(terminal events): :func:`heyoka_system`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Table", "hermite", "Model", "heyoka_system", "em_acceleration"]


@dataclass(frozen=True)
class Table:
    """A sampled path: positions and velocities (rows of 6) at the times ``(k0 + j) step``."""

    step: float
    k0: float
    tab: np.ndarray

    def rows(self, t: float) -> tuple[int, float]:
        """The row j and the fraction f of the interval that holds t (as the kernel clamps)."""
        s = t / self.step
        kf = math.floor(s)
        f = s - kf
        j = int(kf - self.k0)
        last = self.tab.shape[0] - 2
        if j < 0:
            f, j = f + j, 0
        elif j > last:
            f, j = f + j - last, last
        return j, f

    def state(self, t: float):
        """Position and velocity on the path at t."""
        j, f = self.rows(t)
        return hermite(self.tab[j], self.tab[j + 1], f, self.step)


def hermite(r0, r1, f, step):
    """Position and velocity of the cubic Hermite polynomial between rows r0 and r1 (6 values
    each) at the fraction f of the interval: floats or heyoka expressions."""
    f2 = f * f
    f3 = f2 * f
    h00, h10, h01, h11 = 2.0 * f3 - 3.0 * f2 + 1.0, f3 - 2.0 * f2 + f, 3.0 * f2 - 2.0 * f3, f3 - f2
    d00, d10, d01, d11 = 6.0 * f2 - 6.0 * f, 3.0 * f2 - 4.0 * f + 1.0, 6.0 * f - 6.0 * f2, 3.0 * f2 - 2.0 * f
    pos = [h00 * r0[k] + h01 * r1[k] + step * (h10 * r0[k + 3] + h11 * r1[k + 3]) for k in range(3)]
    vel = [(d00 * r0[k] + d01 * r1[k]) / step + d10 * r0[k + 3] + d11 * r1[k + 3] for k in range(3)]
    return pos, vel


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@dataclass
class Model:
    """One case's force model, read from the emorbit simulation (:meth:`from_simulation`).

    Attributes
    ----------
    gm : float
        The central field's GM, m^3/s^2 (centre at the origin).
    zonal : tuple or None
        (pole (3,), R, (J2, ..., JN)).
    drag : tuple or None
        (B = Cd A / m, w (3,), R, h0, rho0, H).
    srp : tuple or None
        (C = Cr A / m, P_au, au, occulting radius, the Sun's :class:`Table`).
    bodies : list
        (gm, indirect, :class:`Table`) per third body.
    field : tuple or None
        The rotating field: (mu, R, N, M, C, S, B, P, theta0, w), C and S (N + 1, N + 1)
        unnormalised (C[n, m] for m <= M), B and P (3, 3) as the kernel's ``p`` holds them.
    """

    gm: float
    zonal: tuple | None
    drag: tuple | None
    srp: tuple | None
    bodies: list
    field: tuple | None = None

    @classmethod
    def from_simulation(cls, sim, coefficients: dict) -> Model:
        """The model of a simulation whose effects have sampled their tables.

        Parameters
        ----------
        sim : emorbit.Simulation
            With central, zonal, gravity_field (a uniform rotation: "earth" or "uniform"), drag
            (one exponential band), srp (cylindrical or no shadow) and third-body effects only;
            ``sim.effects.prepare`` called over the run (it sets the field's angle at time 0).
        coefficients : dict
            The point's ``ballistic_coefficient`` and ``radiation_coefficient`` (m^2/kg).

        Raises
        ------
        ValueError
            An effect or a setting the peers do not model (naming it).
        """
        gm, zonal, drag, srp, bodies, field = None, None, None, None, [], None
        for e in sim.effects.all:
            p = np.asarray(e.p, float)
            if e.kind == "central":
                gm = float(p[3])
            elif np.any(p[:3] != 0.0) if e.kind in ("zonal", "drag", "gravity_field") else False:
                raise ValueError(f"{e.key}: the peers' models put the centre at the origin")
            if e.kind == "gravity_field":
                if p[27] != 0.0:
                    raise ValueError(f"{e.key}.rotation: the peers model a uniform rotation only")
                field = _field_constants(p, np.asarray(e.tab, float))
            elif e.kind == "zonal":
                zonal = (p[3:6].copy(), float(p[7]), tuple(float(j) for j in p[8:]))
            elif e.kind == "drag":
                nb = int(p[13])
                if p[7] != 0.0 or nb != 1:
                    raise ValueError(f"{e.key}.atmosphere: the peers model one exponential band only")
                h0, rho0, scale = (float(e.tab[k]) for k in range(3))
                drag = (coefficients["ballistic_coefficient"], p[3:6].copy(), float(p[6]), h0, rho0, scale)
            elif e.kind == "srp":
                if p[4] == 2.0:
                    raise ValueError(f"{e.key}.shadow: the peers model the cylindrical shadow or none")
                rows = int(p[10])
                sun = Table(float(p[8]), float(p[9]), e.tab[: 6 * rows].reshape(rows, 6).copy())
                occ = float(p[2]) if p[4] == 1.0 else 0.0
                srp = (coefficients["radiation_coefficient"], float(p[0]), float(p[1]), occ, sun)
            elif e.kind == "third_body":
                rows = int(p[7])
                path = Table(float(p[5]), float(p[6]), e.tab[: 6 * rows].reshape(rows, 6).copy())
                bodies.append((float(p[0]), p[1] != 0.0, path))
            elif e.kind != "central":
                raise ValueError(f"{e.key}: the peers do not model {e.kind!r}")
        return cls(gm, zonal, drag, srp, bodies, field)

    def tables(self) -> list:
        """The sampled paths, the Sun's for radiation pressure first."""
        return ([self.srp[4]] if self.srp else []) + [b[2] for b in self.bodies]

    # -- the formulas, on floats or heyoka expressions ------------------------------------------
    def conservative(self, d, sqrt, paths, turn=None):
        """The conservative acceleration (3,) at d: central, zonal, the rotating field turned by
        ``turn`` (cos and sin of its angle: :meth:`turn`), third bodies at ``paths`` (their
        positions, in :attr:`bodies`' order)."""
        r2 = _dot(d, d)
        r = sqrt(r2)
        k = self.gm / (r2 * r)
        acc = [-k * d[0], -k * d[1], -k * d[2]]
        if self.zonal is not None:
            g = self._zonal(d, r, sqrt)
            acc = [acc[i] + g[i] for i in range(3)]
        if self.field is not None:
            g = self.field_acc(d, turn, sqrt)
            acc = [acc[i] + g[i] for i in range(3)]
        for (gm, indirect, _), s in zip(self.bodies, paths):
            q = [s[i] - d[i] for i in range(3)]
            q2 = _dot(q, q)
            kq = gm / (q2 * sqrt(q2))
            if indirect:
                s2 = _dot(s, s)
                ks = gm / (s2 * sqrt(s2))
                acc = [acc[i] + (kq * q[i] - ks * s[i]) for i in range(3)]
            else:
                acc = [acc[i] + kq * q[i] for i in range(3)]
        return acc

    def _legendre(self, u):
        """P_0..P_N and P'_0..P'_N at u."""
        n_max = len(self.zonal[2]) + 1
        pn, dpn = [1.0, u], [0.0, 1.0]
        for n in range(1, n_max):
            pn.append(((2 * n + 1) * u * pn[n] - n * pn[n - 1]) / (n + 1))
            dpn.append(dpn[n - 1] + (2 * n + 1) * pn[n])
        return pn, dpn

    def _zonal(self, d, r, sqrt):
        pole, radius, jn = self.zonal
        z = _dot(d, pole)
        u = z / r
        pn, dpn = self._legendre(u)
        inv = 1.0 / r
        radial, polar = 0.0, 0.0  # grad V = radial d + polar p
        rn = self.gm * inv  # GM / r (R / r)^n
        for n, j in enumerate(jn, start=2):
            rn_n = rn * (radius * inv) ** n
            radial = radial - (n + 1) * j * rn_n * pn[n] * inv * inv - j * rn_n * dpn[n] * z * inv * inv * inv
            polar = polar + j * rn_n * dpn[n] * inv
        return [-(radial * d[i] + polar * pole[i]) for i in range(3)]

    def zonal_potential(self, d, sqrt):
        """V_zonal per unit mass at d."""
        if self.zonal is None:
            return 0.0
        pole, radius, jn = self.zonal
        r = sqrt(_dot(d, d))
        pn, _ = self._legendre(_dot(d, pole) / r)
        return sum(self.gm / r * j * (radius / r) ** n * pn[n] for n, j in enumerate(jn, start=2))

    def turn(self, t, cos, sin):
        """cos and sin of the field's angle ``theta0 + w t`` (as the kernel forms it) at t, a
        float or heyoka's time."""
        theta = self.field[8] + self.field[9] * t
        return cos(theta), sin(theta)

    def _field_body(self, y, sqrt, grad: bool):
        """U and, where ``grad``, its gradient (3,) at y in the body's frame: Cunningham's
        recursions of V_nm, W_nm to degree N + 1 (Montenbruck and Gill, eqs. 3.29-3.33)."""
        mu, radius, n_max, m_max, C, S = self.field[:6]
        r2 = _dot(y, y)
        rho = radius * radius / r2
        x0, y0, z0 = (y[i] * radius / r2 for i in range(3))
        top = n_max + 1
        V = [[0.0] * (top + 2) for _ in range(top + 2)]
        W = [[0.0] * (top + 2) for _ in range(top + 2)]
        V[0][0] = radius / sqrt(r2)
        for m in range(top + 1):
            if m == 1:  # W_00 = 0
                V[1][1], W[1][1] = x0 * V[0][0], y0 * V[0][0]
            elif m > 1:
                V[m][m] = (2 * m - 1) * (x0 * V[m - 1][m - 1] - y0 * W[m - 1][m - 1])
                W[m][m] = (2 * m - 1) * (x0 * W[m - 1][m - 1] + y0 * V[m - 1][m - 1])
            if m + 1 <= top:
                V[m + 1][m] = (2 * m + 1) * z0 * V[m][m]
                W[m + 1][m] = (2 * m + 1) * z0 * W[m][m] if m > 0 else 0.0
            for n in range(m + 2, top + 1):
                V[n][m] = ((2 * n - 1) * z0 * V[n - 1][m] - (n + m - 1) * rho * V[n - 2][m]) / (n - m)
                if m > 0:
                    W[n][m] = ((2 * n - 1) * z0 * W[n - 1][m] - (n + m - 1) * rho * W[n - 2][m]) / (n - m)
        pot, gx, gy, gz = 0.0, 0.0, 0.0, 0.0
        for n in range(1, n_max + 1):
            for m in range(min(n, m_max) + 1):
                c, s = float(C[n, m]), float(S[n, m])
                if c == 0.0 and s == 0.0:
                    continue
                pot = pot + (c * V[n][m] + s * W[n][m] if m > 0 else c * V[n][m])
                if not grad:
                    continue
                if m == 0:
                    gx = gx - c * V[n + 1][1]
                    gy = gy - c * W[n + 1][1]
                    gz = gz - (n + 1) * c * V[n + 1][0]
                    continue
                f = (n - m + 2) * (n - m + 1)
                gx = gx + 0.5 * (
                    f * (c * V[n + 1][m - 1] + s * W[n + 1][m - 1]) - c * V[n + 1][m + 1] - s * W[n + 1][m + 1]
                )
                gy = gy + 0.5 * (
                    f * (s * V[n + 1][m - 1] - c * W[n + 1][m - 1]) + s * V[n + 1][m + 1] - c * W[n + 1][m + 1]
                )
                gz = gz - (n - m + 1) * (c * V[n + 1][m] + s * W[n + 1][m])
        k = mu / (radius * radius)
        return mu / radius * pot, [k * gx, k * gy, k * gz]

    def field_acc(self, d, turn, sqrt):
        """The rotating field's acceleration (3,) at d, its angle's (cos, sin) ``turn``."""
        B, P = self.field[6], self.field[7]
        y = _to_body(d, B, P, turn)
        return _to_inertial(self._field_body(y, sqrt, True)[1], B, P, turn)

    def field_potential(self, d, turn, sqrt):
        """The rotating field's U per unit mass at d (its potential energy is -U)."""
        if self.field is None:
            return 0.0
        return self._field_body(_to_body(d, self.field[6], self.field[7], turn), sqrt, False)[0]

    def field_power(self, d, turn, sqrt):
        """-dU/dt at fixed d, the field turning: ``w e3 . (d x g)``, e3 = B's third column."""
        w = self.field[9]
        e3 = [self.field[6][i][2] for i in range(3)]
        g = self.field_acc(d, turn, sqrt)
        cross = [d[1] * g[2] - d[2] * g[1], d[2] * g[0] - d[0] * g[2], d[0] * g[1] - d[1] * g[0]]
        return w * _dot(e3, cross)

    def drag_acc(self, d, v, sqrt, exp):
        """Drag per unit mass at d, v."""
        b, w, radius, h0, rho0, scale = self.drag
        u = [v[0] - (w[1] * d[2] - w[2] * d[1]), v[1] - (w[2] * d[0] - w[0] * d[2]), v[2] - (w[0] * d[1] - w[1] * d[0])]
        rho = rho0 * exp(-(sqrt(_dot(d, d)) - radius - h0) / scale)
        k = -0.5 * rho * b * sqrt(_dot(u, u))
        return [k * u[0], k * u[1], k * u[2]]

    def srp_acc(self, d, sun, nu, sqrt):
        """Radiation pressure per unit mass at d with the Sun at ``sun`` and the visible fraction nu."""
        c, p_au, au, _, _ = self.srp
        q = [d[i] - sun[i] for i in range(3)]
        q2 = _dot(q, q)
        k = nu * p_au * (au * au / q2) * c / sqrt(q2)
        return [k * q[0], k * q[1], k * q[2]]

    def shadow(self, d, sun) -> float:
        """The cylindrical shadow's nu at d (floats): 0 or 1."""
        occ = self.srp[3]
        s = math.sqrt(_dot(sun, sun))
        u = [sun[i] / s for i in range(3)]
        p = _dot(d, u)
        if occ == 0.0 or p >= 0.0:
            return 1.0
        return 0.0 if _dot(d, d) - p * p < occ * occ else 1.0

    def tidal(self, d, s, sv, sqrt):
        """Each third body's potential U per unit mass and its rate dU/dt = grad_s U . s'."""
        out = []
        for (gm, indirect, _), si, vi in zip(self.bodies, s, sv):
            q = [si[i] - d[i] for i in range(3)]
            q2, s2 = _dot(q, q), _dot(si, si)
            qn, sn = sqrt(q2), sqrt(s2)
            if indirect:
                ds = _dot(d, si)
                u = -gm * (1.0 / qn - 1.0 / sn - ds / (s2 * sn))
                g = [
                    -gm * (-q[i] / (q2 * qn) + si[i] / (s2 * sn) - d[i] / (s2 * sn) + 3.0 * ds * si[i] / (s2 * s2 * sn))
                    for i in range(3)
                ]
            else:
                u = -gm / qn
                g = [-gm * q[i] / (q2 * qn) for i in range(3)]
            out.append((u, _dot(g, vi)))
        return out

    # -- on floats -----------------------------------------------------------------------------
    def _paths(self, t):
        sun = self.srp[4].state(t)[0] if self.srp else None
        states = [b[2].state(t) for b in self.bodies]
        return sun, [s[0] for s in states], [s[1] for s in states]

    def _turn(self, t):
        return self.turn(t, math.cos, math.sin) if self.field is not None else None

    def acceleration(self, t: float, x, v) -> list:
        """The whole acceleration (3,) at time t, position x, velocity v (floats)."""
        sun, s, _ = self._paths(t)
        acc = self.conservative(x, math.sqrt, s, self._turn(t))
        if self.drag is not None:
            g = self.drag_acc(x, v, math.sqrt, math.exp)
            acc = [acc[i] + g[i] for i in range(3)]
        if self.srp is not None:
            g = self.srp_acc(x, sun, self.shadow(x, sun), math.sqrt)
            acc = [acc[i] + g[i] for i in range(3)]
        return acc

    def perturbation(self, t: float, x, v) -> list:
        """The acceleration less the central term (REBOUND's gravity gives that)."""
        r2 = _dot(x, x)
        k = self.gm / (r2 * math.sqrt(r2))
        acc = self.acceleration(t, x, v)
        return [acc[i] + k * x[i] for i in range(3)]

    def power(self, t: float, x, v) -> float:
        """dE/dt per unit mass: drag's and radiation pressure's power, the field's turning and
        the third bodies' dU/dt (floats)."""
        sun, s, sv = self._paths(t)
        out = sum(rate for _, rate in self.tidal(x, s, sv, math.sqrt))
        if self.field is not None:
            out += self.field_power(x, self._turn(t), math.sqrt)
        if self.drag is not None:
            out += _dot(self.drag_acc(x, v, math.sqrt, math.exp), v)
        if self.srp is not None:
            out += _dot(self.srp_acc(x, sun, self.shadow(x, sun), math.sqrt), v)
        return out

    def energy(self, t: float, x, v) -> float:
        """E per unit mass: kinetic, central, zonal, the field's and the third bodies' potentials
        (floats)."""
        _, s, sv = self._paths(t)
        e = 0.5 * _dot(v, v) - self.gm / math.sqrt(_dot(x, x)) + self.zonal_potential(x, math.sqrt)
        e -= self.field_potential(x, self._turn(t), math.sqrt)
        return e + sum(u for u, _ in self.tidal(x, s, sv, math.sqrt))

    def rhs(self, t: float, y) -> list:
        """The derivative of (x, v, W) for an ODE solver."""
        x, v = y[0:3], y[3:6]
        a = self.acceleration(t, x, v)
        return [v[0], v[1], v[2], a[0], a[1], a[2], self.power(t, x, v)]


def _field_constants(p, tab) -> tuple:
    """The rotating field's constants from the gravity_field effect's ``p`` and ``tab``
    (:mod:`emorbit.kernels.effects.gravity_field`'s layout): C and S unnormalised."""
    n_max, m_max = int(p[16]), int(p[17])
    size = (n_max + 1) * (n_max + 2) // 2
    C, S = np.zeros((n_max + 1, n_max + 1)), np.zeros((n_max + 1, n_max + 1))
    for n in range(n_max + 1):
        for m in range(min(n, m_max) + 1):
            k = n * (n + 1) // 2 + m
            scale = math.sqrt((2.0 - (m == 0)) * (2 * n + 1) * math.factorial(n - m) / math.factorial(n + m))
            C[n, m], S[n, m] = tab[k] * scale, tab[size + k] * scale
    B, P = p[3:12].reshape(3, 3).tolist(), p[18:27].reshape(3, 3).tolist()
    return float(p[14]), float(p[15]), n_max, m_max, C, S, B, P, float(p[12]), float(p[13])


def _mat(M, v, transpose: bool = False) -> list:
    """M v (or M^T v) for a float matrix (nested lists) and a vector of floats or expressions,
    skipping M's zeros (exact: the kernel's products by 0 add nothing)."""
    out = []
    for i in range(3):
        acc = None
        for j in range(3):
            a = M[j][i] if transpose else M[i][j]
            if a == 0.0:
                continue
            term = v[j] if a == 1.0 else a * v[j]
            acc = term if acc is None else acc + term
        out.append(0.0 if acc is None else acc)
    return out


def _to_body(d, B, P, turn) -> list:
    """``y = P Rz(theta)^T B^T d``, turn = (cos, sin) of theta."""
    cs, sn = turn
    b = _mat(B, d, True)
    return _mat(P, [cs * b[0] + sn * b[1], cs * b[1] - sn * b[0], b[2]])


def _to_inertial(g, B, P, turn) -> list:
    """``B Rz(theta) P^T g``."""
    cs, sn = turn
    q = _mat(P, g, True)
    return _mat(B, [cs * q[0] - sn * q[1], sn * q[0] + cs * q[1], q[2]])


# -- heyoka -------------------------------------------------------------------------------------
def heyoka_system(model: Model, hy):
    """heyoka's equations of (x, v, W) with the paths' rows and the shadow as parameters.

    Parameters
    ----------
    model : Model
    hy : module
        heyoka.

    Returns
    -------
    system : list
        ``[(var, rhs), ...]`` for ``taylor_adaptive``.
    set_pars : callable
        ``set_pars(pars, t)``: the paths' rows of the interval that starts at t, in place.
    shadow : tuple or None
        (the event's expression, the parameter's index of nu) where there is a shadow.
    """
    x, y, z, vx, vy, vz, w = hy.make_vars("x", "y", "z", "vx", "vy", "vz", "w")
    d, v = [x, y, z], [vx, vy, vz]
    tables = model.tables()
    paths = []
    for k, tb in enumerate(tables):
        base = 13 * k
        r0 = [hy.par[base + i] for i in range(6)]
        r1 = [hy.par[base + 6 + i] for i in range(6)]
        f = hy.time / tb.step - hy.par[base + 12]
        paths.append(hermite(r0, r1, f, tb.step))
    nu_index = 13 * len(tables)
    sun = paths[0][0] if model.srp else None
    bodies = paths[1:] if model.srp else paths
    turn = model.turn(hy.time, hy.cos, hy.sin) if model.field is not None else None
    acc = model.conservative(d, hy.sqrt, [p[0] for p in bodies], turn)
    power = sum((rate for _, rate in model.tidal(d, [p[0] for p in bodies], [p[1] for p in bodies], hy.sqrt)), 0.0)
    if model.field is not None:
        power = power + model.field_power(d, turn, hy.sqrt)
    if model.drag is not None:
        g = model.drag_acc(d, v, hy.sqrt, hy.exp)
        acc = [acc[i] + g[i] for i in range(3)]
        power = power + _dot(g, v)
    event = None
    if model.srp is not None:
        g = model.srp_acc(d, sun, hy.par[nu_index], hy.sqrt)
        acc = [acc[i] + g[i] for i in range(3)]
        power = power + _dot(g, v)
        if model.srp[3] > 0.0:  # the cylinder's surface: |d|^2 - (d . s)^2 / |s|^2 - R^2 = 0
            event = (_dot(d, d) - _dot(d, sun) ** 2 / _dot(sun, sun) - model.srp[3] ** 2, nu_index)

    def set_pars(pars, t: float) -> None:
        for k, tb in enumerate(tables):
            j = tb.rows(t)[0]
            pars[13 * k : 13 * k + 6] = tb.tab[j]
            pars[13 * k + 6 : 13 * k + 12] = tb.tab[j + 1]
            pars[13 * k + 12] = j + tb.k0  # f = t / step - (j + k0), as the kernel's

    system = [(x, vx), (y, vy), (z, vz), (vx, acc[0]), (vy, acc[1]), (vz, acc[2]), (w, power)]
    return system, set_pars, event


def em_acceleration(sim, values: dict, t: float, x, v, h: float = 10.0) -> np.ndarray:
    """emorbit's acceleration of the point ``sat`` at time t, position x, velocity v, from the
    compiled effect set: every effect at x0 = x1 = x (``MODE_EXPLICIT``), drag apart, on the
    chord x -+ v h / 2 of one step h (its midpoint x, its velocity v).

    Parameters
    ----------
    sim : emorbit.Simulation
        With its effects; ``sim.effects.prepare`` called over t.
    values : dict
        The point's keys (``ballistic_coefficient``, ``radiation_coefficient``).
    t : float
        s from the epoch.
    x, v : array_like
        (3,) m, m/s.
    h : float
        The chord's step for drag, s.

    Returns
    -------
    numpy.ndarray
        (3,) m/s^2.
    """
    from ..kernels.effects.atmosphere import drag_force
    from ..kernels.effects.blocks import run_forces
    from ..kernels.effects.signatures import MODE_EXPLICIT

    effects = sim.effects
    prog = effects.program()
    P, I, T, S = effects.arrays(1)
    coef = effects.coefficients("point", "sat", values)[:, None].copy()
    kinds = [e.kind for e in effects.all]
    xc = np.asarray(x, float).reshape(3, 1).copy()
    prog.prepare(t, t, t, P, I, T, S)
    F, W = np.zeros((3, 1)), np.zeros((9, 1))
    drag = kinds.index("drag") if "drag" in kinds else None
    b = 0.0
    if drag is not None:
        b, coef[drag, 0] = float(coef[drag, 0]), 0.0
    run_forces(
        prog.forces, xc, xc, np.ones(1), np.zeros(1, np.int64), coef, h, MODE_EXPLICIT, P, I, T, S, F, W, np.zeros(1),
        False, True,
    )  # fmt: skip
    acc = F[:, 0].copy()
    if drag is not None:
        e = effects.all[drag]
        p, nb = e.p, int(e.p[13])
        x0 = np.asarray(x, float) - 0.5 * h * np.asarray(v, float)
        x1 = np.asarray(x, float) + 0.5 * h * np.asarray(v, float)
        tab = e.tab
        acc += np.array(drag_force(*x0, *x1, h, *p[0:6], b, p[6], tab[0:nb], tab[nb : 2 * nb], tab[2 * nb : 3 * nb]))
    return acc
