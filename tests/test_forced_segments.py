"""The nonlinear forced response's grid shared over ranks in segments (:mod:`wheelrom.
analysis.periodic.forced_segments`, issue #45), the ranks played in turn in one process: on
the lift-off ring whose peak folds (tests/test_forced_branch.py), a seam between the folds
where the downward sweep is on the upper state and a start at rest finds the lower one is
caught and its segment solved again in order (the curve the one process's to 1e-9); a seam
where both starts find one state keeps the rank's segment (the one process's curve to
Newton's tolerance). ``mpirun -n 2`` against one process: tests/mpi/test_forced_segments_mpi.py.
"""

import math

import numpy as np
import pytest

from test_forced_branch import BETA, H, lift_off_ring
from wheelrom.analysis.periodic import forced_segments as segments
from wheelrom.analysis.periodic.forced_wave import ForcedWave, forced_curve

RANKS = 2


def _stitched(frequencies_hz):
    """``(one process's curve, the ranks' pieces, the stitched curve, the bounds)``."""
    model, params = lift_off_ring()
    equilibrium = np.zeros((3, 1))
    w = 2 * math.pi * np.asarray(frequencies_hz)
    serial = forced_curve(model, params, BETA, w, equilibrium, harmonics=H, lam=0.0)
    problem = ForcedWave(model, params, BETA, H, 0, 0.0)
    bounds = segments.segment_bounds(w.size, RANKS)
    pieces = [segments.solve_segment(problem, model, params, w, equilibrium, bounds, r)
              for r in range(RANKS)]
    return serial, pieces, segments.stitch(problem, model, params, w, equilibrium, bounds,
                                           pieces), bounds


def test_a_seam_inside_the_fold_is_solved_again_in_order():
    """Down from 135 to 110 Hz (folds at 121.5 and 127.1 Hz): the seam at 123 Hz holds three
    states; the sweep is on the upper one (0.61 mm), rank 1's start at rest finds the lower
    (43 um): its segment is solved again from the upper state, and the curve jumps down at
    the upper fold as the one process's does."""
    serial, pieces, curve, bounds = _stitched(np.linspace(135.0, 110.0, 26))
    seam = bounds[1] - 1
    assert curve.frequency[seam] / (2 * math.pi) == pytest.approx(123.0)
    assert pieces[1].tip_amplitude[0] < 0.2 * pieces[0].tip_amplitude[-1]  # another state
    assert curve.resolved_seams == [curve.frequency[seam]]
    np.testing.assert_array_equal(curve.converged, serial.converged)
    np.testing.assert_allclose(curve.tip_amplitude, serial.tip_amplitude, rtol=1e-9)
    assert serial.tip_amplitude[seam] > 10 * serial.tip_amplitude[-1]  # the jump after it


def test_a_seam_with_one_state_keeps_the_ranks_segment():
    """Up from 110 to 135 Hz the seam (122 Hz) is on the lower state either way: nothing is
    solved again, the curve is the one process's to Newton's tolerance."""
    serial, pieces, curve, bounds = _stitched(np.linspace(110.0, 135.0, 26))
    assert curve.resolved_seams == []
    assert segments.same_state(pieces[0], -1, pieces[1], 0)
    np.testing.assert_array_equal(curve.converged, serial.converged)
    np.testing.assert_allclose(curve.tip_amplitude, serial.tip_amplitude, rtol=1e-7)


def test_segment_bounds_cover_the_grid_once():
    assert segments.segment_bounds(12, 4).tolist() == [0, 3, 6, 9, 12]
    assert segments.segment_bounds(7, 2).tolist() == [0, 3, 7]
