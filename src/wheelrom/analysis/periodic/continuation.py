"""Newton (PETSc SNES) and pseudo-arclength continuation of a travelling wave's harmonic
balance (:class:`wheelrom.analysis.periodic.harmonic_balance.WaveBalance`).

The extended unknown ``z = (y, Omega, lam)``: the harmonics in units of ``x_scale`` (one per
packed row: the mean ``c_0``, which carries the preload's static deflection, in its own units,
the vibration harmonics in units of ``x_ref``; ``X = x_scale y``), the frequency in units of
``omega_ref`` and the factor on the self-excitation. The equations: the balance of each
harmonic in units of ``omega_ref^2 x_scale`` (each harmonic relative to its own size), the phase
condition ``Im c_1[j*] = 0`` and one constraint ``a . z = b`` that picks the point: the
pseudo-arclength condition ``t . (z - z_pred) = 0`` on a branch, ``lam = 1`` for the limit
cycle of the configured intensity, or a fixed amplitude for the first point. One SNES (options
prefix ``limitcycle_``, LU on a dense Jacobian, ``setFromOptions`` last) solves them all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.analysis.periodic.window import Linearisation
from wheelrom.runtime.environment import petsc

PREFIX = "limitcycle_"
MAX_ITERATIONS = 30  # Newton iterations of one corrector solve
#: Newton iterations of one branch point: a predictor within the step converges in a few (the
#: step grows below 5 and shrinks above 10); one that has not by then is on its way off the
#: branch, or at a grazing point whose slow iterations cost more than the seeds at lam = 1
#: that reach the cycles beyond it (the paper wheel's 70 deg branch: 69 s with 12, 105 s
#: with 30)
BRANCH_ITERATIONS = 12
#: halvings of a failed branch step before the branch is said to stall: a grazing point
#: (a contact starting to touch or lift off within the cycle) either yields within a few or
#: not at all (measured: the paper's 70 deg branch spent 1100 Jacobians, 84 s, halving its
#: step 17 times down to step_min; its 80 deg branch passes its grazing point after 3)
RETRIES = 8
ROUNDOFF = 1e-10  # reachable residual relative to the balanced terms
CONTRACTION = 0.25  # a chord step that reduces the residual less asks for a fresh Jacobian
FREQUENCY_RANGE = 2.0  # solutions beyond this factor off the Hopf frequency are rejected


@dataclass
class Point:
    """One solved point: ``z`` ``(n + 2,)`` scaled unknowns, ``X`` ``(2H + 1, m)`` packed
    harmonics [sqrt(kg) m], ``omega`` [rad/s], ``lam`` [-], ``iterations`` (Newton) and the
    force linearisation at the solution (Floquet's input: :meth:`Corrector.linearisation`
    fills it when asked)."""

    z: np.ndarray
    X: np.ndarray
    omega: float
    lam: float
    iterations: int
    linearisation: Linearisation | None = None


class Corrector:
    """The scaled extended system of one wave and its SNES."""

    def __init__(self, balance: WaveBalance, x_scale: np.ndarray, omega_ref: float,
                 phase_index: int, comm=None, prefix: str = PREFIX):
        PETSc = petsc()
        self.balance, self.omega_ref = balance, omega_ref
        self.x_scale = np.asarray(x_scale, dtype=float)[:, None]  # (2H + 1, 1)
        self.phase_index = phase_index  # flat index of Im c_1[j*] in X
        n = balance.size + 2
        self.n = n
        self.constraint = (np.zeros(n), 0.0)
        self._J: np.ndarray | None = None  # the last Jacobian built (n - 1, n)
        self._lin: tuple | None = None  # (z, its force linearisation)
        self.exact = self.refresh = False
        self._last_norm = np.inf
        self.term_size = 0.0
        self.cap = MAX_ITERATIONS  # iterations of the current solve (at most SNES's max_it)
        comm = comm or PETSc.COMM_SELF
        self.snes = PETSc.SNES().create(comm=comm)
        self.snes.setOptionsPrefix(prefix)
        self.J = PETSc.Mat().createDense((n, n), comm=comm)
        self.J.setUp()
        self.r = PETSc.Vec().createSeq(n, comm=comm)
        self.x = PETSc.Vec().createSeq(n, comm=comm)
        self.snes.setFunction(self._residual, self.r)
        self.snes.setJacobian(self._jacobian, self.J, self.J)
        self.snes.setTolerances(rtol=1e-30, atol=1e-9, stol=1e-12, max_it=MAX_ITERATIONS)
        # plain Newton steps: the AFT residual has kinks where a time sample's contact opens
        # or closes, across which a backtracking line search stalls; a failed solve is
        # retried from a shorter predictor instead
        options = PETSc.Options(prefix)
        if not options.hasName("snes_linesearch_type"):
            options.setValue("snes_linesearch_type", "basic")
        self.snes.setConvergenceTest(self._converged)
        self.snes.getKSP().setType("preonly")
        self.snes.getKSP().getPC().setType("lu")
        self.snes.setFromOptions()

    # -------------------------------------------------------------- scaled <-> physical
    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, float, float]:
        b = self.balance
        X = self.x_scale * z[: b.size].reshape(2 * b.H + 1, b.modes)
        return X, self.omega_ref * z[-2], z[-1]

    def pack(self, X: np.ndarray, omega: float, lam: float) -> np.ndarray:
        return np.concatenate([(X / self.x_scale).ravel(), [omega / self.omega_ref, lam]])

    # -------------------------------------------------------------- system
    def _scale(self) -> np.ndarray:
        return 1.0 / (self.omega_ref**2 * self.x_scale)  # (2H + 1, 1) per equation row

    def function(self, z: np.ndarray) -> np.ndarray:
        """The scaled equations without the constraint ``(n - 1,)`` (no Jacobian: the forces at
        the time samples only)."""
        X, omega, lam = self.unpack(z)
        b, scale = self.balance, self._scale()
        linear = b.linear_term(X, omega, lam)
        R = linear - b.P @ b.nonlinear_force(X, omega, lam)
        # the size of the balanced terms: round-off in them (the preload's static forces,
        # the stiff contact springs) sets the residual a Newton iteration can reach
        self.term_size = float(np.abs(linear * scale).max())
        return np.concatenate([(R * scale).ravel(), [z[self.phase_index]]])

    def system(self, z: np.ndarray):
        """``(F, J, lin)``: the scaled equations without the constraint ``(n - 1,)``, their
        Jacobian ``(n - 1, n)`` and the force linearisation at ``z``."""
        X, omega, lam = self.unpack(z)
        b, scale = self.balance, self._scale()
        lin = b.linearise(X, omega, lam)
        R, dRdX, dRdw, dRdlam = b.jacobian(X, omega, lam, lin)
        F = np.concatenate([(R * scale).ravel(), [z[self.phase_index]]])
        self.term_size = float(np.abs(b.linear_term(X, omega, lam) * scale).max())
        J = np.zeros((self.n - 1, self.n))
        dRdX = dRdX * scale[:, :, None, None] * self.x_scale[None, None, :, :]
        J[: b.size, : b.size] = dRdX.reshape(b.size, b.size)
        J[: b.size, -2] = (dRdw * scale).ravel() * self.omega_ref
        J[: b.size, -1] = (dRdlam * scale).ravel()
        J[-1, self.phase_index] = 1.0
        return F, J, lin

    def _converged(self, snes, iteration, norms):
        """Converged when ``|F| <= atol`` or ``<= ROUNDOFF x`` the balanced terms' size;
        diverged after ``max_it`` iterations (SNES's tolerances, settable by options). A
        residual that fell less than :data:`CONTRACTION` in the last iteration asks for a
        fresh Jacobian at the next one."""
        fnorm = norms[2]
        atol, max_it = snes.getTolerances()[1], snes.getTolerances()[3]
        if iteration > 0 and fnorm > CONTRACTION * self._last_norm:
            self.refresh = True
        self._last_norm = fnorm
        if fnorm <= max(atol, ROUNDOFF * self.term_size):
            return 2  # SNES_CONVERGED_FNORM_ABS
        if iteration >= min(max_it, self.cap):
            return -5  # SNES_DIVERGED_MAX_IT
        return 0

    def _residual(self, snes, x, r) -> None:
        z = x.getArray(readonly=True).copy()
        a, b = self.constraint
        r.setArray(np.concatenate([self.function(z), [a @ z - b]]))

    def _jacobian(self, snes, x, J, P) -> None:
        """The force Jacobian (finite differences over the window at every sample: the
        expensive part) is rebuilt only when asked (:attr:`refresh`, or every iteration in
        :attr:`exact` mode); otherwise the last one serves (a chord step), with the current
        constraint row."""
        if self.exact or self.refresh or self._J is None:
            z = x.getArray(readonly=True).copy()
            _, self._J, lin = self.system(z)
            self._lin = (z, lin)
            self.refresh = False
        P.setValues(range(self.n), range(self.n), np.vstack([self._J, self.constraint[0]]))
        P.assemble()

    def solve(self, z0: np.ndarray, a: np.ndarray, b: float, chord: bool = False,
              iterations: int = MAX_ITERATIONS) -> Point | None:
        """Newton from ``z0`` on the balance, the phase condition and ``a . z = b`` with a
        fresh Jacobian every iteration; ``chord``: first with the last Jacobian kept while
        the residual falls fast (chord steps: a continuation's small steps), then, if that
        fails, exactly; each at most ``iterations``. ``None`` when Newton fails (the caller
        shortens its step)."""
        self.constraint, self.cap = (a, b), iterations
        for exact in (False, True) if chord else (True,):
            self.exact, self.refresh, self._last_norm = exact, exact, np.inf
            self.x.setArray(z0)
            self.snes.solve(None, self.x)
            if self.snes.getConvergedReason() > 0:
                z = self.x.getArray().copy()
                X, omega, lam = self.unpack(z)
                return Point(z, X, omega, lam, self.snes.getIterationNumber(), None)
        return None

    def linearisation(self, point: Point) -> Linearisation:
        """The force linearisation at a solved point (computed once, kept on it)."""
        if point.linearisation is None:
            if self._lin is not None and np.array_equal(self._lin[0], point.z):
                point.linearisation = self._lin[1]
            else:
                point.linearisation = self.balance.linearise(point.X, point.omega, point.lam)
        return point.linearisation

    def plausible(self, point: Point) -> bool:
        """Whether a solution's frequency is within a factor :data:`FREQUENCY_RANGE` of the
        reference: far below it, the same motion is written as a high harmonic of a slow
        fundamental (a spurious solution of the truncated balance)."""
        ratio = point.omega / self.omega_ref
        return 1 / FREQUENCY_RANGE <= ratio <= FREQUENCY_RANGE

    def tangent(self, z: np.ndarray, previous: np.ndarray) -> np.ndarray:
        """Unit tangent of the branch at ``z``, oriented along ``previous``, from the Jacobian
        at ``z`` (built here unless the last one was; the next solve's chord steps start from
        it)."""
        if self._lin is None or not np.array_equal(self._lin[0], z):
            _, self._J, lin = self.system(z)
            self._lin = (z.copy(), lin)
        t = np.linalg.solve(np.vstack([self._J, previous]), np.r_[np.zeros(self.n - 1), 1.0])
        t /= np.linalg.norm(t)
        return t if t @ previous >= 0 else -t

    def destroy(self) -> None:
        for obj in (self.snes, self.J, self.r, self.x):
            obj.destroy()


@dataclass(frozen=True)
class BranchSettings:
    """``lam_max``: stop when the factor on the self-excitation exceeds it; ``amplitude_max``
    [m]: stop when the tip amplitude does; ``steps``: most points; ``step``, ``step_min``,
    ``step_max``: arclength (scaled units)."""

    lam_max: float = 4.0
    amplitude_max: float = 1e-3
    steps: int = 120
    step: float = 0.05
    step_min: float = 1e-4
    step_max: float = 20.0


def trace(corrector: Corrector, first: Point, direction: np.ndarray, settings: BranchSettings,
          amplitude, progress=None) -> tuple[list[Point], str]:
    """Pseudo-arclength continuation from ``first`` along ``direction`` (scaled); returns the
    points and why the branch ends (in words). ``amplitude(point)`` [m] (tip, 0-peak)."""
    points = [first]
    t = corrector.tangent(first.z, direction)
    ds, failures = settings.step, 0
    while True:
        z = points[-1].z
        if len(points) >= settings.steps:
            return points, f"stopped after {settings.steps} points (limit_cycle.steps)"
        predictor = z + ds * t
        point = corrector.solve(predictor, t, float(t @ predictor), chord=True,
                                iterations=BRANCH_ITERATIONS)
        if point is not None and (np.linalg.norm(point.z - predictor) > ds
                                  or not corrector.plausible(point)):
            point = None  # the corrector jumped (to another branch, or the trivial one)
        if point is None:
            ds /= 2
            failures += 1
            if ds < settings.step_min or failures > RETRIES:
                return points, ("continuation stalled (Newton fails at the smallest step or "
                                f"after {RETRIES} halvings of it)")
            continue
        failures = 0
        t = corrector.tangent(point.z, t)
        points.append(point)
        if progress is not None:
            progress(point)
        if point.iterations <= 4:
            ds = min(settings.step_max, 1.5 * ds)
        elif point.iterations > MAX_ITERATIONS // 3:
            ds /= 2
        a = amplitude(point)
        if point.lam > settings.lam_max:
            return points, f"intensity factor above {settings.lam_max:g} (limit_cycle.mu_max)"
        if point.lam < 0:
            return points, "the branch turns back below zero self-excitation"
        if a > settings.amplitude_max:
            return points, (f"tip amplitude above {settings.amplitude_max:.3g} m "
                            "(limit_cycle.amplitude_max)")
