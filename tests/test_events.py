"""Events in the step (:mod:`wheelrom.analysis.periodic.events`, issue #70) against closed
forms: the contact switches of an oscillator with a Jenkins element and the derivative of its
flow map, which the compiled kernel's flow on an event schedule reproduces at the scheme's
order, where uniform steps across the switches reach first order only.

The oscillator is the friction ring of ``test_forced_den_hartog`` (four one-mode blades,
contacts between neighbours whose normal never moves, elastic Coulomb law) without its
nozzle, undamped: in its ND 2 wave every blade obeys ``x'' + k x + J = 0`` with ``J`` a
Jenkins element of stiffness ``k_J = 4 k_t`` and limit ``L = 2 mu F_n`` on ``x`` (two
contacts a blade, each sliding by ``2 x``). Stuck about its slider ``w`` it is a linear
oscillator at ``sqrt(k + k_J)`` about ``k_J w / (k + k_J)``; slipping one way (``sigma = +-1``)
one at ``sqrt(k)`` about ``-sigma L / k`` with ``w = x - sigma L / k_J``. It starts to slip
where ``|k_J (x - w)|`` reaches ``L`` and sticks again where its velocity vanishes: every
piece and every switch in closed form (:func:`jenkins_flow`).
"""

import dataclasses
import math

import numpy as np
import pytest

from test_forced_den_hartog import STIFFNESS, _shot_config, friction_ring
from wheelrom.analysis.periodic.events import locate
from wheelrom.analysis.periodic.flow import WheelFlow
from wheelrom.forces.contact_law import HELD_SLIP, HELD_STICK

RATIO = 2.0  # k_t over the blade's own stiffness k: the stuck oscillator at sqrt(9) = 3 x
K_JENKINS = 4 * RATIO * STIFFNESS  # [N/m per kg] on a blade's x
FRICTION = 0.5  # 2 mu F_n over the nozzle force of friction_ring
LIMIT = FRICTION * 1.0  # [N] L = 2 mu F_n (the ring's nozzle force is 1 N)
SPEED = 4.0 * LIMIT * math.sqrt(STIFFNESS + K_JENKINS) / K_JENKINS  # [m/s]: slips at 1/4


def _stuck(x, v, w, s):
    """``(x, v)`` after ``s`` [s] stuck about slider ``w``."""
    w1 = math.sqrt(STIFFNESS + K_JENKINS)
    c = K_JENKINS * w / (STIFFNESS + K_JENKINS)
    return (c + (x - c) * math.cos(w1 * s) + v / w1 * math.sin(w1 * s),
            -(x - c) * w1 * math.sin(w1 * s) + v * math.cos(w1 * s))


def _slipping(x, v, sigma, s):
    """``(x, v)`` after ``s`` [s] slipping with the force ``sigma L`` against the motion."""
    w0 = math.sqrt(STIFFNESS)
    c = -sigma * LIMIT / STIFFNESS
    return (c + (x - c) * math.cos(w0 * s) + v / w0 * math.sin(w0 * s),
            -(x - c) * w0 * math.sin(w0 * s) + v * math.cos(w0 * s))


def jenkins_flow(x: float, v: float, w: float, duration: float):
    """``((x, v, w) at duration, switch times)`` of the oscillator from ``x`` [m], ``v``
    [m/s], slider ``w`` [m], stuck (``|k_J (x - w)| <= L``), in closed form."""
    w1, w0 = math.sqrt(STIFFNESS + K_JENKINS), math.sqrt(STIFFNESS)
    t, stuck, sigma, switches = 0.0, True, 0.0, []
    while True:
        if stuck:  # slips where x - w reaches +-L / k_J: x - c = R cos(w1 s - phi)
            c = K_JENKINS * w / (STIFFNESS + K_JENKINS)
            R, phi = math.hypot(x - c, v / w1), math.atan2(v / w1, x - c)
            ends = []
            for side in (1.0, -1.0):
                ratio = (w + side * LIMIT / K_JENKINS - c) / R
                if abs(ratio) < 1.0:
                    for root in (math.acos(ratio), -math.acos(ratio)):
                        s = ((root + phi) / w1) % (2 * math.pi / w1)
                        ends.append((s if s > 1e-15 else s + 2 * math.pi / w1, side))
            s, side = min(ends) if ends else (math.inf, 0.0)
        else:  # sticks where v = 0: v(s) = R w0 cos(w0 s + psi)
            c = -sigma * LIMIT / STIFFNESS
            s = (math.atan2(v, (x - c) * w0) / w0) % (math.pi / w0)
        if t + s >= duration:
            s = duration - t
            if stuck:
                x, v = _stuck(x, v, w, s)
            else:
                x, v = _slipping(x, v, sigma, s)
                w = x - sigma * LIMIT / K_JENKINS
            return (x, v, w), switches
        t += s
        switches.append(t)
        if stuck:
            x, v = _stuck(x, v, w, s)
            stuck, sigma = False, side
        else:
            x, v = _slipping(x, v, sigma, s)
            stuck, w = True, x - sigma * LIMIT / K_JENKINS


