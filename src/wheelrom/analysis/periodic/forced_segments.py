"""The nonlinear forced response's frequency grid over MPI ranks (issue #45): the grid is cut
into contiguous segments, dealt to the ranks in turn; each is solved by natural continuation,
started at rest one frequency early (at the previous segment's last frequency), and the seams
are checked.

Where a rank's first state, solved at rest at the previous segment's last frequency, is that
segment's own last state (to :data:`SEAM_TOLERANCE`), the rank continued from the state one
process would have continued from, and its segment is the one process's curve. Where it is
not (two steady states coexist there, inside a fold of the curve, or either solve failed),
the segment is solved again from the previous segment's last solution, in order, as one
process does: the curve never depends on the number of ranks, and a grid without folds at
its seams costs about ``1 / P`` of one process's time plus one solve a segment."""

from __future__ import annotations

import time

import numpy as np

from wheelrom.analysis.periodic.forced_wave import (
    ForcedCurve,
    ForcedWave,
    at_rest,
    continue_over,
    empty_curve,
    forced_curve,
    refine_peak,
)
from wheelrom.forces.parameters import ForceParameters
from wheelrom.rom.model import ReducedModel

#: two solutions at a seam are one steady state when their harmonics differ by at most this
#: share of the larger motion (each solve is converged to ~1e-7 of it; a second state of the
#: same frequency differs at order 1)
SEAM_TOLERANCE = 1e-5
#: segments a rank solves on average, taken from a shared queue as ranks become free: the
#: cost of a frequency varies along the band (the paper wheel's 200-point elastic curve
#: spends 40 % of its time in the first eighth, at the slipping resonance), and each segment
#: costs one solve from rest more and starts without the secant predictor or a carried chord
#: matrix: of 2, 4 and 8 segments a rank, 2 were the fastest on 2 ranks under the elastic law
#: (the paper wheel's 200-point curve in 22 s against 30 s with 8; docs/history.md)
SEGMENTS_PER_RANK = 2


def segmented_curve(model: ReducedModel, params: ForceParameters, beta: float, frequencies,
                    equilibrium: np.ndarray, comm, harmonics: int = 7, samples: int = 0,
                    lam: float = 1.0, progress=None, refine: bool = False, segments: int = 0,
                    taken=None) -> ForcedCurve:
    """:func:`.forced_wave.forced_curve` with its frequencies cut into ``segments``
    contiguous segments (0: :data:`SEGMENTS_PER_RANK` a rank, at least two frequencies
    each) solved by the ranks of the mpi4py communicator ``comm``: this rank solves the
    segment indices ``taken`` yields (an iterable shared by the ranks, such as a
    :class:`~wheelrom.studies.queue.CaseQueue`; None: dealt in turn). Every rank returns the
    whole curve; ``curve.resolved_seams`` the seams solved again in order. One rank, or
    fewer than two frequencies a rank: the one process's loop."""
    w_all = np.atleast_1d(np.asarray(frequencies, dtype=float))
    ranks = 1 if comm is None else comm.size
    if ranks == 1 or w_all.size < 2 * ranks:
        return forced_curve(model, params, beta, w_all, equilibrium, harmonics, samples, lam,
                            progress, refine)
    t0 = time.perf_counter()
    problem = ForcedWave(model, params, beta, harmonics, samples, lam)
    count = min(segments or segment_count(w_all.size, ranks), w_all.size // 2)
    bounds = segment_bounds(w_all.size, count)
    taken = range(comm.rank, count, ranks) if taken is None else taken
    mine = {r: solve_segment(problem, model, params, w_all, equilibrium, bounds, r, progress)
            for r in taken}
    parts, curve = comm.gather(mine, root=0), None
    if comm.rank == 0:  # one rank decides the seams and the peak, every rank holds them
        pieces = {r: piece for part in parts for r, piece in part.items()}
        curve = stitch(problem, model, params, w_all, equilibrium, bounds,
                       [pieces[r] for r in range(count)])
        if refine:
            curve.refined = refine_peak(problem, curve)
    curve = comm.bcast(curve, root=0)
    curve.wall_s = time.perf_counter() - t0
    return curve


def segment_count(frequencies: int, ranks: int) -> int:
    """Segments for ``frequencies`` over ``ranks``: :data:`SEGMENTS_PER_RANK` a rank, at
    least two frequencies a segment."""
    return max(ranks, min(ranks * SEGMENTS_PER_RANK, frequencies // 2))


def segment_bounds(frequencies: int, segments: int) -> np.ndarray:
    """``(segments + 1,)``: segment ``r`` is the frequencies ``bounds[r]:bounds[r + 1]``."""
    return np.array([frequencies * r // segments for r in range(segments + 1)])


def solve_segment(problem: ForcedWave, model: ReducedModel, params: ForceParameters,
                  frequencies: np.ndarray, equilibrium: np.ndarray, bounds: np.ndarray,
                  rank: int, progress=None) -> ForcedCurve:
    """Segment ``rank`` of ``frequencies`` [rad/s] by natural continuation from rest, from
    the previous segment's last frequency on (its first point: the seam's check)."""
    first = bounds[rank] - 1 if rank > 0 else 0
    piece = empty_curve(problem, model, params, frequencies[first : bounds[rank + 1]])

    def told(i, w, amplitude):  # the grid's index; the seam's point is the segment before's
        if first + i >= bounds[rank]:
            progress(first + i, w, amplitude)

    continue_over(problem, piece, range(piece.frequency.size), at_rest(problem, equilibrium),
                  None, told if progress is not None else None)
    return piece


def stitch(problem: ForcedWave, model: ReducedModel, params: ForceParameters,
           frequencies: np.ndarray, equilibrium: np.ndarray, bounds: np.ndarray,
           pieces: list[ForcedCurve]) -> ForcedCurve:
    """The whole curve from every rank's :func:`solve_segment`, in order: a segment whose
    first state is not the previous segment's last (:func:`same_state`) is solved again
    from the last solution before it (the equilibrium at rest if none), with the one
    process's secant predictor through the two last solutions."""
    curve = empty_curve(problem, model, params, frequencies)
    for r, piece in enumerate(pieces):
        lo, hi = int(bounds[r]), int(bounds[r + 1])
        if r == 0 or same_state(curve, lo - 1, piece, 0):
            skip = 0 if r == 0 else 1
            for name in ("harmonics", "tip_amplitude", "converged", "iterations", "fractions"):
                getattr(curve, name)[lo:hi] = getattr(piece, name)[skip:]
            continue
        curve.resolved_seams.append(float(frequencies[lo - 1]))
        done = np.flatnonzero(curve.converged[:lo])  # the one process's last two solutions
        X, last, before = at_rest(problem, equilibrium), None, None
        if done.size:
            X, last = curve.harmonics[done[-1]], float(frequencies[done[-1]])
        if done.size > 1:
            before = (curve.harmonics[done[-2]], float(frequencies[done[-2]]))
        continue_over(problem, curve, range(lo, hi), X, last, before=before)
    return curve


def same_state(a: ForcedCurve, i: int, b: ForcedCurve, j: int) -> bool:
    """Whether point ``i`` of ``a`` and point ``j`` of ``b`` both converged to one steady
    state (:data:`SEAM_TOLERANCE`)."""
    if not (a.converged[i] and b.converged[j]):
        return False
    X, Y = a.harmonics[i], b.harmonics[j]
    motion = max(float(np.abs(X[1:]).max()), float(np.abs(Y[1:]).max()), 1e-300)
    return float(np.abs(X - Y).max()) <= SEAM_TOLERANCE * motion
