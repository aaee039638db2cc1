"""The sparse linear algebra of a coupled structure (:mod:`emorbit.bodies.coupled`).

The Jacobian of a step has 3 unknowns per slot and 6 constraint multipliers per rigid body;
its sparsity pattern is built once (:func:`jacobian_pattern`) and Numba kernels fill its
values in place. :class:`EquilibratedLU` scales rows and columns to unit max-norm before
SuperLU factors the matrix, and measures residuals in that scaling. :class:`KeptFactors` holds
the factorisations that Newton's "reuse" mode keeps across steps, and turns them into arrays
for checkpoints and back.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError
from ..kernels import coupled as kc

__all__ = ["jacobian_pattern", "slot_pairs", "slot_pairs_fast", "EquilibratedLU", "KeptFactors", "align"]


def slot_pairs(node_slot, node_coef, a: int, b: int) -> list:
    """Every pair of the slots that nodes a and b are made of, with their coefficients.

    Parameters
    ----------
    node_slot : ndarray
        (n_nodes, 4) slots of each node (-1 unused).
    node_coef : ndarray
        (n_nodes, 4) their coefficients: a node is sum_i coef_i u[slot_i].
    a, b : int
        The nodes.

    Returns
    -------
    list of tuple
        (slot of a, slot of b, coefficient of a's slot, coefficient of b's slot).
    """
    out = []
    for i in range(4):
        si = node_slot[a, i]
        if si < 0:
            break
        for j in range(4):
            sj = node_slot[b, j]
            if sj < 0:
                break
            out.append((si, sj, node_coef[a, i], node_coef[b, j]))
    return out


def jacobian_pattern(Ms, node_slot, bar_node, tet_node, gp_node, rb_slots):
    """The sparsity pattern of a structure's Jacobian, and its mass part.

    Unknowns are the 3 components of every slot, then 6 constraint multipliers per rigid
    body. Blocks of 3 x 3 couple every two slots that share a mass-matrix entry, an element
    (bar, tetrahedron), a gravity point or a rigid body's axes; each multiplier couples to
    its body's axes.

    Parameters
    ----------
    Ms : scipy.sparse matrix
        (n_slots, n_slots) scalar mass matrix over the slots, kg.
    node_slot : ndarray
        (n_nodes, 4) slots of each node (-1 unused).
    bar_node, tet_node : ndarray
        (m, 2) and (k, 4) node indices of the elements.
    gp_node : ndarray
        (q, 4) node indices of the gravity points (-1 unused).
    rb_slots : ndarray
        (n_rigid, 4) slots of each rigid body (centre of mass, then its axes).

    Returns
    -------
    J : scipy.sparse.csc_matrix
        The pattern, zeros, with int64 index arrays and sorted indices.
    indices32, indptr32 : ndarray
        Its index arrays as int32, for SuperLU.
    J_mass : scipy.sparse.csc_matrix
        The mass part of the Jacobian (M times the identity in 3-D) on the pattern.
    """
    ns = Ms.shape[0]
    nr = rb_slots.shape[0]
    n = 3 * ns + 6 * nr
    pairs = []
    M = Ms.tocoo()
    pairs.append(np.stack([M.row, M.col], 1))
    if len(bar_node):
        a, b = bar_node[:, 0], bar_node[:, 1]
        pairs.append(slot_pairs_fast(node_slot, np.concatenate([a, a, b, b]), np.concatenate([a, b, a, b])))
    if len(tet_node):
        na = np.repeat(tet_node, 4, axis=1).ravel()
        nb = np.tile(tet_node, (1, 4)).ravel()
        pairs.append(slot_pairs_fast(node_slot, na, nb))
    for q in range(gp_node.shape[0]):
        nodes = gp_node[q][gp_node[q] >= 0]
        pairs.append(slot_pairs_fast(node_slot, np.repeat(nodes, nodes.size), np.tile(nodes, nodes.size)))
    for r in range(nr):
        d = rb_slots[r, 1:]
        pairs.append(np.stack([np.repeat(d, 3), np.tile(d, 3)], 1))
    P = np.unique(np.concatenate(pairs), axis=0)
    rr = np.repeat(3 * P[:, 0], 9) + np.tile(np.repeat(np.arange(3), 3), len(P))
    cc = np.repeat(3 * P[:, 1], 9) + np.tile(np.tile(np.arange(3), 3), len(P))
    rows = [rr]
    cols = [cc]
    for r in range(nr):
        base = 3 * ns + 6 * r
        for s in rb_slots[r, 1:]:
            for j in range(6):
                for d in range(3):
                    rows += [np.array([3 * s + d]), np.array([base + j])]
                    cols += [np.array([base + j]), np.array([3 * s + d])]
    R = np.concatenate(rows)
    C = np.concatenate(cols)
    pattern = sp.csc_matrix((np.ones(R.size), (R, C)), shape=(n, n))
    pattern.sum_duplicates()
    pattern.sort_indices()
    indptr32 = pattern.indptr.astype(np.int32)
    indices32 = pattern.indices.astype(np.int32)
    pattern.indptr = pattern.indptr.astype(np.int64)
    pattern.indices = pattern.indices.astype(np.int64)
    pattern.data[:] = 0.0
    # the mass part of the Jacobian, precomputed
    Mfull = sp.kron(Ms, sp.identity(3), format="coo")
    Mfull.resize((n, n))
    return pattern, indices32, indptr32, align(Mfull, pattern)


def slot_pairs_fast(node_slot, na, nb):
    """The slot pairs of many node pairs: every slot of one node with every slot of the other.

    Parameters
    ----------
    node_slot : ndarray
        (n_nodes, 4) slots of each node (-1 unused, dropped).
    na, nb : ndarray
        (P,) the node pairs.

    Returns
    -------
    ndarray
        (Q, 2) slot pairs.
    """
    ns = node_slot
    nc = ns.shape[1]
    si = ns[na]  # (P, 4)
    sj = ns[nb]
    I = np.repeat(si, nc, axis=1)
    Jm = np.tile(sj, (1, nc))
    ok = (I >= 0) & (Jm >= 0)
    return np.stack([I[ok], Jm[ok]], 1)


class EquilibratedLU:
    """Sparse LU factors of an equilibrated Jacobian.

    Rows and columns are scaled to unit max-norm first (as LAPACK's geequ does; SuperLU's
    factorisation alone does not), which lowers the condition number of structures that mix
    stiff elements, rigid-body axes and constraint impulses by orders of magnitude. The
    scaling runs in Numba on the CSC arrays: scipy's sparse-matrix bookkeeping costs more
    than the factorisations of small structures.

    Parameters
    ----------
    data, indices, indptr : ndarray
        The Jacobian in CSC form (int64 indices).
    n : int
        Its order.
    indices32, indptr32 : ndarray
        The same index arrays as int32, for SuperLU.
    """

    def __init__(self, data, indices, indptr, n, indices32, indptr32):
        self.r, self.c, scaled = kc.equilibrate(data, indices, indptr, n)
        self.lu = spla.splu(sp.csc_matrix((scaled, indices32, indptr32), shape=(n, n)))

    def solve(self, b):
        """The solution x of J x = b.

        Parameters
        ----------
        b : ndarray
            The right-hand side.

        Returns
        -------
        ndarray
            x.
        """
        return self.c * self.lu.solve(self.r * b)

    def norm(self, b) -> float:
        """The max-norm of a residual in the equilibrated scaling.

        Parameters
        ----------
        b : ndarray
            The residual.

        Returns
        -------
        float
            max |r_i b_i| over the rows.
        """
        return float(np.max(np.abs(self.r * b)))


class KeptFactors:
    """The solver state of Newton's "reuse" mode: kept factorisations and iteration counts.

    One factorisation is kept per sub-step size h, together with the Jacobian values it was
    made from; the iterations of the last step of each size decide whether a step starts
    with the kept factors. Factoring the same values again gives the same factors, so the
    values are the state: :meth:`arrays` writes them for a checkpoint and :meth:`load`
    factors them again, and a run continues bit for bit wherever its checkpoints fall.

    Attributes
    ----------
    lus : dict
        {h (s): EquilibratedLU}.
    data : dict
        {h (s): the Jacobian values (CSC order) that ``lus[h]`` factors}.
    its : dict
        {h (s): Newton iterations of the last step of size h}.
    """

    #: the checkpoint arrays, by name
    NAMES = ("lu_steps", "lu_jacobians", "last_iterations")

    def __init__(self):
        self.lus: dict = {}
        self.data: dict = {}
        self.its: dict = {}

    def keep(self, h: float, lu: EquilibratedLU, data) -> None:
        """Keep ``lu``, made from the values ``data``, for steps of size ``h``."""
        self.lus[h] = lu
        self.data[h] = data

    def drop(self, h: float) -> None:
        """Forget the factors for steps of size ``h``."""
        self.lus.pop(h, None)
        self.data.pop(h, None)

    def copy(self) -> KeptFactors:
        """A copy that later changes of this one leave alone (factors are shared, never changed)."""
        out = KeptFactors()
        out.lus, out.data, out.its = dict(self.lus), dict(self.data), dict(self.its)
        return out

    def arrays(self, nnz: int) -> dict[str, np.ndarray]:
        """The state as float64 arrays: ``lu_steps`` (k,) in s, ``lu_jacobians`` (k, nnz) and
        ``last_iterations`` (m, 2) of rows (h in s, iterations); h < 0 for the backward sub-steps
        of compositions."""
        hs = list(self.lus)
        return {
            "lu_steps": np.array(hs, dtype=float),
            "lu_jacobians": np.array([self.data[h] for h in hs], dtype=float).reshape(len(hs), nnz),
            "last_iterations": np.array(list(self.its.items()), dtype=float).reshape(-1, 2),
        }

    def load(self, arrays: dict, nnz: int, factor) -> None:
        """Restore what :meth:`arrays` wrote, factoring each kept Jacobian again.

        Parameters
        ----------
        arrays : dict
            {name: array}; names missing from it count as empty (no kept factors).
        nnz : int
            Nonzeros of the Jacobian's pattern.
        factor : callable
            ``factor(data) -> EquilibratedLU``.

        Raises
        ------
        InputError
            Arrays of the wrong shape, or values that are not finite (key ``checkpoint``).
        """
        hs = np.asarray(arrays.get("lu_steps", np.zeros(0)), dtype=float)
        jac = np.asarray(arrays.get("lu_jacobians", np.zeros((0, nnz))), dtype=float)
        its = np.asarray(arrays.get("last_iterations", np.zeros((0, 2))), dtype=float)
        if (
            hs.ndim != 1
            or jac.shape != (hs.size, nnz)
            or its.ndim != 2
            or its.shape[1] != 2
            or not (np.all(np.isfinite(hs)) and np.all(np.isfinite(jac)) and np.all(np.isfinite(its)))
            or np.any(hs == 0)
            or np.any(its[:, 0] == 0)
            or np.any(its[:, 1] < 0)
        ):
            raise InputError(
                "checkpoint",
                "the file's Newton state (structure/lu_steps, lu_jacobians, last_iterations) does not match "
                f"the structure ({nnz} Jacobian values per kept factorisation)",
            )
        self.lus, self.data, self.its = {}, {}, {}
        for h, d in zip(hs.tolist(), jac):
            d = np.ascontiguousarray(d)
            try:
                self.keep(h, factor(d), d)
            except RuntimeError:
                raise InputError("checkpoint", f"the kept Jacobian for steps of {h!r} s is singular") from None
        self.its = {h: int(n) for h, n in its.tolist()}


def align(A, pattern):
    """A sparse matrix's values on a pattern's CSC structure.

    Parameters
    ----------
    A : scipy.sparse matrix
        Its nonzeros must lie inside the pattern.
    pattern : scipy.sparse.csc_matrix
        With int64 index arrays.

    Returns
    -------
    scipy.sparse.csc_matrix
        A copy of the pattern holding A's values (zeros elsewhere).
    """
    out = pattern.copy()
    out.data[:] = 0.0
    A = A.tocoo()
    kc.scatter(
        A.row.astype(np.int64),
        A.col.astype(np.int64),
        A.data.astype(float),
        out.indptr.astype(np.int64),
        out.indices.astype(np.int64),
        out.data,
    )
    return out