@pytest.fixture(scope="module")
def jenkins_ring():
    model, params = friction_ring(FRICTION, k_t=RATIO * STIFFNESS)
    params = dataclasses.replace(params, nozzle_force=0.0)
    period = 2 * math.pi / math.sqrt(STIFFNESS)
    return model, params, period


def _flow(jenkins_ring, step: float) -> WheelFlow:
    model, params, period = jenkins_ring
    cfg = _shot_config(2 * math.pi / (100 * step), beta=0.0)
    return WheelFlow(model, cfg, params=params)


def _wave(x: float, v: float) -> np.ndarray:
    """The flat state of the ND 2 wave: blade ``s`` at ``(-1)^s (x, v)``, sliders at 0."""
    sign = np.array([1.0, -1.0, 1.0, -1.0])
    return np.concatenate([x * sign, v * sign, np.zeros(8)])


def test_the_switches_are_located_where_the_closed_form_has_them(jenkins_ring):
    """Stick, slip, stick, slip ... over 1.2 periods: every switch within 1e-10 of the
    period of its closed form (1e-9), each piece held on the branch it has there."""
    model, params, period = jenkins_ring
    duration = 1.2 * period
    _, truth = jenkins_flow(0.0, SPEED, 0.0, duration)
    assert len(truth) >= 4
    flow = _flow(jenkins_ring, period / 200)
    try:
        found = locate(flow, _wave(0.0, SPEED), duration, period / 200)
    finally:
        flow.destroy()
    assert found.times.size == len(truth)
    assert np.abs(found.times - truth).max() < 1e-9 * period
    # stuck first, then slipping and stuck in turn, every contact together
    branches = found.modes[:, 0, :]
    assert np.all(branches == branches[:, :1])
    assert branches[:, 0].tolist() == [HELD_SLIP if i % 2 else HELD_STICK
                                       for i in range(len(truth) + 1)]


#: the units of (x, v): the stuck oscillator's amplitude and the start's speed
UNITS = np.array([SPEED / math.sqrt(STIFFNESS + K_JENKINS), SPEED])
DIFFERENCE = 1e-6  # central differences, in those units


def _derivative(end_of) -> np.ndarray:
    """``d (x, v)(T) / d (x, v)(0)`` in :data:`UNITS` of blade 0 in the wave from ``(0,
    SPEED)``, central differences of ``end_of(starts (B, 2)) -> ends (B, 2)``."""
    start = np.array([0.0, SPEED])
    shifts = np.diag(DIFFERENCE * UNITS)
    ends = end_of(np.concatenate([start + shifts, start - shifts]))
    return ((ends[:2] - ends[2:]) / (2 * DIFFERENCE) / UNITS).T


def _tool(flow, duration, steps, schedule=None):
    def end_of(starts):
        ends = flow.advance(np.array([_wave(x, v) for x, v in starts]), duration, steps,
                            schedule=schedule)
        return ends[:, [0, 4]]
    return _derivative(end_of)


def _closed(duration):
    return _derivative(lambda starts: np.array([jenkins_flow(x, v, 0.0, duration)[0][:2]
                                                for x, v in starts]))


