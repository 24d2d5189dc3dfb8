"""Linear stability of a case: the static equilibrium under the contact preloads (nozzle
excluded), the analytic Jacobian there (:mod:`wheelrom.analysis.jacobian`) and its
eigenvalues per nodal diameter.

A tuned wheel with the same contact angles on every blade has a cyclic equilibrium, and its
Jacobian is block-circulant over the blades: with ``x_s = x_0 e^{i s phi}``,
``phi = 2 pi k / N``, the spectrum is the union over ``k`` of the eigenvalues of the
``2m x 2m`` blocks ``J(k) = sum_d J_{0,d} e^{i d phi}`` (LAPACK). ``k`` and ``N - k`` give
complex conjugates, so ND ``0..N/2`` hold every growth rate. A wheel that is not cyclic (or
as a check) goes through the assembled real ``2 N m`` Jacobian: SLEPc, non-Hermitian,
rightmost eigenvalues, options prefix ``stability_`` (:func:`rightmost_eigenvalues`, any
communicator).

Per eigenvalue ``lambda``: growth rate ``Re lambda`` [1/s] (> 0: the equilibrium is unstable,
the mode grows as ``e^{Re lambda t}``), frequency ``|Im lambda| / 2 pi`` [Hz], damping ratio
``-Re lambda / |lambda|``, and what the mode does: its tip amplitude, the normal and tangential
amplitudes of every contact kind's gap relative to the tip, and the share of each segment mode.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from wheelrom.analysis.jacobian import force_derivatives, jacobian
from wheelrom.config import Config
from wheelrom.forces.parameters import force_parameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.environment import petsc, slepc
from wheelrom.transient.preload import static_equilibrium

PREFIX = "stability_"


@dataclass
class StabilityResult:
    """One case's linear stability (``E`` eigenvalues: ``2 m`` per ND ``0..N/2``; ``K``
    contact kinds, ``N`` blades, ``m`` modes).

    ``angles_deg``: kind -> contact angle; ``equilibrium``: ``(N, m)`` static ``q``;
    ``residual``: its SNES residual; ``normal_force``, ``margin``: ``(K, N)`` [N], [m]
    (margin: normal opening left before lift-off, 0 = open); ``nodal_diameter`` ``(E,)``;
    ``eigenvalue`` ``(E,)`` complex [1/s]; ``growth_rate`` [1/s], ``frequency_hz``,
    ``damping_ratio`` ``(E,)``; ``tip_amplitude`` ``(E,)`` (eigenvector scaled to unit modal
    norm); ``contact_normal``, ``contact_tangential`` ``(E, K)`` gap amplitudes relative to
    the tip; ``modal_share`` ``(E, m)`` (rows sum to 1); ``cyclic``: per-ND blocks were used;
    ``wall_s``.
    """

    angles_deg: dict
    kinds: tuple
    equilibrium: np.ndarray
    residual: float
    normal_force: np.ndarray
    margin: np.ndarray
    nodal_diameter: np.ndarray
    eigenvalue: np.ndarray
    tip_amplitude: np.ndarray
    contact_normal: np.ndarray
    contact_tangential: np.ndarray
    modal_share: np.ndarray
    cyclic: bool
    wall_s: float = 0.0
    jacobian: object = field(default=None, repr=False)
    flutter_margin: object = None  # a margin.FlutterMargin when asked for

    @property
    def growth_rate(self) -> np.ndarray:
        return self.eigenvalue.real

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.eigenvalue.imag) / (2 * math.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        return -self.eigenvalue.real / np.maximum(np.abs(self.eigenvalue), 1e-300)

    def critical(self) -> int:
        """Index of the eigenvalue with the largest growth rate."""
        return int(np.argmax(self.growth_rate))

    def verdict(self, tolerance: float = 1e-6) -> str:
        """``"stable"`` or ``"unstable"``: any growth rate above ``tolerance`` [1/s]."""
        return "unstable" if self.growth_rate.max() > tolerance else "stable"

    def describe(self, i: int | None = None) -> str:
        """One line on eigenvalue ``i`` (default: the critical one) for people."""
        i = self.critical() if i is None else i
        parts = [f"ND {self.nodal_diameter[i]}", f"{self.frequency_hz[i]:.1f} Hz",
                 f"growth {self.growth_rate[i]:+.3g} /s"]
        for c, kind in enumerate(self.kinds):
            parts.append(f"{kind} gap n/t {self.contact_normal[i, c]:.2g}/"
                         f"{self.contact_tangential[i, c]:.2g} x tip")
        j = int(np.argmax(self.modal_share[i]))
        parts.append(f"mostly segment mode {j + 1} ({100 * self.modal_share[i, j]:.0f} %)")
        return ", ".join(parts)


def linearise(model: ReducedModel, cfg: Config, angles_deg: dict | None = None, comm=None,
              prefix: str = PREFIX):
    """``(params, q, residual, J, contacts)``: the case's force parameters with the nozzle
    off, its static equilibrium ``q`` ``(N, m)`` (SNES, options prefix ``<prefix>preload_``,
    analytic tangent), the sparse Jacobian there and the contact linearisations."""
    comm = comm or petsc().COMM_SELF
    params = force_parameters(model, cfg, angles_deg)
    params = dataclasses.replace(params, nozzle_force=0.0)  # the equilibrium, not the forcing
    N, m = model.blades, model.modes
    K = model.sparse_stiffness()  # the blade blocks only: no dense (N m)^2 array per case
    scale = float(max(1.0, params.contacts.preload.max(initial=1.0)))
    q, residual = static_equilibrium(
        ReferenceForces(params), K, comm, scale, prefix + "preload_",
        tangent=lambda q: force_derivatives(params, q, stiffness_only=True)[0],
    )
    q = q.reshape(N, m)
    Fq, Fv, contacts = force_derivatives(params, q)
    return params, q, residual, jacobian(K, cfg.wheel.damping_beta, Fq, Fv), contacts


def analyse(model: ReducedModel, cfg: Config, angles_deg: dict | None = None, comm=None,
            keep_jacobian: bool = False,
            linearised: tuple | None = None) -> StabilityResult:
    """The linear stability of one case (contact angles ``angles_deg``, kind -> [deg]);
    ``linearised``: what :func:`linearise` returned for it, when already computed."""
    t0 = time.perf_counter()
    params, q, residual, J, contacts = linearised or linearise(model, cfg, angles_deg, comm)
    N, m = q.shape
    cyclic = is_circulant(J, N, m)
    if cyclic:
        nds, values, _, blade, pair = nd_spectrum(blade_blocks(J, N, m))
    else:
        nds, values, _, blade, pair = _assembled_spectrum(J, N, m)
    tip, normal, tangential, share = _describe_modes(model, contacts, blade, pair)
    K = len(params.contacts.kinds)
    return StabilityResult(
        angles_deg={k: float(np.atleast_1d(v)[0]) for k, v in params.contacts.angles_deg.items()},
        kinds=params.contacts.kinds,
        equilibrium=q,
        residual=residual,
        normal_force=np.array([c.normal_force for c in contacts]).reshape(K, N),
        margin=np.array([c.margin for c in contacts]).reshape(K, N),
        nodal_diameter=nds,
        eigenvalue=values,
        tip_amplitude=tip,
        contact_normal=normal,
        contact_tangential=tangential,
        modal_share=share,
        cyclic=cyclic,
        wall_s=time.perf_counter() - t0,
        jacobian=J if keep_jacobian else None,
    )


def _blade_order(N: int, m: int) -> np.ndarray:
    """State indices blade by blade: ``(q_s, q'_s)`` of blade 0, then blade 1, ..."""
    n = N * m
    return np.concatenate([np.r_[s * m : (s + 1) * m, n + s * m : n + (s + 1) * m]
                           for s in range(N)])


def blade_blocks(J, N: int, m: int) -> np.ndarray:
    """``(N, 2m, 2m)`` the first block row of ``J`` (state ``(q, q')``, ``q`` blade-major):
    block ``d`` maps ``(q_d, q'_d)`` to ``(q'_0, q''_0)``."""
    order = _blade_order(N, m)
    J = sp.csr_matrix(J)
    row = J[order[: 2 * m]][:, order].toarray()  # (2m, 2Nm)
    return row.reshape(2 * m, N, 2 * m).transpose(1, 0, 2)


def is_circulant(J, N: int, m: int, rtol: float = 1e-10) -> bool:
    """Whether block ``[s, s + d]`` of ``J`` equals ``[0, d]`` for every ``s``, ``d`` (a tuned
    wheel): ``J`` in blade order is unchanged by a shift of one blade."""
    order = _blade_order(N, m)
    Jb = sp.csr_matrix(J)[order][:, order]
    shift = np.roll(np.arange(2 * N * m), 2 * m)
    difference = abs(Jb - Jb[shift][:, shift]).max()
    return bool(difference <= rtol * abs(Jb).max())


def nd_block(row: np.ndarray, k: int) -> np.ndarray:
    """``J(k) = sum_d J_{0,d} e^{i 2 pi k d / N}`` ``(2m, 2m)`` complex from the first block
    row ``(N, 2m, 2m)`` (:func:`blade_blocks`)."""
    N = row.shape[0]
    phase = np.exp(2j * math.pi * k * np.arange(N) / N)
    return np.einsum("d,dij->ij", phase, row)


def nd_spectrum(row: np.ndarray):
    """``(nd, eigenvalues, vectors, blade, pair)`` over ND ``0..N/2`` from the first block
    row (:func:`blade_blocks`): ``(E,)``, ``(E,)``, ``(E, 2m)`` (the blade-0 part
    ``(q_0, q'_0)`` of each Bloch mode), ``(E,)`` zeros (the blade described) and ``(E, 2m)``
    ``(q_0, q_1)`` with ``q_1 = q_0 e^{i 2 pi k / N}``."""
    N = row.shape[0]
    nds, values, vectors = [], [], []
    for k in range(N // 2 + 1):
        lam, vec = np.linalg.eig(nd_block(row, k))
        nds.append(np.full(lam.size, k))
        values.append(lam)
        vectors.append(vec.T)
    nds, values, vectors = np.concatenate(nds), np.concatenate(values), np.concatenate(vectors)
    m = vectors.shape[1] // 2
    q0 = vectors[:, :m]
    pair = np.concatenate([q0, q0 * np.exp(2j * math.pi * nds / N)[:, None]], axis=1)
    return nds, values, vectors, np.zeros(nds.size, dtype=int), pair


def _assembled_spectrum(J, N: int, m: int):
    """All eigenvalues of the assembled ``J`` (dense LAPACK), returned as by
    :func:`nd_spectrum`: the ND of a mode is the dominant Fourier harmonic of its ``q`` over
    the blades, the blade described is the one with the largest motion, ``pair`` its ``q``
    and the next blade's from the whole eigenvector (a mistuned mode is no Bloch wave)."""
    lam, vec = np.linalg.eig(J.toarray() if hasattr(J, "toarray") else J)
    n = N * m
    q = vec[:n].T.reshape(-1, N, m)
    spectrum = np.abs(np.fft.fft(q, axis=1)).sum(axis=2)  # (E, N)
    k = np.argmax(spectrum, axis=1)
    nds = np.minimum(k, N - k)
    blade = np.argmax(np.abs(q).sum(axis=2), axis=1)
    rows = np.arange(lam.size)
    v = vec[n:].T.reshape(-1, N, m)
    vectors = np.concatenate([q[rows, blade], v[rows, blade]], axis=1)
    pair = np.concatenate([q[rows, blade], q[rows, (blade + 1) % N]], axis=1)
    return nds, lam, vectors, blade, pair


def _describe_modes(model: ReducedModel, contacts, blade, pair):
    """Tip amplitude, contact gap amplitudes relative to the tip (normal, tangential, per
    kind: pair ``(blade, blade + 1)``) and segment-mode shares of every mode (see
    :class:`StabilityResult`); ``pair`` ``(E, 2m)``: ``(q_b, q_{b+1})`` of each mode."""
    m = model.modes
    scale = np.maximum(np.linalg.norm(pair[:, :m], axis=1, keepdims=True), 1e-300)
    pair = pair / scale  # q_b of unit norm
    q0 = pair[:, :m]
    tip = np.linalg.norm(q0 @ model.tip.T, axis=1)
    K, E = len(contacts), len(pair)
    normal, tangential = np.zeros((E, K)), np.zeros((E, K))
    for c in range(K):
        local = np.einsum("eij,ej->ei", contacts[c].gap_map[blade], pair)  # (E, 3) xi, eta, zeta
        normal[:, c] = np.abs(local[:, 1])
        tangential[:, c] = np.hypot(np.abs(local[:, 0]), np.abs(local[:, 2]))
    ref = np.maximum(tip, 1e-300)[:, None]
    share = np.abs(q0) ** 2
    return tip, normal / ref, tangential / ref, share / share.sum(axis=1, keepdims=True)


def rightmost_eigenvalues(J, comm, nev: int = 10, prefix: str = PREFIX,
                          ncv: int | None = None) -> np.ndarray:
    """The ``nev`` eigenvalues of largest real part of the assembled real ``J`` (scipy
    sparse, every rank holds it) with SLEPc on ``comm`` (non-Hermitian, Krylov-Schur;
    ``-stability_eps_*`` options apply, ``setFromOptions`` last). Complex ``(nev,)``."""
    from wheelrom.segment.petsc import to_petsc

    SLEPc = slepc()
    A = to_petsc(J.tocsr(), comm)
    eps = SLEPc.EPS().create(comm=comm)
    eps.setOptionsPrefix(prefix)
    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
    # the spectrum spreads along the imaginary axis (frequencies up to kHz) while the growth
    # rates are small: the rightmost eigenvalues need a wide subspace
    eps.setDimensions(nev=nev, ncv=ncv or min(J.shape[0], max(4 * nev, 200)))
    eps.setTolerances(tol=1e-12, max_it=5000)
    # rows of q and q' differ in scale by the frequencies (up to kHz), and ND k and N - k give
    # equal eigenvalue pairs: unbalanced, the Schur reordering of the projected problem can
    # fail (LAPACK trexc, measured on the 12-blade wheel); two-sided balancing is robust
    eps.setBalance(SLEPc.EPS.Balance.TWOSIDE)
    eps.setFromOptions()
    eps.solve()
    found = eps.getConverged()
    if found < nev:
        raise RuntimeError(f"{prefix}eps: only {found} of {nev} eigenvalues converged")
    values = np.array([complex(eps.getEigenvalue(i)) for i in range(nev)])
    eps.destroy()
    A.destroy()
    return values


STILL_GROWING = 0.25  # transient growth over its last half above this share of the linear rate
OPEN_FLUTTER = 0.2  # contact-open fraction in the last window that makes a limit cycle flutter


def classify(linear_rate: float, transient_rate: float, final_amplitude: float,
             open_fraction: dict) -> str:
    """A case from both analyses: ``"stable"`` (no growing linear mode); ``"flutter, still
    growing"`` (unstable and the transient still grows over its last half at more than a
    quarter of the linear rate: the run was too short to see where it ends); ``"small limit
    cycle"`` (unstable, saturated, every contact kind open less than 20 % of the last window)
    or ``"flutter, limit cycle"`` (saturated with contacts opening more), each with the
    vibration amplitude ``final_amplitude`` [m] (shown in um) and the open fractions.
    ``transient_rate`` [1/s]: the fastest ND component's growth over the last half."""
    if not np.isfinite(linear_rate):
        return "unknown (no linear analysis)"
    if linear_rate <= 1e-6:
        return "stable"
    if not np.isfinite(transient_rate):
        return f"unstable ({linear_rate:.3g} /s; the transient is too short to judge)"
    if transient_rate > STILL_GROWING * linear_rate:
        return (f"flutter, still growing ({transient_rate:.3g} /s at the end, linear "
                f"{linear_rate:.3g} /s)")
    opening = ", ".join(f"{k} open {100 * v:.0f} %" for k, v in open_fraction.items())
    kind = "small limit cycle" if max(open_fraction.values(), default=0.0) < OPEN_FLUTTER else (
        "flutter, limit cycle")
    return f"{kind} ({final_amplitude * 1e6:.3g} um; {opening})"
