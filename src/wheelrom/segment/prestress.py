"""Rotating segment: centrifugal prestress, stress stiffening and spin softening.

At rotor speed ``Omega = 2 pi wheel.speed_hz`` about ``z`` (no Coriolis, as the paper):

1. static centrifugal load ``f = int rho Omega^2 (x, y, 0) . v dV`` on the segment closed onto
   itself by the cut-face springs at ND 0 (the wheel's cyclic-symmetric static state; free cut
   faces would lose the disc's hoop stress); linear solve with PETSc KSP (Cholesky/MUMPS,
   prefix ``prestress_``);
2. its stress ``S = lambda tr(eps) I + 2 mu eps`` at the quadrature points gives the geometric
   (stress-stiffening) matrix ``K_sigma[a i, b j] = delta_ij int S_kl dN_a/dx_k dN_b/dx_l dV``;
3. spin softening ``M_s``: the mass matrix of the in-plane components ``x, y``.

The segment modes are then those of ``K + K_sigma - Omega^2 M_s`` with the unchanged ``M``.
Checked against the Southwell relation of a rotating cantilever (tests).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from wheelrom.segment.assembly import SegmentMatrices, basis_arrays, scalar_to_vector, scatter
from wheelrom.segment.mesh import SegmentMesh
from wheelrom.segment.petsc import direct_solve
from wheelrom.segment.springs import phase_stiffness, spring_parts


def centrifugal_load(seg: SegmentMesh, density: float, omega: float, arrays=None) -> np.ndarray:
    """``(n_dofs,)`` consistent nodal forces [N] of ``rho Omega^2 (x, y, 0)``.

    ``arrays``: :func:`~wheelrom.segment.assembly.basis_arrays` of ``seg`` when already at hand."""
    values, _, dx, dofs, bs = arrays or basis_arrays(seg)
    xq = bs.mapping.F(bs.X)  # (3, nel, nq) quadrature point coordinates
    f = np.zeros(seg.n_dofs)
    for c in (0, 1):
        loc = np.einsum("aeq,eq->ea", values, density * omega**2 * xq[c] * dx)
        np.add.at(f, dofs[:, c::3], loc)
    return f


def spin_softening_mass(seg: SegmentMesh, density: float, arrays=None) -> sp.csr_matrix:
    """``M_s``: consistent mass of the ``x`` and ``y`` components only [kg]."""
    values, _, dx, dofs, _ = arrays or basis_arrays(seg)
    m_loc = density * np.einsum("aeq,beq->eab", values * dx[None], values, optimize=True)
    return scatter(scalar_to_vector(m_loc, (1.0, 1.0, 0.0)), dofs, seg.n_dofs)


def gauss_stress(seg: SegmentMesh, young: float, poisson: float, u: np.ndarray,
                 arrays=None) -> np.ndarray:
    """``(nel, nq, 3, 3)`` linear-elastic stress [Pa] of the displacement ``u`` ``(n_dofs,)``
    at the Gauss points."""
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    _, grads, dx, dofs, _ = arrays or basis_arrays(seg)
    U = u[dofs].reshape(len(dofs), -1, 3)  # (nel, nb, 3)
    G = np.einsum("eai,akeq->eqik", U, grads, optimize=True)  # du_i/dx_k
    eps = 0.5 * (G + G.transpose(0, 1, 3, 2))
    tr = np.trace(eps, axis1=2, axis2=3)
    return 2 * mu * eps + lam * tr[:, :, None, None] * np.eye(3)


def von_mises(S: np.ndarray) -> np.ndarray:
    """Von Mises stress ``sqrt(3/2 s:s)`` (``s`` the deviator) of stresses ``(..., 3, 3)``."""
    dev = S - np.trace(S, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) / 3
    return np.sqrt(1.5 * np.einsum("...ij,...ij->...", dev, dev))


def geometric_stiffness(seg: SegmentMesh, young: float, poisson: float, u: np.ndarray,
                        arrays=None) -> sp.csr_matrix:
    """``K_sigma`` [N/m] of the stress of the displacement ``u`` ``(n_dofs,)``."""
    _, grads, dx, dofs, _ = arrays or basis_arrays(seg)
    S = gauss_stress(seg, young, poisson, u, arrays)
    g_loc = np.einsum("akeq,eqkl,bleq,eq->eab", grads, S, grads, dx, optimize=True)
    return scatter(scalar_to_vector(g_loc), dofs, seg.n_dofs)


@dataclass
class Prestress:
    """Static centrifugal state and the matrices it adds (free DOFs, scipy CSR)."""

    omega: float
    displacement: np.ndarray  # (n_dofs,) [m]
    K_sigma: sp.csr_matrix
    M_spin: sp.csr_matrix
    residual: float
    solve_s: float
    peak_von_mises: float = 0.0  # [Pa] largest over the Gauss points
    peak_radius: float = 0.0  # [m] distance from the axis of the element where it occurs
    element_von_mises: np.ndarray | None = None  # (n_elements,) [Pa] largest per element
    element_radius: np.ndarray | None = None  # (n_elements,) [m] element centre's radius

    def peak_where(self, mask: np.ndarray) -> tuple[float, float]:
        """Largest von Mises stress [Pa] over the elements of ``mask`` and its radius [m]."""
        vm = np.where(mask, self.element_von_mises, -np.inf)
        k = int(np.argmax(vm))
        return float(vm[k]), float(self.element_radius[k])

    def stiffness(self, mats: SegmentMatrices) -> sp.csr_matrix:
        """``K + K_sigma - Omega^2 M_s`` on the free DOFs."""
        K = mats.K + self.K_sigma - self.omega**2 * self.M_spin
        return ((K + K.T) * 0.5).tocsr()


def prestress(seg: SegmentMesh, mats: SegmentMatrices, young: float, poisson: float,
              density: float, omega: float, c1: float, comm,
              prefix: str = "prestress_") -> Prestress:
    """Centrifugal static solve at ``omega`` [rad/s] and the prestress matrices."""
    t0 = time.perf_counter()
    arrays = basis_arrays(seg)
    f = centrifugal_load(seg, density, omega, arrays)[mats.free]
    if seg.sectors > 1 and "left" in seg.node_sets:  # ND 0: the sector closed onto itself
        A, _ = phase_stiffness(mats, spring_parts(seg, mats, c1), 0.0)
    else:
        A = mats.K
    u = direct_solve(A, f, comm, prefix)[:, 0]
    residual = float(np.linalg.norm(A @ u - f) / max(np.linalg.norm(f), 1e-300))
    u_full = mats.expand(u)
    Ks = geometric_stiffness(seg, young, poisson, u_full, arrays)[mats.free][:, mats.free]
    Ms = spin_softening_mass(seg, density, arrays)[mats.free][:, mats.free]
    stress = von_mises(gauss_stress(seg, young, poisson, u_full, arrays)).max(axis=1)  # (nel,)
    centres = seg.nodes[seg.quadratic_cells()].mean(axis=1)
    radius = np.hypot(centres[:, 0], centres[:, 1])
    element = int(np.argmax(stress))
    return Prestress(omega, u_full, Ks.tocsr(), Ms.tocsr(), residual, time.perf_counter() - t0,
                     float(stress[element]), float(radius[element]), stress,
                     radius)