def test_the_flow_maps_derivative_converges_at_the_schemes_order_on_its_events(jenkins_ring):
    """The derivative of the flow over 1.2 periods (four switches) against its closed form:
    on the event schedule its error falls by at least 8 a halving of the step (fourth order:
    16), to below 1e-6; across the switches in uniform steps it stays above 1e-4, first order
    (ETDRK4's scheme is smooth; the kinks are not)."""
    model, params, period = jenkins_ring
    duration = 1.2 * period
    truth = _closed(duration)
    size = np.abs(truth).max()
    steps = [period / 100, period / 200, period / 400]
    evented, uniform = [], []
    flow = _flow(jenkins_ring, steps[-1] / 8)
    try:
        switches = locate(flow, _wave(0.0, SPEED), duration, steps[-1])
    finally:
        flow.destroy()
    for h in steps:
        flow = _flow(jenkins_ring, h)
        try:
            n = math.ceil(duration / h - 1e-9)
            evented.append(np.abs(_tool(flow, duration, 0, switches.schedule(h))
                                  - truth).max() / size)
            uniform.append(np.abs(_tool(flow, duration, n) - truth).max() / size)
        finally:
            flow.destroy()
    assert evented[1] < evented[0] / 8 and evented[2] < evented[1] / 8, evented
    assert evented[2] < 1e-6, evented
    assert min(uniform) > 1e-4 and min(uniform) > 100 * evented[2], uniform


def test_each_blades_contact_is_held_on_its_own_branch_in_a_batch():
    """The kernel's held branches, column by column: the lift-off ring of
    ``test_forced_branch`` (three one-mode blades, a preloaded normal contact between
    neighbours) with its first and third contact held closed (the normal spring past its
    lift-off: in tension where it would open) and its second held open, two different
    states in one batch, over a period: a linear system, whose exact flow (the matrix
    exponential of the ring written out) the schedule's piece reproduces to 1e-9 of the
    motion (measured 1e-11), both states alike (the branches put on the wrong blades fail it
    by 0.6-0.7); the free law, which opens and closes the contacts on the way, ends
    elsewhere."""
    from scipy.linalg import expm

    from test_forced_branch import BETA, CONTACT, PRELOAD, RING_K, W_CLOSED, lift_off_ring
    from wheelrom.analysis.periodic.events import Schedule
    from wheelrom.forces.contact_law import HELD_OPEN

    model, params = lift_off_ring()
    params = dataclasses.replace(params, nozzle_force=0.0)
    duration, steps = 2 * math.pi / W_CLOSED, 400
    closed = np.array([True, False, True])  # the contact between blade s and s + 1
    modes = np.where(closed, HELD_STICK, HELD_OPEN)[None].astype(float)
    flow = WheelFlow(model, _shot_config(2 * math.pi / (100 * duration / steps), beta=BETA),
                     params=params)
    lift_off = PRELOAD / CONTACT
    # displacements of a few lift-offs, velocities of as many per period
    states = np.array([[2.0, -1.0, 0.5, 0.0, 3.0, -2.0],
                       [-1.5, 0.3, 1.1, 1.5, 0.0, 0.8]]) * lift_off
    states[:, 3:] *= W_CLOSED
    try:
        held = flow.advance(states, duration, schedule=Schedule(duration, (
            (duration, steps, modes),)))
        free = flow.advance(states, duration, steps)
    finally:
        flow.destroy()
    # y'' = -K (y + beta y') + f, f = sum over closed contacts c of n_c on blade c + 1 and
    # -n_c on blade c, n_c = F_N0 - k_c (y_{c+1} - y_c): the augmented linear system
    A = np.zeros((7, 7))
    A[:3, 3:6] = np.eye(3)
    A[3:6, :3] = -RING_K
    A[3:6, 3:6] = -BETA * RING_K
    for c in np.flatnonzero(closed):
        d = c + 1 if c < 2 else 0
        for blade, sign in ((d, 1.0), (c, -1.0)):
            A[3 + blade, 6] += sign * PRELOAD
            A[3 + blade, d] -= sign * CONTACT
            A[3 + blade, c] += sign * CONTACT
    exact = np.array([(expm(A * duration) @ np.append(s, 1.0))[:6] for s in states])
    size = np.abs(exact[:, :3]).max()
    assert np.abs(held[:, :3] - exact[:, :3]).max() < 1e-9 * size
    assert np.abs(free[:, :3] - exact[:, :3]).max() > 1e-2 * size
