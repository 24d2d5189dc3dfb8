"""Convergence orders measured against a reference, held only where they mean something.

An error measured against a reference cannot fall below the reference's own error (its
*floor*: truncation and rounding, which differ between CPUs). A test that asserts an order
on errors near that floor passes on one machine and fails on another (#46: the finest
exponential step's error 1.2e-12 sat on the 5dp reference's floor on an EPYC). So every
convergence test measures its reference's floor (the reference at two steps) and asserts
its finest error at least ``FLOOR_MARGIN`` times above it before any ratio.
"""

import numpy as np

FLOOR_MARGIN = 10.0


def assert_order(errors, floor: float, low: float, high: float = np.inf) -> np.ndarray:
    """Assert every error in ``errors`` (coarse to fine) is at least ``FLOOR_MARGIN`` times
    the reference's ``floor`` and every ratio of consecutive errors lies in ``(low, high)``;
    returns the ratios."""
    errors = np.asarray(errors, dtype=float)
    assert np.all(np.isfinite(errors)) and floor >= 0.0, (errors, floor)
    assert errors.min() > FLOOR_MARGIN * floor, (
        f"the finest error {errors.min():.3g} is within {FLOOR_MARGIN:g}x of the reference's "
        f"floor {floor:.3g}: refine the reference or drop the finest step", errors)
    ratios = errors[:-1] / errors[1:]
    assert np.all((ratios > low) & (ratios < high)), (errors, ratios)
    return ratios


def rounding_floor(steps: int) -> float:
    """The floor of a quantity with no reference but the exact law (an energy balance, a
    drift): the rounding of ``steps`` accumulated terms, ``steps * eps`` relative."""
    return steps * float(np.finfo(float).eps)
