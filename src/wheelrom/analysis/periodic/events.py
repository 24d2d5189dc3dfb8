"""Events in the step: an orbit's contact switches (a contact opening or closing, the elastic
law's slider starting or stopping) located once, and step schedules whose pieces end at them,
each piece integrated with every contact held on the branch the orbit has there
(docs/theory.md "Events in the step").

Why: the contact laws switch branches (the normal force's kink at lift-off, the elastic law's
stick and slip). A fixed step that straddles a switch makes the step's map first order there,
and the multipliers, differences of that map, scatter with where the switches fall in the
steps (the paper's 90 deg orbit: 1.47 / 2.21 / 1.55 / 1.73 / 1.79 at 10 / 5 / 2.5 / 1.25 /
0.62 us). A perturbed state switches a little earlier or later than the orbit, but with the
contact held on one smooth branch up to the orbit's switch the map is smooth in the state,
and the switch of a force that is continuous across it costs nothing to first order (its
saltation matrix is the identity): the period map's Jacobian converges at the scheme's order
(the same orbit: 1.8565 / 1.8278 / 1.8231 / 1.8227 / 1.8227). The elastic law's force is
continuous at its switches too (the trial force is on the Coulomb limit at both).

Not events: the paper law's turn from its micro-slip branch to its slip branch at `|v| = v_k`
(a kink in the slip velocity; with Table 1's `v_k` = 0.6 m/s no contact of the paper's study
reaches it), and the 2D slip's turning direction, which the kernel's once-a-step return of the
slider integrates at first order (docs/theory.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wheelrom.forces.contact_law import HELD_OPEN, HELD_SLIP, HELD_STICK

#: samples of the locating pass per step of the flow it runs on
LOCATE_SAMPLES = 8
#: bisections of a switch inside its sample interval (2^-40 of it: the round-off of t)
BISECTIONS = 40
#: the probe step [share of a sample interval] that tells a slipping slider from a stuck one
#: (:func:`contact_modes`), and the share of it that bisects a slip's start (:func:`_bisect`)
PROBE, PROBE_BISECT = 1e-3, 1e-6


@dataclass(frozen=True)
class Schedule:
    """Pieces ``(duration [s], steps, modes)`` over ``duration`` [s], ``modes`` ``(K, N)``
    each contact's held branch (:mod:`wheelrom.forces.contact_law`: ``HELD_OPEN``,
    ``HELD_STICK``, ``HELD_SLIP``) as floats (the kernel's context)."""

    duration: float
    pieces: tuple

    @property
    def steps(self) -> int:
        return sum(p[1] for p in self.pieces)


@dataclass(frozen=True)
class Switches:
    """The contact switches of a flow from one state over ``duration`` [s]: ``times``
    ``(S,)`` [s] from the start, ``modes`` ``(S + 1, K, N')`` every contact's branch on each
    piece between them (the pattern's blades)."""

    duration: float
    times: np.ndarray
    modes: np.ndarray

    def schedule(self, step: float, blades: int | None = None) -> Schedule:
        """The pieces in whole steps of at most ``step`` [s]; ``blades``: the modes tiled
        over a wheel of that many blades (a pattern's copies, blade ``s`` is pattern blade
        ``s mod N'``)."""
        bounds = np.concatenate([[0.0], self.times, [self.duration]])
        pattern = self.modes.shape[2]
        tile = np.arange(pattern if blades is None else blades) % pattern
        pieces = []
        for i, (a, b) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
            n = max(1, math.ceil((b - a) / step * (1 - 1e-12)))
            pieces.append((float(b - a), n, self.modes[i][:, tile].astype(float)))
        return Schedule(self.duration, tuple(pieces))


def contact_modes(flow, state: np.ndarray, probe: float) -> np.ndarray:
    """``(K, N')`` the branch of every contact at the flat ``state`` (``q, q'`` and the
    sliders, returned at it): open where its normal force is 0; under the elastic law
    slipping where a probe step of ``probe`` [s] moves its slider (the kernel's own Coulomb
    limit: the reference force model's kinematics differ from the kernel's by 5e-9 of the
    force, at second order in the arm's rotation, too much to test the limit against), else
    stuck; the paper law has no slider (closed is ``HELD_STICK``)."""
    N, m = flow.N, flow.m
    q = np.ascontiguousarray(state[: N * m].reshape(N, m))
    v = np.ascontiguousarray(state[N * m : 2 * N * m].reshape(N, m))
    K = len(flow.params.contacts.kinds)
    sliders = state[2 * N * m :].reshape(K, N, 2) if flow.sliders else None
    forces = flow.forces()
    forces.evaluate(0.0, q, v, sliders)
    closed = forces.normal_force > 0.0
    modes = np.where(closed, HELD_STICK, HELD_OPEN)
    if sliders is not None:
        later = flow.advance(state[None], probe, 1)[0][2 * N * m :].reshape(K, N, 2)
        modes = np.where(closed & np.any(later != sliders, axis=2), HELD_SLIP, modes)
    return modes


def _bisect(flow, state: np.ndarray, h: float, modes: np.ndarray, now: np.ndarray,
            contact: int, probe: float) -> float:
    """[s] from ``state`` to where contact ``contact`` (flat index) leaves its branch
    (``modes`` at ``state``, ``now`` a step ``h`` later; :data:`BISECTIONS` halvings, one
    step each). The probe of :func:`contact_modes` finds a slip that starts up to its length
    early; a slip's end, where the slip velocity falls through 0, it sees half its length
    early (the slider's displacement over it, a parabola about the end, is 0 there) but no
    later than where that displacement falls below the round-off: a slip's end is bisected
    with ``probe`` and moved on by half of it, every other change with
    :data:`PROBE_BISECT` of it."""
    ending = modes.ravel()[contact] == HELD_SLIP and now.ravel()[contact] == HELD_STICK
    probe = probe if ending else probe * PROBE_BISECT
    lo, hi = 0.0, h
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        inner = flow.advance(state[None], mid, 1)[0]
        if contact_modes(flow, inner, probe).ravel()[contact] != modes.ravel()[contact]:
            hi = mid
        else:
            lo = mid
    return min(hi + 0.5 * probe, h) if ending else hi


def orbit_switches(flow, orbit, step: float = 0.0) -> Switches:
    """:func:`locate` over a shot of ``orbit`` (a :class:`~.shooting.Orbit`: its flat state
    at ``t = 0``, ``fraction`` of its ``period``) on ``flow``, sampled at ``step`` [s] (0:
    the orbit's own step)."""
    return locate(flow, orbit.flat(), orbit.fraction * orbit.period,
                  step or orbit.period / max(orbit.steps_per_period, 1))


def locate(flow, x: np.ndarray, duration: float, step: float,
           samples: int = LOCATE_SAMPLES) -> Switches:
    """The :class:`Switches` of the free flow from the flat state ``x`` over ``duration``
    [s]: the contacts' branches sampled ``samples`` times per step of at most ``step`` [s],
    and every contact's change bisected to where it happens (:func:`contact_modes`)."""
    count = max(1, math.ceil(duration / step * (1 - 1e-12))) * samples
    h = duration / count
    probe = PROBE * h
    state = np.array(x, dtype=float)
    start = modes = contact_modes(flow, state, probe)
    changes = []  # (time, flat contact index, its new branch)
    for i in range(count):
        after = flow.advance(state[None], h, 1)[0]
        now = contact_modes(flow, after, probe)
        changed = np.flatnonzero(now.ravel() != modes.ravel())
        if changed.size:
            found = [(_bisect(flow, state, h, modes, now, c, probe), int(c))
                     for c in changed]
            changes += [(i * h + at, c, int(now.ravel()[c])) for at, c in found]
            # on from the first switch: a sample step across it would be first order there
            # and move the later switches by its error (measured: 3e-7 of the period)
            first = min(found)[0]
            if first < (1 - 1e-9) * h:
                switched = flow.advance(state[None], first, 1)[0]
                after = flow.advance(switched[None], h - first, 1)[0]
                again = contact_modes(flow, after, probe)
                # a switch the restart moves across the interval's end (rare: both within
                # a round-off of it) is taken from the restart's integration
                for c in np.flatnonzero(again.ravel() != now.ravel()):
                    changes = [ch for ch in changes if not (ch[0] > i * h and ch[1] == c)]
                    if again.ravel()[c] != modes.ravel()[c]:
                        at = _bisect(flow, switched, h - first, modes, again, c, probe)
                        changes.append((i * h + first + at, int(c), int(again.ravel()[c])))
                now = again
        state, modes = after, now
    changes.sort()
    times, pieces, current = [], [start.copy()], start.ravel().copy()
    for t, c, branch in changes:
        if t >= (1 - 1e-9) * duration:  # at the end: the next shot's start
            continue
        current[c] = branch
        if t - (times[-1] if times else 0.0) <= 1e-9 * duration:  # one instant, one boundary
            pieces[-1] = current.reshape(start.shape).copy()
            continue
        times.append(t)
        pieces.append(current.reshape(start.shape).copy())
    return Switches(float(duration), np.array(times), np.array(pieces))
