"""The nonlinear forced response of the tuned wheel to the nozzle (issue #45): the
steady periodic state at the excitation frequency, by harmonic balance on one blade with the
travelling-wave condition, under either contact law (docs/theory.md, "Nonlinear forced
response").

The nozzle force on blade ``s``, ``F_b cos(w t - phi_s)``, ``phi_s = 2 pi (1 - n_s / N) s``
(eq. 13), is a travelling wave: blade ``s`` feels blade 0's force ``s`` phases ``2 pi n_s /
N`` later, the wave ``k = n_s mod N`` of :class:`~.harmonic_balance.WaveBalance` (ND
``min(k, N - k)``: 2 on the paper wheel). With ``tau = w t`` the response is blade 0's
harmonics ``c_h`` of the same packing, and the equations are the autonomous ones plus the
force on harmonic 1, at the fixed ``w`` (no phase condition: the force sets the phase)::

    (K_h (1 + i h w beta_D) - (h w)^2) c_h - f_h(c, w) - F_b p_exc delta_{h1} = 0

``f_h``: the contacts (marching the elastic law's sliders) and, when on, the Van der Pol
force by AFT, as for the limit cycles. Newton per frequency, from the last frequency's
solution (natural continuation over a grid; :mod:`.forced_branch` traces the curve through
its folds by arclength).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.harmonic_balance import WaveBalance
from wheelrom.forces.parameters import ForceParameters
from wheelrom.rom.model import ReducedModel, nodal_diameter

#: Newton iterations of one frequency at most
MAX_ITERATIONS = 40
#: chord iterations (the Jacobian kept while the residual falls by ``CONTRACTION``) tried
#: first (:meth:`ForcedWave._chord`)
CHORD_ITERATIONS, CONTRACTION = 12, 0.25
#: converged when the residual is this small against the nozzle's generalised force, or
#: against the balanced terms (the preload's static forces and the stiff contact springs,
#: whose rounding a Newton iteration cannot go below)
TOLERANCE = 1e-10
#: the rounding floor of the equations against the static terms (the preload's forces): the
#: arm kinematics' ``L (e - e0)`` loses the unit vector's last digits, which the contact
#: springs ``k_c`` turn into force noise of ~2e-11 of the static terms (measured); the
#: harmonics' equations are held to it or to 1e-7 of their own terms, whichever is larger
ROUNDOFF_STATIC = 1e-10
ROUNDOFF_MOVING = 1e-7
#: time samples per period at least of the 0-peak tip amplitude
AMPLITUDE_SAMPLES = 512
#: the slow flow's relaxation (:meth:`ForcedWave._relax`): its first step [periods], steps
#: at most, steps one Jacobian serves at most, the Jacobian's differencing step [share of a
#: row's size], a step's reach [share of the vibration's largest harmonic]
RELAX_START, RELAX_STEPS, RELAX_CHORD, RELAX_STEP, RELAX_REACH = 25.0, 150, 4, 1e-6, 0.3
#: steps without a new smallest residual before it gives up, then Newton's iterations from
#: its closest state
RELAX_PATIENCE, RELAX_POLISH = 40, 6
#: halvings of a frequency step whose Newton solve failed (:func:`stepped_solve`)
SUBSTEPS = 3
#: the secant predictor's step at most this many times the step between the two solutions
#: it extrapolates (a failed frequency between them leaves a longer reach: not trusted)
SECANT_REACH = 1.5
#: the refined peak's frequency to this share of itself, and on until the amplitudes inside
#: the bracket agree to ``PEAK_AMPLITUDE`` (a lightly damped stuck resonance is narrower than
#: 1e-4: its half-power band is 2 zeta ~ 1e-4 on the paper wheel), down to ``PEAK_FLOOR``
#: (:func:`refine_peak`)
PEAK_TOLERANCE = 1e-4
PEAK_AMPLITUDE = 1e-7
PEAK_FLOOR = 1e-12


@dataclass
class ForcedCurve:
    """The steady response over ``F`` excitation frequencies.

    ``frequency``: ``(F,)`` [rad/s]; ``harmonics``: ``(F, 2H + 1, m)`` blade 0's packed
    harmonics (NaN where Newton failed); ``tip_amplitude``: ``(F,)`` 0-peak tip amplitude
    [m] of the motion about its mean (every blade the same: a tuned travelling wave);
    ``converged``: ``(F,)``; ``iterations``: ``(F,)``; ``fractions``: ``(F, K, 3)`` share of
    the period each contact kind is open / sticks / slips (blade pair 0); ``wave``,
    ``nodal_diameter``; ``wall_s``. A traced curve (:func:`.forced_branch.traced_curve`)
    holds its points in the order traced (through a fold the frequency turns back; a row
    not converged separates two pieces traced from either end of the band).
    """

    frequency: np.ndarray
    harmonics: np.ndarray
    tip_amplitude: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    fractions: np.ndarray
    wave: int
    nodal_diameter: int
    wall_s: float = 0.0
    kinds: tuple = field(default_factory=tuple)
    refined: RefinedPeak | None = None
    #: arclength continuation (:mod:`.forced_branch`): the folds' frequencies [rad/s] and how
    #: the trace ended (the frequencies are then the curve's points in the order traced)
    folds: np.ndarray = field(default_factory=lambda: np.zeros(0))
    trace: str = ""
    #: ``(F,)`` [1/s] the largest Floquet exponent's real part per point (Hill's method in
    #: the forced wave's family and family 0; NaN: not computed), :func:`.forced_branch.
    #: forced_growth`
    growth: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: over MPI ranks (:mod:`.forced_segments`): the seams [rad/s] whose next segment was
    #: solved again in order (its rank's first state was another steady state)
    resolved_seams: list = field(default_factory=list)

    @property
    def peak(self) -> int:
        """Index of the largest converged tip amplitude."""
        amplitude = np.where(self.converged, self.tip_amplitude, -np.inf)
        return int(np.argmax(amplitude))


@dataclass
class RefinedPeak:
    """The largest tip amplitude of a :class:`ForcedCurve` found off its grid (see
    :func:`refine_peak`): ``frequency`` [rad/s], ``tip_amplitude`` [m], ``harmonics``
    ``(2H + 1, m)``, ``fractions`` ``(K, 3)`` (open / stick / slip per contact kind) and the
    Newton ``solves`` the search took."""

    frequency: float
    tip_amplitude: float
    harmonics: np.ndarray
    fractions: np.ndarray
    solves: int


class ForcedWave:
    """The forced harmonic balance of one case: ``params`` with the nozzle (``n_s``,
    ``F_b``) and the self-excitation at factor ``lam`` (0: off), ``H`` harmonics and
    ``samples`` per period of the AFT (0: ``8 (H + 1)``)."""

    def __init__(self, model: ReducedModel, params: ForceParameters, beta: float,
                 harmonics: int, samples: int = 0, lam: float = 1.0):
        samples = samples or 8 * (harmonics + 1)
        self.wave = params.stator_vanes % model.blades
        self.balance = WaveBalance(model, params, beta, self.wave, harmonics, samples)
        self.lam, self.harmonics = lam, harmonics
        self._force_jacobian = None  # (n, n) the forces' part of the last Jacobian
        self.force = np.zeros((2 * harmonics + 1, model.modes))
        self.force[1] = params.nozzle_force * np.asarray(params.excitation, dtype=float)

    def residual(self, X: np.ndarray, omega: float) -> np.ndarray:
        """``(2H + 1, m)`` packed residual at the excitation frequency ``omega`` [rad/s]."""
        return self.balance.residual(X, omega, self.lam) - self.force

    def solve(self, X0: np.ndarray, omega: float) -> tuple[np.ndarray, bool, int]:
        """The steady state from ``X0`` ``(2H + 1, m)``: ``(X, converged, iterations)``.

        Chord steps first (:meth:`_chord`), then Newton's full steps, then steps backtracked
        until the residual falls (either alone loses cases the other solves: measured on the
        small wheel under the elastic law, full steps 7 of 8 frequencies near the stuck
        resonance and 2 of 17 on a coarse grid through the slipping one, backtracking 1 and
        12, both together 7 and 13), and where all fail the relaxation along the slow flow
        (:meth:`_relax`: the friction plateau at a slip onset, issue #69)."""
        X, ok, iterations = self._chord(X0, omega)
        if ok:
            return X, ok, iterations
        for backtrack in (False, True):
            X, ok, more = self._newton(X0, omega, backtrack=backtrack)
            iterations += more
            if ok:
                return X, ok, iterations
        X, ok, more = self._relax(X0, omega)
        return X, ok, iterations + more

    def _relax(self, X0: np.ndarray, omega: float) -> tuple[np.ndarray, bool, int]:
        """Pseudo-transient continuation from ``X0`` ``(2H + 1, m)`` at ``omega`` [rad/s]
        along the balance's slow flow: ``(X, converged, steps)``.

        The harmonics of a slowly varying motion ``Re(c_h e^{i h tau})`` obey (unit modal
        mass, ``c''`` dropped) ``2 i h omega c_h' = -R_h``: the residual drives them as the
        transient would, and a steady state is where they rest. Implicit Euler steps of
        this flow, the mean held in static balance, ``(D / dt - J) dX = R`` with ``D`` the
        flow's ``2 h omega`` rotation of each harmonic's (Re, Im) pair and ``J`` the
        residual's Jacobian, are Newton's step regularised along ``D``: a step ``dt`` of
        :data:`RELAX_START` periods at first, doubled where the residual falls, kept where
        it grows less than twice, quartered where it grows more; every step taken (the
        march's loop has kinks the flow must cross: refusing the steps that grow the
        residual stalled it at them), the vibration moved by at most :data:`RELAX_REACH` of
        itself a step (a large force from rest otherwise overshoots and diverges: the small
        wheel at 10 N, 252 Hz); ``dt`` to infinity is Newton. It gives up after
        :data:`RELAX_PATIENCE` steps without a new smallest residual, and Newton takes over
        from its closest state (:meth:`_polish`).

        Why: at a lightly damped resonance whose contacts just start to slip the response
        is held at the slip onset by a dissipation that rises steeply with the amplitude,
        and the balance is stiff on the slipping side, near-singular (the resonance) on the
        sticking side and kinked between: Newton's step from either side lands far on the
        other (measured on the small wheel at 0.02 N: 9 frequencies of 41 unsolved, the
        Newton step growing the residual 4000-fold, its backtracked steps stalling, least
        squares (Levenberg-Marquardt) and a continuation in the force stalling at the
        onset's corner, where the curve at a fixed frequency folds). The slow flow passes
        the corner as the vibration builds up to it (all 41 solved, 10-40 steps).

        Under the elastic law ``J`` is the residual's central difference (:meth:`
        _difference_jacobian`): the loop's analytic Jacobian misses the grazing and
        shaken-down contacts' sliders there (10-50 % off in the harmonic-1 and mean blocks,
        against a resonance whose smallest singular value is 1e-6 of the largest), with it
        the relaxation reaches the plateau and wanders on it. ``J`` is kept for up to
        :data:`RELAX_CHORD` steps while each step halves the residual."""
        b = self.balance
        X = np.array(X0, dtype=float)
        n, m = b.size, b.modes
        flow = np.zeros((n, n))  # D: the slow flow's rotation of each harmonic pair
        for h in range(1, self.harmonics + 1):
            re = (2 * h - 1) * m + np.arange(m)
            flow[re, re + m] = 2 * h * omega
            flow[re + m, re] = -2 * h * omega
        dt = RELAX_START * 2 * math.pi / omega
        R = self.residual(X, omega)
        J, age, slow, best, since, closest = None, 0, False, math.inf, 0, X
        for step in range(RELAX_STEPS + 1):
            if not np.all(np.isfinite(R)):
                return X, False, step
            if self._converged(R, X, omega):
                return X, True, step
            if step == RELAX_STEPS or since > RELAX_PATIENCE:
                return self._polish(closest, omega, step)
            if J is None or age >= RELAX_CHORD or slow:
                J, age = self._relax_jacobian(X, omega), 0
            size = float(np.linalg.norm(R / self._row_scale(X, omega)))
            if size < best:
                best, since, closest = size, 0, X
            else:
                since += 1
            try:
                dX = np.linalg.solve(flow / dt - J, R.ravel()).reshape(X.shape)
            except np.linalg.LinAlgError:
                return self._polish(closest, omega, step)
            vibration, moved = float(np.abs(X[1:]).max()), float(np.abs(dX[1:]).max())
            if 0 < vibration and RELAX_REACH * vibration < moved:
                dX *= RELAX_REACH * vibration / moved
            X = X + dX
            R_new = self.residual(X, omega)
            grown = float(np.linalg.norm(R_new / self._row_scale(X, omega)))
            dt *= 2.0 if grown < size else 1.0 if grown < 2.0 * size else 0.25
            R, age, slow = R_new, age + 1, not grown < 0.5 * size
        return self._polish(closest, omega, RELAX_STEPS)

    def _polish(self, X0: np.ndarray, omega: float, steps: int) -> tuple[np.ndarray, bool, int]:
        """Newton from ``X0``, the relaxation's closest state, when the flow did not settle:
        ``(X, converged, steps + iterations)``. The flow leaves a steady state it cannot rest
        on (one that a slipping contact makes unstable: measured on the small wheel at 1 N,
        257.945 Hz, the residual falling to 2e-6 of its terms, then growing by 1.4 a step
        towards another branch); the balance holds it all the same."""
        X = np.array(X0, dtype=float)
        for it in range(RELAX_POLISH + 1):
            R = self.residual(X, omega)
            if not np.all(np.isfinite(R)):
                break
            if self._converged(R, X, omega):
                return X, True, steps + it
            if it == RELAX_POLISH:
                break
            J = self._relax_jacobian(X, omega)
            try:
                X = X - np.linalg.solve(J, R.ravel()).reshape(X.shape)
            except np.linalg.LinAlgError:
                break
        return X0, False, steps + RELAX_POLISH

    def _row_scale(self, X: np.ndarray, omega: float) -> np.ndarray:
        """``(2H + 1, 1)`` each equation's scale: the mean's largest linear term (the
        preload's static forces), the harmonics' largest."""
        terms = np.abs(self.balance.linear_term(X, omega, self.lam))
        return np.maximum(np.r_[terms[0].max(), np.full(terms.shape[0] - 1,
                                                       terms[1:].max())], 1e-300)[:, None]

    def _relax_jacobian(self, X: np.ndarray, omega: float) -> np.ndarray:
        """``(n, n)`` the relaxation's and its polish's Jacobian: by central differences
        under the elastic law (:meth:`_difference_jacobian`), the balance's own otherwise."""
        if self.balance.elastic:
            return self._difference_jacobian(X, omega)
        return self._jacobian(X, omega)[0]

    def _difference_jacobian(self, X: np.ndarray, omega: float) -> np.ndarray:
        """``(n, n)`` the residual's Jacobian at ``X`` by central differences of
        :data:`RELAX_STEP` of each row's size (the mean's and the harmonics' largest entry:
        the march's loop moves with the motion; a step of the loop Jacobian's 1e-10 m
        crosses the sampled onsets' kinks at a response of 1e-6 m); where a row is zero (at
        rest), the balance's own step."""
        b = self.balance
        n, m = b.size, b.modes
        size = np.r_[np.abs(X[0]).max(), np.full(X.shape[0] - 1, np.abs(X[1:]).max())]
        J = np.empty((n, n))
        for k in range(n):
            row, mode = divmod(k, m)
            h = RELAX_STEP * size[row] if size[row] > 0 else b.fd_step[mode]
            d = np.zeros_like(X)
            d[row, mode] = h
            J[:, k] = (self.residual(X + d, omega) - self.residual(X - d, omega)).ravel() \
                / (2 * h)
        return J

    def _chord(self, X0: np.ndarray, omega: float):
        """Newton with the Jacobian kept while the residual falls by :data:`CONTRACTION` an
        iteration (a fresh one where it does not): the forces' Jacobian costs ~35 residuals
        (the paper law's physical inputs), and a grid's next frequency starts close. The
        first matrix is the last solve's forces' part beside this frequency's linear part
        (:meth:`_carried`: the paper wheel's 200-point elastic curve in 27 s instead of 36).
        At most :data:`CHORD_ITERATIONS`; ``(X, converged, iterations)``."""
        b = self.balance
        X = np.array(X0, dtype=float)
        J, last, fresh = self._carried(X, omega), math.inf, False
        for it in range(CHORD_ITERATIONS + 1):
            if J is None:
                J, R = self._jacobian(X, omega)
                fresh = True
            else:
                R = b.residual(X, omega, self.lam) - self.force
            if not np.all(np.isfinite(R)):
                return X, False, it
            if self._converged(R, X, omega):
                return X, True, it
            size = float(np.abs(R).max())
            if size > CONTRACTION * last:  # the chord stalls: a fresh Jacobian here
                if it > 0 and size > last and fresh:
                    return X, False, it  # growing: leave it to Newton
                J, R = self._jacobian(X, omega)
                fresh = True
            last = size
            X = X - np.linalg.solve(J, R.ravel()).reshape(X.shape)
        return X, False, CHORD_ITERATIONS

    def _jacobian(self, X: np.ndarray, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """``(J, R)``: the residual's Jacobian ``(n, n)`` and the residual at ``X``; the
        forces' part kept for the next solve's first chord matrix (:meth:`_carried`)."""
        b = self.balance
        R, dRdX, _, _ = b.jacobian(X, omega, self.lam)
        J = dRdX.reshape(b.size, b.size)
        self._force_jacobian = b.linear_jacobian(X, omega, self.lam) - J
        return J, R - self.force

    def _carried(self, X: np.ndarray, omega: float) -> np.ndarray | None:
        """The chord matrix at ``omega`` [rad/s] from the last Jacobian's forces' part and
        this frequency's linear part (exact): the forces' part changes little from one grid
        frequency to the next, and under the elastic law a Jacobian costs a march and ~150
        periods of unmarched samples against a march for a residual. None before any
        Jacobian."""
        if self._force_jacobian is None:
            return None
        return self.balance.linear_jacobian(X, omega, self.lam) - self._force_jacobian

    def _newton(self, X0: np.ndarray, omega: float, backtrack: bool):
        X = np.array(X0, dtype=float)
        for it in range(MAX_ITERATIONS + 1):
            J, R = self._jacobian(X, omega)
            if not np.all(np.isfinite(R)):
                return X, False, it
            if self._converged(R, X, omega):
                return X, True, it
            if it == MAX_ITERATIONS:
                break
            step = np.linalg.solve(J, R.ravel()).reshape(X.shape)
            X = self._backtrack(X, step, float(np.abs(R).max()), omega) if backtrack \
                else X - step
        return X, False, MAX_ITERATIONS

    def _backtrack(self, X: np.ndarray, step: np.ndarray, size: float,
                   omega: float) -> np.ndarray:
        """``X - a step`` with ``a`` halved (down to 1/64) until the residual falls: contacts
        that open, close, stick and slip between the samples make the residual kinked, and
        a full Newton step from the last frequency's solution can land far off."""
        a = 1.0
        for _ in range(7):
            trial = X - a * step
            R = self.residual(trial, omega)
            if np.all(np.isfinite(R)) and np.abs(R).max() < size:
                return trial
            a *= 0.5
        return X - step

    def _converged(self, R: np.ndarray, X: np.ndarray, omega: float) -> bool:
        """The mean's equations against their own terms (the preload's static forces), the
        harmonics' against theirs or the nozzle force: a small force's response is not
        lost in the rounding of the static terms; under the elastic law none below the
        march's force noise (:attr:`~.harmonic_balance.WaveBalance.force_noise`)."""
        terms = np.abs(self.balance.linear_term(X, omega, self.lam))
        floor = TOLERANCE * float(np.abs(self.force).max())
        static = max(ROUNDOFF_STATIC * float(terms[0].max()), floor, 1e-300)
        moving = max(ROUNDOFF_MOVING * float(terms[1:].max()), floor, static)
        noise = self.balance.force_noise
        return bool(np.all(np.abs(R[0]) <= np.maximum(static, noise))
                    and np.all(np.abs(R[1:]) <= np.maximum(moving, noise)))

    def tip_amplitude(self, X: np.ndarray, omega: float) -> float:
        """0-peak tip amplitude [m] of the motion about its mean (a time grid of at least
        :data:`AMPLITUDE_SAMPLES` per period: the largest sample is within ``1 - cos(pi /
        S)`` = 2e-5 of the peak of a harmonic motion)."""
        tau = np.linspace(0.0, 2 * math.pi, max(4 * self.balance.nt, AMPLITUDE_SAMPLES),
                          endpoint=False)
        c = self.balance.complex_harmonics(X)
        h = np.arange(1, c.shape[0])
        q = (np.exp(1j * np.outer(tau, h)) @ c[1:]).real  # (S, m) about the mean
        return float(np.linalg.norm(q @ self.balance.model.tip.T, axis=1).max())

    def fractions(self, X: np.ndarray, omega: float) -> np.ndarray:
        """``(K, 3)`` share of the period each contact kind of blade pair 0 is open, sticks,
        slips (paper law: sticks = the micro-slip branch)."""
        b = self.balance
        q, v = b.samples(X, omega)
        state = b._evaluate(q, v, self.lam)[3]
        return np.array([[np.mean(state[:, k] == s) for s in range(3)]
                         for k in range(state.shape[1])])


def forced_curve(model: ReducedModel, params: ForceParameters, beta: float,
                 frequencies, equilibrium: np.ndarray, harmonics: int = 7,
                 samples: int = 0, lam: float = 1.0, progress=None,
                 refine: bool = False) -> ForcedCurve:
    """The steady response at every excitation frequency of ``frequencies`` [rad/s], in the
    order given (natural continuation: each Newton solve starts from the last solution, the
    first from the preloaded ``equilibrium`` ``(N, m)`` at rest). ``progress(i, omega,
    amplitude)`` after each frequency; ``refine``: also the peak off the grid
    (:func:`refine_peak`, ``curve.refined``). Over MPI ranks: :func:`.forced_segments.
    segmented_curve`."""
    t0 = time.perf_counter()
    problem = ForcedWave(model, params, beta, harmonics, samples, lam)
    out = empty_curve(problem, model, params, frequencies)
    continue_over(problem, out, range(out.frequency.size), at_rest(problem, equilibrium),
                  None, progress)
    if refine:
        out.refined = refine_peak(problem, out)
    out.wall_s = time.perf_counter() - t0
    return out


def empty_curve(problem: ForcedWave, model: ReducedModel, params: ForceParameters,
                frequencies) -> ForcedCurve:
    """A :class:`ForcedCurve` over ``frequencies`` [rad/s] with nothing solved yet."""
    w_all = np.atleast_1d(np.asarray(frequencies, dtype=float))
    F, K, H = w_all.size, len(params.contacts.kinds), problem.harmonics
    return ForcedCurve(w_all, np.full((F, 2 * H + 1, model.modes), np.nan), np.full(F, np.nan),
                       np.zeros(F, bool), np.zeros(F, int), np.full((F, K, 3), np.nan),
                       problem.wave, int(nodal_diameter(problem.wave, model.blades)),
                       kinds=params.contacts.kinds)


def at_rest(problem: ForcedWave, equilibrium: np.ndarray) -> np.ndarray:
    """``(2H + 1, m)``: the preloaded ``equilibrium`` ``(N, m)``, no motion."""
    X = np.zeros((2 * problem.harmonics + 1, equilibrium.shape[1]))
    X[0] = equilibrium[0]
    return X


def continue_over(problem: ForcedWave, curve: ForcedCurve, indices, X: np.ndarray,
                  last: float | None, progress=None, before: tuple | None = None) -> None:
    """Solve ``curve``'s frequencies at ``indices`` in that order into ``curve``, each from
    the last solution, the first from ``X`` ``(2H + 1, m)`` solved at ``last`` [rad/s]
    (None: a start at rest); ``before``: ``(X, omega)`` the converged solution before that
    one (None: none), for the secant predictor (:func:`predicted_solve`)."""
    for i in indices:
        w = float(curve.frequency[i])
        X_new, ok, iterations = predicted_solve(problem, X, last, w, before)
        curve.converged[i], curve.iterations[i] = ok, iterations
        if ok:
            before = (X, last) if last is not None else None
            X, last = X_new, w
            curve.harmonics[i] = X
            curve.tip_amplitude[i] = problem.tip_amplitude(X, w)
            if curve.fractions.shape[1]:
                curve.fractions[i] = problem.fractions(X, w)
        if progress is not None:
            progress(i, w, curve.tip_amplitude[i])


def predicted_solve(problem: ForcedWave, X: np.ndarray, last: float | None, w: float,
                    before: tuple | None) -> tuple[np.ndarray, bool, int]:
    """The state at ``w`` [rad/s] after ``X`` at ``last``: Newton from the secant through
    ``before`` ``(X, omega)`` and ``X`` (the last two converged solutions) when the step is
    at most :data:`SECANT_REACH` times theirs, and :func:`stepped_solve` from ``X`` when
    that fails or there is no secant (measured on the paper wheel's 200-point curves: 10-20 %
    fewer Newton iterations, 30 % (elastic law) to 50 % (paper law) less time); when that
    fails too, from rest (the mean kept): past a fold of the curve the branch followed
    ends, and the vibration built up from rest settles on another (measured on the small
    wheel's friction plateau at 0.1 N: the branch from below ends at 258.06 Hz, 1.13 um,
    the one from rest holds 1.15 um up to 258.1 Hz)."""
    iterations = 0
    if before is not None and last is not None and before[1] != last:
        ratio = (w - last) / (last - before[1])
        if 0 < ratio <= SECANT_REACH:
            X_new, ok, iterations = problem.solve(X + ratio * (X - before[0]), w)
            if ok:
                return X_new, ok, iterations
    X_new, ok, more = stepped_solve(problem, X, last, w)
    iterations += more
    if ok or last is None:
        return X_new, ok, iterations
    # the branch ended (a fold of the frequency): the state the vibration builds up to from
    # rest, as a sweep jumps there
    rest = np.zeros_like(X)
    rest[0] = X[0]
    X_new, ok, more = problem.solve(rest, w)
    return X_new, ok, iterations + more


def stepped_solve(problem: ForcedWave, X: np.ndarray, w_from: float | None, w_to: float,
                  depth: int = SUBSTEPS) -> tuple[np.ndarray, bool, int]:
    """:meth:`ForcedWave.solve` at ``w_to`` from the solution ``X`` at ``w_from`` [rad/s]
    (None: the start); when Newton fails, the step is halved (``depth`` times at most) and
    taken in two: near a sharp resonance the contacts go from sticking to slipping between
    two grid frequencies and Newton from the last solution lands far off (measured on the
    small wheel's stuck resonance: the grid point on it failed from its neighbour 11 Hz
    away)."""
    X_to, ok, n = problem.solve(X, w_to)
    if ok or depth == 0 or w_from is None:
        return X_to, ok, n
    middle = 0.5 * (w_from + w_to)
    X_mid, ok, n_mid = stepped_solve(problem, X, w_from, middle, depth - 1)
    if not ok:
        return X_to, False, n + n_mid
    X_to, ok, n_to = stepped_solve(problem, X_mid, middle, w_to, depth - 1)
    return X_to, ok, n + n_mid + n_to


def refine_peak(problem: ForcedWave, curve: ForcedCurve,
                tolerance: float = PEAK_TOLERANCE) -> RefinedPeak | None:
    """The largest tip amplitude between the grid neighbours of the curve's largest
    converged point, by golden-section search (each frequency solved by Newton from the
    nearest solution found so far) down to ``tolerance`` of the frequency: a peak that does
    not depend on the grid (and the amplitudes of the bracket to ``PEAK_AMPLITUDE``). At
    the band's edge, or beside a frequency Newton missed, the
    search runs on the side that has a converged neighbour (a peak at the edge is reported
    there); None when nothing converged."""
    if not curve.converged.any():
        return None
    i = curve.peak
    w, ok = curve.frequency, curve.converged
    known = {float(w[i]): (float(curve.tip_amplitude[i]), curve.harmonics[i])}
    solves = 0

    def amplitude(x: float) -> float:
        nonlocal solves
        if x not in known:
            start = known[min(known, key=lambda y: abs(y - x))][1]
            X, converged, _ = problem.solve(start, x)
            solves += 1
            known[x] = (problem.tip_amplitude(X, x) if converged else -math.inf, X)
        return known[x][0]

    sides = [float(w[j]) for j in (i - 1, i + 1) if 0 <= j < w.size and ok[j]]
    if sides:
        lo, hi = min(sides + [float(w[i])]), max(sides + [float(w[i])])
        golden = (math.sqrt(5.0) - 1.0) / 2.0
        a, b = hi - golden * (hi - lo), lo + golden * (hi - lo)
        while hi - lo > PEAK_FLOOR * float(w[i]) and (
                hi - lo > tolerance * float(w[i]) or
                abs(amplitude(a) - amplitude(b)) > PEAK_AMPLITUDE * max(amplitude(a),
                                                                        amplitude(b))):
            if amplitude(a) >= amplitude(b):
                hi, b = b, a
                a = hi - golden * (hi - lo)
            else:
                lo, a = a, b
                b = lo + golden * (hi - lo)
    best = max(known, key=lambda x: known[x][0])
    A, X = known[best]
    return RefinedPeak(best, A, X, problem.fractions(X, best), solves)

