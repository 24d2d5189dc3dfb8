"""The forced response traced by pseudo-arclength continuation in the excitation frequency
(issue #45): through folds (a peak bent by a stiffening or softening contact, where one
frequency has three steady states) and through the steep flanks of a lightly damped stuck
resonance, where Newton from the last frequency of a grid lands off the curve.

The unknown ``z = (y, nu)``: blade 0's packed harmonics ``X = x_scale y`` (the mean row in
units of the preloaded equilibrium's size, the vibration rows in units of ``x_ref``, the
response's expected size) and the frequency ``omega = omega_ref + omega_unit nu`` (``omega_unit``
the range traced). The equations: the
forced balance of :class:`~.forced_wave.ForcedWave`, each row in units of ``omega_ref^2
x_scale``, and the arclength condition ``t . (z - z_pred) = 0`` (``t`` the unit tangent of
the curve at the last point, ``z_pred = z + ds t``). A fold (turning point in the
frequency) is where the tangent's frequency component changes sign between two points; it is
located on the cubic Hermite interpolant of the frequency between them (the curve's points
stay as traced).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.floquet import exponents
from wheelrom.analysis.periodic.forced_wave import (
    PEAK_AMPLITUDE,
    ForcedCurve,
    ForcedWave,
    RefinedPeak,
    stepped_solve,
)
from wheelrom.rom.model import nodal_diameter

#: Newton iterations of one corrector at most (a predictor within the step converges in a
#: few; the step grows below 4 and shrinks above 8)
CORRECTOR_ITERATIONS = 10
#: halvings of a failed step before the curve is said to stall
RETRIES = 8
#: the first step [scaled units] and its bounds
STEP, STEP_MIN, STEP_MAX = 0.02, 1e-6, 0.1
#: points in a row taken with a step below ``CRAWL`` mean a corner the trace creeps towards
#: (halving and growing its step in turn: measured, 1200 points within 1e-6 Hz of a corner
#: of the small wheel's elastic curve): the trace stalls there
CRAWL, CRAWL_POINTS = 1e-4, 10
#: the vibration harmonics' unit without a grid: this many times the band edge's response
START_FACTOR = 10.0
#: a chord step that reduces the residual less asks for a fresh Jacobian
CONTRACTION = 0.25
#: points at most of one curve
MAX_POINTS = 2000
#: consecutive folds closer than this share of their frequency are one turn: the sampled
#: AFT's residual has a kink wherever a contact's opening or sticking instant crosses a time
#: sample, and a smooth turn of the curve (the tip of a bent peak) becomes a zig-zag of
#: turns within ~1e-3 of the frequency there (measured on the lift-off ring of
#: tests/test_forced_branch.py: 15 turns within 0.09 Hz at 121.5 Hz)
FOLD_MERGE = 2e-3


@dataclass
class Branch:
    """The traced curve: ``frequency`` ``(P,)`` [rad/s] in the order traced (not monotonic
    through a fold), ``harmonics`` ``(P, 2H + 1, m)``, ``iterations`` ``(P,)`` Newton per
    point, ``folds``: ``(omega, index)`` per turning point (its frequency [rad/s] and the
    point before it), ``end``: why the trace stopped (in words), ``jumps``: ``(from, to)``
    [rad/s] per stall passed by Newton in the frequency (:func:`_walk`: the curve between
    sampled in the frequency, not traced by arclength)."""

    frequency: np.ndarray
    harmonics: np.ndarray
    iterations: np.ndarray
    folds: list = field(default_factory=list)
    end: str = ""
    jumps: list = field(default_factory=list)
    #: points solved in the frequency where the arclength corrector failed (:func:`_in_frequency`)
    in_frequency: int = 0


class ArclengthCorrector:
    """Newton on the scaled forced balance and one linear constraint ``a . z = b``."""

    def __init__(self, problem: ForcedWave, x_scale: np.ndarray, omega_ref: float,
                 omega_unit: float | None = None):
        self.problem, self.omega_ref = problem, omega_ref
        self.omega_unit = float(omega_unit or omega_ref)
        self.x_scale = np.asarray(x_scale, dtype=float)[:, None]  # (2H + 1, 1)
        self.shape = problem.force.shape
        self.size = problem.balance.size
        # the equations' units: each row in omega_ref^2 x_scale
        self.row_scale = 1.0 / (omega_ref**2 * self.x_scale)  # (2H + 1, 1)

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, float]:
        return self.x_scale * z[:-1].reshape(self.shape), self.frequency(float(z[-1]))

    def frequency(self, nu: float) -> float:
        """[rad/s] of the scaled frequency ``nu``."""
        return self.omega_ref + self.omega_unit * nu

    def pack(self, X: np.ndarray, omega: float) -> np.ndarray:
        return np.concatenate([(X / self.x_scale).ravel(),
                               [(omega - self.omega_ref) / self.omega_unit]])

    def system(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
        """``(F, J, converged)``: the scaled balance ``(n,)``, its Jacobian ``(n, n + 1)``
        and whether the balance meets :meth:`ForcedWave._converged` at ``z``."""
        X, omega = self.unpack(z)
        p = self.problem
        R, dRdX, dRdw, _ = p.balance.jacobian(X, omega, p.lam)
        R = R - p.force
        scale = self.row_scale
        J = np.empty((self.size, self.size + 1))
        J[:, :-1] = (dRdX * scale[:, :, None, None]
                     * self.x_scale[None, None, :, :]).reshape(self.size, self.size)
        J[:, -1] = (dRdw * scale).ravel() * self.omega_unit
        ok = bool(np.all(np.isfinite(R))) and p._converged(R, X, omega)
        return (R * scale).ravel(), J, ok

    def function(self, z: np.ndarray) -> tuple[np.ndarray, bool]:
        """``(F, converged)`` of :meth:`system` without the Jacobian (the forces at the
        samples only: a fraction of a Jacobian's cost)."""
        X, omega = self.unpack(z)
        R = self.problem.residual(X, omega)
        ok = bool(np.all(np.isfinite(R))) and self.problem._converged(R, X, omega)
        return (R * self.row_scale).ravel(), ok

    def solve(self, z0: np.ndarray, a: np.ndarray, b: float,
              iterations: int = CORRECTOR_ITERATIONS,
              J0: np.ndarray | None = None) -> tuple:
        """Newton from ``z0`` on the balance and ``a . z = b``: ``(z, iterations)`` (``z``
        None when it fails). With the Jacobian ``J0`` (the last point's) first by chord
        steps: ``J0`` serves while the residual falls by :data:`CONTRACTION` an iteration, a
        fresh one is built where it does not; if that fails, by Newton with a fresh Jacobian
        every iteration (the kinks of the sampled AFT defeat chord steps where Newton
        passes: measured on the small wheel's elastic curve)."""
        total = 0
        for J in ((J0, None) if J0 is not None else (None,)):
            z, n = self._newton(z0, a, b, iterations, J)
            total += n
            if z is not None:
                return z, total
        return None, total

    def _newton(self, z0: np.ndarray, a: np.ndarray, b: float, iterations: int,
                J: np.ndarray | None) -> tuple:
        """:meth:`solve`'s iterations: chord steps from ``J``, exact ones when it is None."""
        chord = J is not None
        z = np.array(z0, dtype=float)
        last = math.inf
        for it in range(iterations + 1):
            if chord:
                F, ok = self.function(z)
            else:
                F, J, ok = self.system(z)
            if not np.all(np.isfinite(F)):
                return None, it
            gap = a @ z - b
            if ok and abs(gap) <= 1e-12 * max(1.0, np.abs(z).max()):
                return z, it
            if it == iterations:
                break
            norm = float(np.abs(F).max())
            if chord and norm > CONTRACTION * last:  # the chord stalls: a fresh Jacobian
                F, J, ok = self.system(z)
            last = norm
            try:
                step = np.linalg.solve(np.vstack([J, a]), np.r_[F, gap])
            except np.linalg.LinAlgError:
                return None, it
            z = z - step
        return None, iterations

    @staticmethod
    def tangent(J: np.ndarray, previous: np.ndarray) -> np.ndarray:
        """Unit null vector of ``J`` ``(n, n + 1)``, oriented along ``previous``."""
        t = np.linalg.solve(np.vstack([J, previous]), np.r_[np.zeros(J.shape[0]), 1.0])
        t /= np.linalg.norm(t)
        return t if t @ previous >= 0 else -t


def trace_frequency(problem: ForcedWave, X_start: np.ndarray, omega_start: float,
                    omega_end: float, x_ref: float, progress=None, jump: float = 0.0,
                    max_points: int = MAX_POINTS) -> Branch:
    """The forced response from the solved point ``X_start`` ``(2H + 1, m)`` at
    ``omega_start`` [rad/s] towards ``omega_end``, by pseudo-arclength continuation, until
    the frequency passes ``omega_end`` (the last point is then the curve at ``omega_end``,
    solved there), the curve turns back past ``omega_start``, or the step stalls.
    ``x_ref`` [sqrt(kg) m]: the vibration harmonics' unit (the response's expected size:
    the step is ``STEP`` of it at first). ``jump`` [rad/s]: where the step stalls (a corner
    where a contact starts to stick or slip), the curve is taken up again by Newton in the
    frequency (:func:`~.forced_wave.stepped_solve`, its backtracking and halvings) up to
    this far on, the jump recorded in ``Branch.jumps``; 0: no jumps.
    ``progress(point_index, omega, X)`` per point."""
    corrector = _corrector(problem, X_start, omega_start, omega_end, x_ref)
    sense = 1.0 if omega_end >= omega_start else -1.0
    along = np.r_[np.zeros(X_start.size), sense]  # the frequency's direction
    z = corrector.pack(X_start, omega_start)
    _, J, _ = corrector.system(z)
    t = corrector.tangent(J, along)
    zs, its, folds, jumps = [z], [0], [], []
    ds, failures, crawl, end = STEP, 0, 0, f"stopped after {max_points} points"
    in_frequency = 0
    while len(zs) < max_points:
        z_new, n, kink = _next_point(problem, corrector, zs[-1], t, J, ds, sense, failures)
        in_frequency += kink
        if z_new is None:
            ds /= 2
            failures += 1
            stalled = ds < STEP_MIN or failures > RETRIES
        else:
            failures = 0
            crawl = crawl + 1 if ds < CRAWL else 0
            stalled = crawl > CRAWL_POINTS
        if stalled:  # Newton in the frequency past the corner, else the trace ends here
            X_last, w_last = corrector.unpack(zs[-1])
            target = w_last + sense * min(jump, abs(omega_end - w_last))
            walked = _walk(problem, corrector, zs[-1], target) \
                if jump and target != w_last else []
            if not walked:
                end = f"stalled at {w_last / (2 * math.pi):.6g} Hz"
                break
            for z_walked, n_walked in walked[:-1]:  # the curve's points on the way
                zs.append(z_walked)
                its.append(n_walked)
            z_new, n = walked[-1]
            jumps.append((w_last, corrector.unpack(z_new)[1]))
            ds, failures, crawl = STEP, 0, 0
            t = along  # the tangent below is oriented along the frequency
        elif z_new is None or failures:
            continue
        _, J, _ = corrector.system(z_new)  # the tangent's (and the next chord steps')
        t_new = corrector.tangent(J, t)
        if t_new[-1] * t[-1] < 0 and not stalled:  # the frequency turned: a fold
            folds.append((_fold(corrector, zs[-1], t, z_new, t_new), len(zs) - 1))
        omega = corrector.unpack(z_new)[1]
        if sense * (omega - omega_end) > 0:  # past the end: the last point at omega_end
            X_end, ok, n = problem.solve(corrector.unpack(zs[-1])[0], omega_end)
            if ok:
                zs.append(corrector.pack(X_end, omega_end))
                its.append(n)
            end = REACHED
            break
        zs.append(z_new)
        its.append(n)
        t = t_new
        if progress is not None:
            progress(len(zs) - 1, omega, corrector.unpack(z_new)[0])
        if sense * (omega - omega_start) < 0 and folds:
            end = "turned back past the start of the range"
            break
        if stalled and sense * (omega - omega_end) == 0:
            end = REACHED
            break
        if not kink:
            ds = min(STEP_MAX, 1.5 * ds) if n <= 5 else (ds / 2 if n > 10 else ds)
    pts = [corrector.unpack(z) for z in zs]
    return Branch(np.array([w for _, w in pts]), np.stack([X for X, _ in pts]),
                  np.array(its), merged_folds(folds), end, jumps, in_frequency)


#: a stall is passed in this many steps of the frequency, each twice the last, each point
#: solved and kept: the first 1e-3 of the way (a plateau just past a slip onset is narrow
#: beside a grid's spacing: the small wheel's 0.04 Hz against 3.7 Hz)
WALK_STEPS = 10


def _walk(problem: ForcedWave, corrector: ArclengthCorrector, z_last: np.ndarray,
          target: float) -> list:
    """``[(z, iterations), ...]``: the curve from ``z_last`` towards ``target`` [rad/s] in
    :data:`WALK_STEPS` steps of the frequency, each twice the last, each solved from the last
    solved one (:func:`~.forced_wave.stepped_solve`; one that fails is passed over: empty when
    all did). Where the trace stalls at a corner of the curve (a contact starts or stops
    slipping) the curve goes on in the frequency, and a friction plateau beyond the corner
    is sampled on the way instead of being jumped over."""
    X, w = corrector.unpack(z_last)
    out = []
    share = (2.0 ** np.arange(1, WALK_STEPS + 1) - 1) / (2.0**WALK_STEPS - 1)
    for w_next in w + (target - w) * share:
        X_next, ok, n = stepped_solve(problem, X, w, float(w_next), depth=0)
        if ok:  # a step that fails is passed over, as a grid passes a frequency it misses
            X, w = X_next, float(w_next)
            out.append((corrector.pack(X, w), n))
    return out


def _in_frequency(problem: ForcedWave, corrector: ArclengthCorrector, z_last: np.ndarray,
                  predictor: np.ndarray, ds: float, sense: float) -> tuple:
    """``(z, iterations)`` of the balance solved at the ``predictor``'s frequency from the
    last point by the balance's own solver (:meth:`~.forced_wave.ForcedWave.solve`: its
    Newton variants and the relaxation along the slow flow), or ``(None, iterations)``.

    The corrector is Newton on the arclength system with the balance's analytic Jacobian,
    and the sampled AFT's residual has a kink wherever a sample's contact starts or stops
    sticking: on a friction plateau, where every point lies near a slip onset, the
    corrector fails at every step and the trace stalled (issue #69: the small wheel's
    plateau was never traced, only bridged by grid-wide jumps). Where the curve goes on in
    the frequency (the predictor moves in the trace's sense), the point is the curve's at
    the predictor's frequency: the frequency as the local parameter, as in a continuation
    that parametrises by the tangent's leading component. It is kept only within ``2 ds``
    of the predictor, the corrector's own acceptance, so it cannot land on another branch
    across a fold (near one the predictor's frequency barely moves and a solve there
    starts from the last point, on its own branch)."""
    X_last, w_last = corrector.unpack(z_last)
    w = corrector.unpack(predictor)[1]
    if sense * (w - w_last) <= 0:
        return None, 0
    X, ok, n = problem.solve(X_last, w)
    z = corrector.pack(X, w)
    if not ok or np.linalg.norm(z - predictor) > 2 * ds:
        return None, n
    return z, n


def _corrector(problem: ForcedWave, X_start: np.ndarray, omega_start: float,
               omega_end: float, x_ref: float) -> ArclengthCorrector:
    """The trace's corrector: the mean row in units of the start's mean (or ``x_ref``), the
    vibration rows in ``x_ref``, the frequency in units of the range to trace (the start's
    frequency was the unit, and on a narrow resonance a step of the arclength then moved the
    frequency across the whole range: the small wheel's 0.2 Hz plateau at 258 Hz was crossed
    in one step, from one branch to another)."""
    mean = max(float(np.abs(X_start[0]).max()), x_ref)
    x_scale = np.r_[mean, np.full(X_start.shape[0] - 1, x_ref)]
    return ArclengthCorrector(problem, x_scale, omega_start,
                              min(abs(omega_end - omega_start), omega_start) or None)


def _next_point(problem: ForcedWave, corrector: ArclengthCorrector, z_last: np.ndarray,
                t: np.ndarray, J: np.ndarray, ds: float, sense: float, failures: int) -> tuple:
    """``(z, iterations, kink)``: the next point a step ``ds`` along the tangent ``t`` (the
    corrector from the last point's Jacobian ``J``), or where the corrector misses it, on
    the first try of a point (``failures`` 0), the curve at the predictor's frequency
    (:func:`_in_frequency`; ``kink`` True: its iterations are the relaxation's, the step
    stays); ``z`` None when both fail. The second solve only once a point: a failed one
    costs the relaxation's patience (1-2 s on the small wheel; tried at every halving it
    took 260 of a 410 s trace)."""
    predictor = z_last + ds * t
    z, n = corrector.solve(predictor, t, float(t @ predictor), J0=J)
    if z is not None and np.linalg.norm(z - predictor) <= 2 * ds:
        return z, n, False
    if failures:
        return None, n, False
    z, n = _in_frequency(problem, corrector, z_last, predictor, ds, sense)
    return z, n, z is not None


def merged_folds(folds: list) -> list:
    """``folds`` ``[(omega, index), ...]`` in the order traced with each run of consecutive
    turns within :data:`FOLD_MERGE` of each other's frequency taken as one: an even run is
    a zig-zag (no turn), an odd one a single turn at the run's middle member."""
    out, run = [], []
    for fold in folds + [None]:
        if fold is not None and run and abs(fold[0] - run[-1][0]) <= FOLD_MERGE * fold[0]:
            run.append(fold)
            continue
        if len(run) % 2:
            out.append(run[len(run) // 2])
        run = [fold]
    return out


def _fold(corrector: ArclengthCorrector, z0: np.ndarray, t0: np.ndarray, z1: np.ndarray,
          t1: np.ndarray) -> float:
    """The frequency [rad/s] of the turning point between ``z0`` and ``z1`` (unit tangents
    ``t0``, ``t1`` whose frequency components have opposite signs): the cubic Hermite
    interpolant of the frequency over the chord's length, at its extremum (no solve: within
    the interpolant's error, ~(chord)^3 of the curvature's change; the points of the curve
    stay as solved)."""
    length = float(np.linalg.norm(z1 - z0))
    w0, w1 = float(z0[-1]), float(z1[-1])
    d0, d1 = float(t0[-1]) * length, float(t1[-1]) * length  # d nu / d (s / length)
    # nu(x) = h00 w0 + h10 d0 + h01 w1 + h11 d1 on x in [0, 1]; nu'(x) is quadratic
    a = 6 * w0 + 3 * d0 - 6 * w1 + 3 * d1
    b = -6 * w0 - 4 * d0 + 6 * w1 - 2 * d1
    c = d0
    roots = np.roots([a, b, c]) if abs(a) > 1e-300 else np.array([-c / b])
    x = next((float(r.real) for r in roots if abs(r.imag) < 1e-12 and 0 <= r.real <= 1), 0.5)
    nu = ((2 * x**3 - 3 * x**2 + 1) * w0 + (x**3 - 2 * x**2 + x) * d0
          + (-2 * x**3 + 3 * x**2) * w1 + (x**3 - x**2) * d1)
    return corrector.frequency(nu)


def traced_curve(model, params, beta: float, band: tuple[float, float],
                 equilibrium: np.ndarray, harmonics: int = 7, samples: int = 0,
                 lam: float = 1.0, x_ref: float = 0.0, progress=None,
                 refine: bool = False, jump: float = 0.0,
                 stability: bool = False) -> ForcedCurve:
    """The forced response over ``band`` ``(lo, hi)`` [rad/s] by arclength continuation from
    the steady state at ``lo`` (Newton from the preloaded ``equilibrium`` ``(N, m)``); when
    the trace stalls, the rest is traced back from ``hi`` towards where it stalled (the two
    pieces separated by a row not converged). ``x_ref`` [sqrt(kg) m]: the vibration
    harmonics' unit (0: :data:`START_FACTOR` times the largest harmonic at ``lo``; the
    largest amplitude of a grid solve is a better one). ``refine``: the peak on the curve
    (:func:`refine_on_branch`); ``jump`` [rad/s]: stalls passed by Newton in the frequency
    up to this far (:func:`trace_frequency`); ``stability``: each point's
    :func:`forced_growth` in ``curve.growth`` (paper law). Arguments otherwise as
    :func:`.forced_wave.forced_curve`."""
    t0 = time.perf_counter()
    samples = samples or 8 * (harmonics + 1)
    problem = ForcedWave(model, params, beta, harmonics, samples, lam)
    pieces, ends, folds = [], [], []
    lo, hi = (float(w) for w in band)
    for start, end in ((lo, hi), (hi, None)):
        if end is None:  # the way back: from hi to where the first piece stopped
            if ends[0].startswith(REACHED):
                break
            # (the whole band when Newton failed at lo; not below lo after a turn back)
            end = max(float(pieces[0][0].frequency[-1]), lo) if pieces else lo
        X = np.zeros((2 * harmonics + 1, model.modes))
        X[0] = equilibrium[0]
        X, ok, _ = problem.solve(X, start)
        if not ok:
            ends.append(f"Newton fails at {start / (2 * math.pi):.6g} Hz")
            continue
        # the unit: ten times the band edge's response (off resonance: a resonance is
        # typically 3-30 times larger), unless given
        x_ref = x_ref or max(START_FACTOR * float(np.abs(X[1:]).max()), 1e-300)
        branch = trace_frequency(problem, X, start, end, x_ref, progress, jump)
        pieces.append((branch, start == hi))
        passed = "".join(f"; passed {a / (2 * math.pi):.6g}..{b / (2 * math.pi):.6g} Hz by "
                         "Newton in the frequency" for a, b in branch.jumps)
        kinks = (f" ({branch.in_frequency} points solved in the frequency at stick-slip "
                 "kinks)" if branch.in_frequency else "")
        ends.append(branch.end + kinks + passed)
        folds += [w for w, _ in branch.folds]
    curve = _curve_of(problem, model, params, pieces, "; ".join(ends), folds)
    curve.growth = np.full(curve.frequency.size, np.nan)
    if stability and not params.law.elastic:
        for i in np.flatnonzero(curve.converged):
            curve.growth[i] = forced_growth(problem, curve.harmonics[i],
                                            float(curve.frequency[i]))
    if refine and pieces:
        curve.refined = refine_on_branch(problem, curve, x_ref)
    curve.wall_s = time.perf_counter() - t0
    return curve


REACHED = "reached the end of the range"


def forced_growth(problem: ForcedWave, X: np.ndarray, omega: float) -> float:
    """[1/s] the largest real part of the Floquet exponents of the forced steady state ``X``
    at ``omega`` [rad/s]: Hill's method on the balance's linearisation
    (:func:`~.floquet.exponents`) in the forced wave's Bloch family ``k``, where the
    amplitude and phase perturbations of the response live (a fold's real multiplier), and
    in family 0: their slots -1..1 hold the NDs 0, ``k`` and ``2k`` (tested: about a state
    whose contacts stay linear, the linear stability's largest growth over those NDs, to
    1e-5; the other NDs, where a quasi-periodic onset would show, are not checked).
    No exponent is removed: the nozzle fixes the phase (no phase shift's multiplier 1). A
    contact that opens within the period makes the force derivatives jump and the exponents
    converge slowly with ``H``: near a fold the sign can be wrong (measured on the lift-off
    ring: within 0.1 Hz of its upper fold). Paper law only (the elastic law's hysteresis has
    no linearisation per time sample)."""
    b = problem.balance
    lin = b.linearise(X, omega, problem.lam)
    families = sorted({0, min(b.wave, b.blades - b.wave)})
    return max(float(exponents(b, lin, omega, problem.lam,
                               2 * math.pi * p / b.blades).real.max()) for p in families)


def _curve_of(problem: ForcedWave, model, params, pieces: list, trace: str,
              folds: list) -> ForcedCurve:
    """The :class:`ForcedCurve` of the traced ``pieces`` (``(branch, traced from hi)``; one
    traced from the band's high end reversed: the curve runs from its low end; a row not
    converged between two that do not meet)."""
    reversed_ = [Branch(b.frequency[::-1], b.harmonics[::-1], b.iterations[::-1]) if back
                 else b for b, back in pieces]
    if len(pieces) == 2:
        first, back = reversed_
        meet = _meet(pieces[0][0], pieces[1][0])
        reversed_ = [first, back] if meet else [first, None, back]
    pieces = reversed_
    n, m = 2 * problem.balance.H + 1, model.modes
    K = len(params.contacts.kinds)
    rows = []
    for piece in pieces:
        if piece is None:
            rows.append((np.nan, np.full((n, m), np.nan), False, 0))
            continue
        rows += [(w, X, True, it) for w, X, it in
                 zip(piece.frequency, piece.harmonics, piece.iterations, strict=True)]
    F = len(rows)
    out = ForcedCurve(np.array([r[0] for r in rows], dtype=float),
                      np.stack([r[1] for r in rows]) if rows else np.zeros((0, n, m)),
                      np.full(F, np.nan), np.array([r[2] for r in rows], dtype=bool),
                      np.array([r[3] for r in rows], dtype=int), np.full((F, K, 3), np.nan),
                      problem.wave, int(nodal_diameter(problem.wave, model.blades)),
                      kinds=params.contacts.kinds, folds=np.array(sorted(folds)),
                      trace=trace)
    for i in np.flatnonzero(out.converged):
        w = float(out.frequency[i])
        out.tip_amplitude[i] = problem.tip_amplitude(out.harmonics[i], w)
        if K:
            out.fractions[i] = problem.fractions(out.harmonics[i], w)
    return out


def _meet(first: Branch, second: Branch) -> bool:
    """Whether the last points of two pieces traced towards each other are one steady state
    (frequency to 1e-9, harmonics to 1e-6 of their size): the curve is then whole, the
    first piece stopped where the second passed (a corner of the sampled AFT's curve)."""
    w1, w2 = first.frequency[-1], second.frequency[-1]
    X1, X2 = first.harmonics[-1], second.harmonics[-1]
    size = max(float(np.abs(X1[1:]).max()), 1e-300)
    return bool(abs(w1 - w2) <= 1e-9 * w1 and np.abs(X1[1:] - X2[1:]).max() <= 1e-6 * size)


def refine_on_branch(problem: ForcedWave, curve: ForcedCurve,
                     x_ref: float) -> RefinedPeak | None:
    """The largest tip amplitude of a traced curve beside its largest point: golden-section
    search over the chord to each converged neighbour, each trial point the curve's
    intersection with the hyperplane normal to the chord there (a peak on a fold, where the
    frequency turns, is found as well as one between two frequencies); to 1e-3 of the chord
    and :data:`.forced_wave.PEAK_AMPLITUDE` of the amplitude. The curve of a contact that
    sticks and slips is wavy at low H: this is the largest local maximum beside the largest
    point, which a denser curve may exceed (``solves``: the searches' Newton solves)."""
    if not curve.converged.any():
        return None
    i = curve.peak
    ok = curve.converged
    X0, w0 = curve.harmonics[i], float(curve.frequency[i])
    x_scale = np.r_[max(float(np.abs(X0[0]).max()), x_ref), np.full(X0.shape[0] - 1, x_ref)]
    corrector = ArclengthCorrector(problem, x_scale, w0)
    best = (float(curve.tip_amplitude[i]), X0, w0)
    solves = 0
    for j in (i - 1, i + 1):
        if 0 <= j < ok.size and ok[j]:
            found, n = _golden_on_chord(problem, corrector, corrector.pack(X0, w0),
                                        corrector.pack(curve.harmonics[j],
                                                       float(curve.frequency[j])))
            solves += n
            best = max(best, found, key=lambda f: f[0])
    A, X, w = best
    return RefinedPeak(w, A, X, problem.fractions(X, w), solves)


def _golden_on_chord(problem: ForcedWave, corrector: ArclengthCorrector, za: np.ndarray,
                     zb: np.ndarray) -> tuple[tuple, int]:
    """``((amplitude, X, omega), solves)``: the largest tip amplitude found by golden-section
    search on the curve between its points ``za`` and ``zb`` (scaled)."""
    chord = zb - za
    e = chord / max(float(np.linalg.norm(chord)), 1e-300)
    known = {}

    def amplitude(s: float) -> float:
        if s not in known:
            zp = za + s * chord
            z, _ = corrector.solve(zp, e, float(e @ zp))
            if z is None:
                known[s] = (-math.inf, None, None)
            else:
                X, w = corrector.unpack(z)
                known[s] = (problem.tip_amplitude(X, w), X, w)
        return known[s][0]

    golden = (math.sqrt(5.0) - 1.0) / 2.0
    a, b, left, right = 1 - golden, golden, 0.0, 1.0
    for _ in range(80):  # to 1e-3 of the chord and the amplitudes agreeing, or 1e-9
        fa, fb = amplitude(a), amplitude(b)
        if right - left < 1e-9 or (right - left < 1e-3
                                   and abs(fa - fb) <= PEAK_AMPLITUDE * max(fa, fb)):
            break
        if fa >= fb:
            right, b = b, a
            a = right - golden * (right - left)
        else:
            left, a = a, b
            b = left + golden * (right - left)
    found = max(known.values(), key=lambda f: f[0])
    return found, len(known)
