"""Floquet multipliers of a periodic orbit from the monodromy matrix of the whole wheel
(docs/theory.md, "Limit cycles: Floquet multipliers from the monodromy").

The monodromy ``M = d phi_T / d x0`` at the orbit is never formed: SLEPc (Krylov-Schur,
largest magnitude, options prefix ``limitcycle_floquet_``, ``setFromOptions`` last) works on
a shell matrix whose product is one linearised period, a finite-difference directional
derivative of the TS flow of all ``N`` blades::

    M v ~ (phi_T(x* + eps D v) - phi_T(x* - eps D v)) / (2 eps),      D = diag(a, omega a)

in the same scaled units as the shooting (``a`` the vibration amplitude; the eigenvalues do
not depend on the scaling). Each multiplier is labelled by the nodal diameter of its
eigenvector (the DFT over blades of the modal displacements, the ND of largest energy) and by
its wave index ``k`` (``0..N-1``). The trivial multiplier of the phase shift (``mu = 1``, the
eigenvector along the flow) is identified by the eigenvector's alignment with the vector field
and reported; the largest non-trivial modulus decides: stable when ``<= 1 + TOLERANCE``.

Unlike Hill's method this needs no Fourier series of the force derivatives, which converge
slowly when a contact opens within the period (their jumps): the flow is integrated through
the openings as the transient does.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.flow import WheelFlow
from wheelrom.analysis.periodic.shooting import Orbit, vibration_units
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel, nodal_diameter
from wheelrom.runtime.environment import petsc, slepc

PREFIX = "limitcycle_floquet_"
DIFFERENCE = 1e-6  # central-difference step, relative to the vibration amplitude
RESIDUAL = 1e-6  # relative eigen-residual of a converged multiplier
RESTARTS = 12  # Krylov-Schur restarts at most (about ncv / 2 linearised periods each)
#: modulus above 1 from which a multiplier counts as growing (the finite-difference
#: monodromy's own error: the trivial multiplier comes out within ~1e-6 of 1)
TOLERANCE = 1e-4


@dataclass
class Multipliers:
    """``values`` ``(E,)`` complex multipliers (largest modulus first); ``nd`` ``(E,)``,
    ``wave`` ``(E,)`` of their eigenvectors; ``trivial``: index of the phase shift's (-1: not
    among them); ``matvecs``: linearised periods integrated; ``wall_s``; ``converged``: the
    eigenpairs SLEPc converged (``values`` holds those)."""

    values: np.ndarray
    nd: np.ndarray
    wave: np.ndarray
    trivial: int
    period: float
    matvecs: int = 0
    wall_s: float = 0.0
    requested: int = 0
    by: str = "monodromy"
    alignment: np.ndarray = field(default_factory=lambda: np.zeros(0))
    trivial_check: float = math.nan  # |M f - f| for the unit flow direction f (scaled)
    step: float = math.nan  # the time step they were computed at [s]

    @property
    def trivial_error(self) -> float:
        """``|mu_0 - 1|`` of the phase shift's multiplier when it is among the computed ones,
        else ``|M f - f|`` along the flow direction ``f`` (0 for an exact orbit)."""
        if self.trivial >= 0:
            return abs(self.values[self.trivial] - 1.0)
        return self.trivial_check

    def nontrivial(self) -> np.ndarray:
        keep = np.ones(self.values.size, bool)
        if self.trivial >= 0:
            keep[self.trivial] = False
        return np.flatnonzero(keep)

    def top(self, count: int) -> Multipliers:
        """The ``count`` largest (``values`` are sorted); the phase shift's error kept when
        its multiplier is not among them."""
        if self.values.size <= count:
            return self
        trivial = self.trivial if self.trivial < count else -1
        return dataclasses.replace(
            self, values=self.values[:count], nd=self.nd[:count], wave=self.wave[:count],
            trivial=trivial, alignment=self.alignment[:count], trivial_check=self.trivial_error)

    @property
    def largest(self) -> float:
        """The largest non-trivial ``|mu|`` (0 when none)."""
        rest = self.nontrivial()
        return float(np.abs(self.values[rest]).max()) if rest.size else 0.0

    @property
    def worst(self) -> int:
        """Index of the largest non-trivial multiplier (-1: none)."""
        rest = self.nontrivial()
        return int(rest[np.argmax(np.abs(self.values[rest]))]) if rest.size else -1

    @property
    def stable(self) -> bool:
        return self.largest <= 1.0 + TOLERANCE

    @property
    def growth(self) -> float:
        """``ln |mu| / T`` [1/s] of the largest non-trivial multiplier."""
        return math.log(max(self.largest, 1e-300)) / self.period


def label_vectors(vectors: np.ndarray, blades: int, modes: int) -> tuple[np.ndarray, np.ndarray]:
    """``(nd, wave)`` of state vectors ``(E, 2 N m)`` (blade-major ``q`` then ``q'``): the
    wave index ``k`` of largest energy of the modal displacements' DFT over blades."""
    q = vectors[:, : blades * modes].reshape(-1, blades, modes)
    energy = (np.abs(np.fft.fft(q, axis=1)) ** 2).sum(axis=2)  # (E, N), index k: e^{-i..}
    k = np.argmax(energy, axis=1)
    # numpy's DFT is sum_s x_s e^{-2 pi i k s / N}: a wave x_s ~ e^{i s phi_k} shows at k
    return np.asarray(nodal_diameter(k, blades), int), k.astype(int)


class LinearisedPeriod:
    """The linearised period as a petsc4py shell matrix (scaled units): states flat
    (``q, q'`` and the elastic law's sliders when the flow carries them)."""

    def __init__(self, flow: WheelFlow, x_star: np.ndarray, period: float, steps: int,
                 scale: np.ndarray):
        self.flow, self.x, self.period, self.steps = flow, x_star.ravel(), period, steps
        self.scale = scale.ravel()
        self.count = 0

    def mult(self, mat, x, y):
        v = x.getArray(readonly=True)
        norm = float(np.linalg.norm(v))
        if norm == 0.0:
            y.set(0.0)
            return
        eps = DIFFERENCE / norm
        # central: both perturbed periods one batch of two (a forward difference was off by
        # 4e-5 on a Van der Pol multiplier, central by 1e-9)
        start = self.x[None] + np.outer([eps, -eps], self.scale * v)
        end = self.flow.advance(start, self.period, self.steps)
        y.setArray((end[0] - end[1]) / (2 * eps * self.scale))
        self.count += 1


def largest_eigenpairs(shell: LinearisedPeriod, n: int, count: int):
    """``(values, vectors (E, n))``: the converged eigenpairs of largest modulus of the shell's
    linearised period (SLEPc Krylov-Schur, prefix ``limitcycle_floquet_``), unsorted."""
    PETSc, SLEPc = petsc(), slepc()
    A = PETSc.Mat().createPython([n, n], shell, comm=PETSc.COMM_SELF)
    A.setUp()
    eps = SLEPc.EPS().create(comm=PETSc.COMM_SELF)
    eps.setOptionsPrefix(PREFIX)
    eps.setOperators(A)
    eps.setProblemType(SLEPc.EPS.ProblemType.NHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setDimensions(count, max(2 * count + 1, 16))
    # a bounded effort: a weakly unstable cycle has hundreds of multipliers within 1 % of
    # the unit circle (the lightly damped modes of every ND), among which Krylov-Schur
    # converges slowly; the largest, which decide, come first (the rest: those converged)
    eps.setTolerances(RESIDUAL, RESTARTS)
    # a deterministic start: the same multipliers for the same orbit on every rank
    start = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
    start.setArray(np.random.default_rng(0).standard_normal(n))
    eps.setInitialSpace([start])
    eps.setFromOptions()
    eps.solve()
    vr, vi = A.createVecs()
    values, vectors = [], []
    for i in range(eps.getConverged()):
        value = eps.getEigenpair(i, vr, vi)
        values.append(complex(value))
        vectors.append(vr.getArray().copy() + 1j * vi.getArray().copy())
    for obj in (eps, A, start, vr, vi):
        obj.destroy()
    return np.array(values, dtype=complex), np.array(vectors).reshape(len(values), n)


def floquet_multipliers(model: ReducedModel, cfg: Config, orbit: Orbit, steps: int,
                        angles_deg: dict | None = None, lam: float = 1.0, count: int = 10,
                        comm=None, progress=None) -> Multipliers:
    """The ``count`` multipliers of largest modulus of ``orbit`` on the whole wheel of
    ``model`` (``steps``: TS steps per period, those of the shooting)."""
    PETSc = petsc()
    t0 = time.perf_counter()
    N, m = model.blades, model.modes
    x_star = orbit.wheel_state(N)
    scale = vibration_units(x_star, orbit.period)
    flow = WheelFlow(model, cfg, angles_deg, lam)
    n = 2 * N * m
    try:
        shell = LinearisedPeriod(flow, x_star, orbit.period, steps, scale)
        values, vectors = largest_eigenpairs(shell, n, count)
        # the phase shift's multiplier, checked directly: M f = f along the flow at x*
        f = (flow.vector_field(x_star) / scale).ravel()
        f /= np.linalg.norm(f)
        # COMM_SELF explicitly: ranks work on different cases; a COMM_WORLD Vec here made
        # one rank wait in a collective for another that had finished (a deadlock)
        x = PETSc.Vec().createWithArray(f.copy(), comm=PETSc.COMM_SELF)
        y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        shell.mult(None, x, y)
        trivial_error = float(np.linalg.norm(y.getArray() - f))
        for obj in (x, y):
            obj.destroy()
    finally:
        flow.destroy()
    order = np.argsort(-np.abs(values))
    values, scaled = values[order], vectors[order]
    nd, wave = label_vectors(scaled * scale.ravel()[None], N, m)
    align = np.array([abs(np.vdot(v, f)) / np.linalg.norm(v) for v in scaled])
    trivial = -1
    near = np.flatnonzero(np.abs(values - 1.0) < 1e-2)
    if near.size:
        trivial = int(near[np.argmax(align[near])])
    return Multipliers(values, nd, wave, trivial, orbit.period, shell.count,
                       time.perf_counter() - t0, count, alignment=align,
                       trivial_check=trivial_error)
