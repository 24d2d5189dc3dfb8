"""Newton with the least-squares step, for shots whose Jacobian can be singular: a contact
that sticks the whole period under the elastic law leaves its slider free (a neutral
direction), so the step is the minimum-norm one (the free directions stay where they are).
The forced shot (:mod:`.forced_shooting`) and the elastic law's autonomous shot
(:mod:`.slider_shooting`) solve with it, on unknowns scaled to the vibration."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

#: converged at this residual (scaled: relative to the vibration), or at the caller's
#: rounding floor
TOLERANCE = 1e-10
#: a Newton that no longer reduces a residual this small has reached the rounding of the
#: shot (a whole period of the whole wheel under an aerodynamic table: 800 steps, 2.9e-10)
STAGNATION = 1e-8
#: the least-squares cut-off, relative to the largest singular value: above the differences'
#: noise (~1e-10 of the unknowns over their scale; a stuck slider's offset is large in units
#: of the vibration), so that a neutral direction takes no step of residual over noise
RCOND = 1e-8
HALVINGS = 7  # of a step whose residual's 2-norm does not fall


#: a chord step (the last Jacobian kept) that reduces the residual's 2-norm by less than this
#: factor asks for a fresh Jacobian at the next iteration. A Jacobian costs ``2 n`` shots, a
#: step one: the paper wheel's 1 N peak at half the step, its chord started on the coarse
#: step's Jacobian, contracts by 0.13-0.34 a step; at 0.25 it asked for a fresh one (18.6
#: s), at 0.5 it converged on the chord (1.9 s, the same state to 1e-10)
CHORD_CONTRACTION = 0.5


def newton_least_squares(residual: Callable, jacobian: Callable, z: np.ndarray,
                         floor: float, max_iterations: int, chord: bool = False,
                         start: np.ndarray | None = None):
    """``(z, F, size, reason, iterations)``: Newton on ``residual(z)`` (scaled, ``(r,)``)
    from ``z`` with ``jacobian(z)`` ``(r, len(z))``, each step the least-squares one halved
    until the residual's 2-norm falls (the direction descends in it, not necessarily in the
    max norm ``size`` that decides convergence: ``size <= max(TOLERANCE, floor)``).
    ``reason`` in words: 'converged', 'converged at the rounding floor', 'the shot
    diverged', 'no step reduces the residual' or 'iterations'.

    ``chord``: the Jacobian's pseudo-inverse is kept from one iteration to the next while
    each step reduces the residual's 2-norm by :data:`CHORD_CONTRACTION` (a fresh one where
    it does not, and before giving up): a Jacobian of a shot costs ``2 n`` shots, a step one
    (the forced state of the paper wheel: 8.5 s against 0.1 s). ``start``: with ``chord``,
    a Jacobian ``(r, len(z))`` near ``z`` the chord starts on (the same state's at twice
    the step), replaced like a kept one where its step does not contract."""
    F = residual(z)
    size, reason, it = float(np.abs(F).max()), "iterations", 0
    inverse = None if start is None or not chord else np.linalg.pinv(start, rcond=RCOND)
    fresh = False
    for it in range(max_iterations + 1):
        if not math.isfinite(size):
            reason = "the shot diverged"
            break
        if size <= max(TOLERANCE, floor):
            reason = "converged"
            break
        if it == max_iterations:
            break
        if not chord:
            dz = np.linalg.lstsq(jacobian(z), -F, rcond=RCOND)[0]
        else:
            if inverse is None:
                inverse, fresh = np.linalg.pinv(jacobian(z), rcond=RCOND), True
            dz = -(inverse @ F)
        a, norm, stepped = 1.0, float(np.linalg.norm(F)), False
        for _ in range(HALVINGS):
            trial = residual(z + a * dz)
            if np.linalg.norm(trial) < norm:
                z, F, stepped = z + a * dz, trial, True
                size = float(np.abs(F).max())
                break
            a *= 0.5
        if chord and (not stepped or np.linalg.norm(F) > CHORD_CONTRACTION * norm):
            stale = not fresh
            inverse, fresh = None, False
            if stale and not stepped:  # the kept Jacobian's step failed: a fresh one
                continue
        fresh = False
        if not stepped:  # stagnated: at the rounding floor of a long shot, or stuck
            reason = "converged at the rounding floor" if size <= STAGNATION else \
                "no step reduces the residual"
            break
    return z, F, size, reason, it


def central_columns(shot: Callable, x: np.ndarray, scale: np.ndarray, step: float,
                    columns: np.ndarray | None = None) -> np.ndarray:
    """``(n, c)`` columns ``columns`` (default all) of ``d shot / dx`` at ``x`` ``(n,)`` in
    units of ``scale`` ``(n,)``, by central differences of ``step`` in those units: all
    ``2 c`` perturbed states one call of ``shot`` (``(B, n) -> (B, n)``, one batch of the
    compiled kernel); the columns not asked for (held or locked sliders) are not shot."""
    cols = np.arange(x.size) if columns is None else np.asarray(columns)
    c = cols.size
    h = step * scale[cols]
    perturbed = np.repeat(x[None], 2 * c, axis=0)
    perturbed[np.arange(c), cols] += h
    perturbed[c + np.arange(c), cols] -= h
    shots = shot(perturbed)
    derivative = (shots[:c] - shots[c:]) / (2 * h[:, None])  # row i: d end / d x_i
    return derivative.T * scale[cols][None, :] / scale[:, None]


#: reduced rank extrapolation every this many periods of a march (the small wheel's 256 Hz
#: partial slip: 66 periods instead of 1547 with 10, 71 with 5, 64 with 20)
EXTRAPOLATION_WINDOW = 10


def reduced_rank_extrapolation(iterates: np.ndarray) -> np.ndarray:
    """The fixed point of a map that the ``(k + 2, n)`` successive ``iterates`` (scaled)
    approach, as reduced rank extrapolation estimates it: ``sum_i g_i x_(i+1)`` with the
    weights ``g`` (summing to 1) that make ``sum_i g_i (x_(i+1) - x_i)`` smallest.

    Exact for a linear map with ``k`` or fewer modes in the start's error, whatever
    their multipliers' signs and phases: the march of a forced shot approaches its state
    along several lightly damped modes of the wheel at once, with multipliers between
    -0.88 and -0.99 (measured on the small wheel at 256 Hz), where a one-direction Aitken
    step never applies. Sidi, "Vector extrapolation methods with applications", SIAM 2017,
    ch. 1."""
    moves = np.diff(iterates, axis=0)
    gram = moves @ moves.T
    # the moves become nearly dependent as the march converges: a rounding-level ridge
    gram += 1e-14 * np.trace(gram) * np.eye(len(gram))
    weights = np.linalg.solve(gram, np.ones(len(gram)))
    return (weights / weights.sum()) @ iterates[1:]
