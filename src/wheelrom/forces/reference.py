"""The reference force model: nozzle (eq. 13), Van der Pol (eqs. 1, 2/14), dry-friction
contacts on rigid arms (eqs. 16-20), written plainly blade by blade (numba, no fast math).
Equations, frames and signs: docs/theory.md.

It serves the static preload solve, the plain-numpy serial reference of the transient and the
energy bookkeeping; the compiled right-hand side (:mod:`wheelrom.transient.kernel`) is a
second, independent implementation that the tests hold equal to this one to round-off.
"""

from __future__ import annotations

import math

import numpy as np

from wheelrom.forces.contact_law import L_MU, tangential_force
from wheelrom.forces.parameters import ForceParameters
from wheelrom.runtime import kernel_cache as _kernel_cache


class ReferenceForces:
    """Nonlinear generalised forces of the whole wheel for one case's
    :class:`~wheelrom.forces.parameters.ForceParameters`.

    :meth:`evaluate` is allocation-free (writes into these arrays):

    - ``force``: ``(N, m)`` generalised force (nozzle + Van der Pol + contacts);
    - ``normal_force``, ``slip_velocity``, ``normal_gap``: ``(K, N)`` [N, m/s, m] per contact
      kind and blade pair ``(s, s+1)``; ``contact_state``: ``(K, N)`` OPEN/STICK/SLIP;
    - ``relative_displacement``, ``relative_velocity``: ``(K, N, 3)`` local (xi, eta, zeta);
    - ``friction_force``: ``(K, N, 2)`` friction force (xi, zeta) [N] on ``A_{s+1}``;
    - ``slider``: ``(K, N, 2)`` the elastic law's sliders (xi, zeta) [m] the last evaluation
      used, ``slider_next`` the same returned onto the Coulomb limit at that state (what a
      step that ends there keeps; both unused under the paper law);
    - ``vdp_displacement``: ``(N,)`` Van der Pol reference displacement ``y_s`` [m];
    - ``power``: ``(3,)`` power of nozzle, Van der Pol and friction forces [W].
    """

    def __init__(self, params: ForceParameters):
        self.params = params
        N, m, K = params.blades, params.modes, len(params.contacts.kinds)
        self.force = np.zeros((N, m))
        self.normal_force = np.zeros((K, N))
        self.slip_velocity = np.zeros((K, N))
        self.normal_gap = np.zeros((K, N))
        self.contact_state = np.zeros((K, N), dtype=np.int8)
        self.relative_displacement = np.zeros((K, N, 3))
        self.relative_velocity = np.zeros((K, N, 3))
        self.friction_force = np.zeros((K, N, 2))
        self.slider = np.zeros((K, N, 2))
        self.marched_periods = 0  # of the last evaluate_samples
        self.slider_next = np.zeros((K, N, 2))
        self.vdp_displacement = np.zeros(N)
        self.power = np.zeros(3)
        self._work = np.zeros((N, 4))

    def evaluate(self, t: float, q: np.ndarray, v: np.ndarray,
                 slider: np.ndarray | None = None) -> np.ndarray:
        """Fill and return ``self.force`` ``(N, m)`` for modal state ``q, v`` ``(N, m)`` at
        time ``t`` [s]; ``slider`` ``(K, N, 2)`` [m]: the elastic law's sliders (None: the
        ones in ``self.slider``)."""
        p, c = self.params, self.params.contacts
        if slider is not None:
            self.slider[...] = np.reshape(slider, self.slider.shape)
        _kernel(t, q, v, self.force, p.omega, p.stator_vanes, p.nozzle_force, p.excitation,
                p.nozzle_phase, p.vdp_model, p.vdp_mu, p.vdp_r, p.aero, p.aero_displacement,
                p.aero_velocity, p.friction, p.rotation,
                c.shape_A, c.shape_B, c.point_A, c.point_B, c.arm_length, c.frame, c.stiffness,
                c.preload, c.tangential, self.slider, self.slider_next, self.normal_force,
                self.slip_velocity, self.normal_gap, self.contact_state,
                self.relative_displacement, self.relative_velocity, self.friction_force,
                self.vdp_displacement, self.power, self._work)
        return self.force

    def replay(self, times, states):
        """Evaluate the stored states ``states`` ``(S, 2, N, m)`` (``q``, ``q'``) at ``times``
        ``(S,)`` [s] in order, yielding each index after its evaluation (the arrays then hold
        its forces). The states hold no sliders: under the elastic law they are replayed
        from rest at the first state, sample to sample (exact for a relative motion monotonic
        between samples once every contact has slipped; the first stick phase's forces are
        relative to the first state)."""
        elastic = self.params.law.elastic
        if elastic and len(times):
            self.slider[...] = self.sliders_at_rest(np.ascontiguousarray(states[0][0]))
        for i, t in enumerate(times):
            self.evaluate(float(t), np.ascontiguousarray(states[i][0]),
                          np.ascontiguousarray(states[i][1]))
            yield i
            if elastic:  # the sliders this sample returned, for the next
                self.slider[...] = self.slider_next

    def sliders_at_rest(self, q: np.ndarray) -> np.ndarray:
        """``(K, N, 2)`` sliders [m] that leave every contact at ``q`` ``(N, m)`` without
        tangential force (``w = u_t``): the start of an elastic-law run."""
        self.evaluate(0.0, q, np.zeros_like(q))
        return self.relative_displacement[:, :, ::2].copy()

    def evaluate_samples(self, q: np.ndarray, v: np.ndarray, force: np.ndarray,
                         normal_force: np.ndarray, friction_power: np.ndarray,
                         contact_state: np.ndarray, sliders: np.ndarray | None = None,
                         periods: int = 0, block: int = 0, max_periods: int = 0,
                         tolerance: float = 0.0,
                         returned: np.ndarray | None = None) -> float:
        """The forces of ``S`` states at once (nozzle at ``t = 0``): ``q``, ``v``
        ``(S, N, m)``; writes ``force`` ``(S, N, m)`` and, of blade pair ``(0, 1)`` of every
        contact kind, ``normal_force`` ``(S, K)`` [N], ``friction_power`` ``(S, K)`` [W] (the
        tangential force's power on the pair's relative slip) and ``contact_state``
        ``(S, K)`` (OPEN/STICK/SLIP). One compiled call: the harmonic balance's time samples
        and their finite-difference perturbations
        (:mod:`wheelrom.analysis.periodic.harmonic_balance`).

        The elastic law's ``sliders`` ``(S, K, N, 2)`` [m]: with ``periods = 0`` the slider of
        each (independent) state; with ``periods > 0`` the states are the samples of one
        period in order, ``sliders[0]`` the slider at the first, and the law is marched
        through them ``periods`` times (each sample's slider is the previous one's return, the
        hysteresis of the alternating frequency-time method); the last period's forces are
        written and ``sliders`` holds the slider each sample used. ``block``: samples of one
        period (0: all ``S``); the states are then ``S / block`` periods marched each on its
        own from its first slider. None: zeros (the paper law reads none).

        ``max_periods > periods``: the march goes on, up to ``max_periods``, until what is
        left of every contact's walk to its loop is within ``tolerance`` [m] (its last
        period's move over one minus the walk's period-to-period shrink, :func:`_walks_closed`:
        the loop is periodic, its forces are those written), the walk extrapolated
        (:func:`_extrapolated`) or, where it zig-zags between two stick discs, closed onto
        their loop at once (:func:`_closed_loops`); returns the largest move of the last
        period over the blocks (0 without sliders); ``self.marched_periods``: the most
        periods a block took. ``returned`` ``(S, K, N, 2)``: filled with the slider each
        state returns (its ``slider_next``: the harmonic balance's slider tangents)."""
        p, c = self.params, self.params.contacts
        if sliders is None:  # one slider for every state (the paper law reads none)
            sliders = np.zeros((1, *self.slider.shape))
        if returned is None:
            returned = np.zeros((0, *self.slider.shape))
        drift = np.zeros(2)
        _kernel_samples(q, v, force, p.omega, p.stator_vanes, p.nozzle_force, p.excitation,
                        p.nozzle_phase, p.vdp_model, p.vdp_mu, p.vdp_r, p.aero,
                        p.aero_displacement, p.aero_velocity, p.friction, p.rotation,
                        c.shape_A, c.shape_B, c.point_A, c.point_B, c.arm_length, c.frame,
                        c.stiffness, c.preload, c.tangential, sliders, periods,
                        max(max_periods, periods), tolerance, drift, block or q.shape[0],
                        self.slider,
                        self.slider_next, self.normal_force, self.slip_velocity,
                        self.normal_gap, self.contact_state, self.relative_displacement,
                        self.relative_velocity, self.friction_force, self.vdp_displacement,
                        self.power, self._work, normal_force, friction_power,
                        contact_state, returned)
        self.marched_periods = int(drift[1])
        return float(drift[0])

    def contact_energy(self) -> float:
        """Potential energy of the normal contact springs at the last evaluation [J].

        ``V = -F_N0 g + k g^2 / 2`` for ``g < F_N0 / k`` (closed), ``-F_N0^2 / (2 k)`` when open;
        ``-dV/dg`` is the normal force, so the contact normal forces are conservative.
        """
        c = self.params.contacts
        g = self.normal_gap
        preload = c.preload[:, None]
        open_ = g >= preload / c.stiffness
        closed = -preload * g + 0.5 * c.stiffness * g * g
        return float(np.where(open_, -(preload**2) / (2 * c.stiffness), closed).sum())


@_kernel_cache.njit(fastmath=False)
def _kernel(t, q, v, out, omega, n_s, Fb, p_exc, phase, vdp_model, mu, r, p_aero, aero_a,
            aero_b, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt, slider, slider_next,
            normal, slip, gap, state, rel_u, rel_v, fric, y_vdp, power, work):
    """The forces of :class:`ReferenceForces` (argument names as in docs/theory.md: ``XA``,
    ``XB`` contact shapes, ``A_pt``, ``B_pt`` undeformed contact points, ``T`` frames)."""
    p_noz, p_vdp = _nozzle_and_van_der_pol(t, q, v, out, omega, n_s, Fb, p_exc, phase,
                                           vdp_model, mu, r, p_aero, aero_a, aero_b, y_vdp,
                                           work)
    p_fric = _contact_forces(q, v, out, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt,
                             slider, slider_next, normal, slip, gap, state, rel_u, rel_v,
                             fric)
    power[0] = p_noz
    power[1] = p_vdp
    power[2] = p_fric


@_kernel_cache.njit(fastmath=False)
def _kernel_samples(q, v, out, omega, n_s, Fb, p_exc, phase, vdp_model, mu, r, p_aero, aero_a,
                    aero_b, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt, sliders,
                    periods, max_periods, tolerance, drift, block, slider, slider_next, normal,
                    slip, gap, state, rel_u, rel_v, fric, y_vdp, power, work, normal_out,
                    power_out, state_out, returned):
    """:func:`_kernel` at ``t = 0`` for every state ``q[i], v[i]`` (``(S, N, m)``) with the
    slider ``sliders[i]``, or marched (``periods > 0``, :meth:`evaluate_samples`: at least
    ``periods``, up to ``max_periods`` until every contact's walk is within ``tolerance``
    of its loop; ``drift[0]``: the largest last move, ``drift[1]``: the most periods a
    block took), keeping blade pair 0's normal
    force, friction power and state per contact kind (and, when ``returned`` has a row per
    state, each state's returned slider)."""
    drift[0], drift[1] = 0.0, 0.0
    move, last_move = np.empty_like(slider), np.empty_like(slider)
    K, N = slider.shape[0], slider.shape[1]
    # per contact: the last aligned move ratio (-1: none), the walk's period-to-period shrink
    # (0: none measured) and the last period's move [m] (0: none, or a jump since)
    ratios, rates, sizes = np.empty((K, N)), np.empty((K, N)), np.empty((K, N))
    # per sample of the last period and contact: its stick disc (centre, radius) [m]
    discs = np.empty((block if periods > 0 else 1, K, N, 3))
    slips = np.empty((K, N, 2), dtype=np.int64)
    count = np.zeros((K, N), dtype=np.int64)
    for start in range(0, q.shape[0], block):
        if periods > 0:
            _copy(slider, sliders[start])
        last_move[...] = 0.0
        ratios[...], rates[...], sizes[...] = -1.0, 0.0, 0.0
        for period in range(max(max_periods, 1)):
            if periods > 0 and period >= 1:
                _moved(move, slider, sliders[start])
                closed = _walks_closed(move, sizes, rates, tolerance)
                if period >= periods and closed:
                    break
                if period >= periods and max_periods > periods:
                    _closed_loops(slider, discs, slips, count, rates, last_move, ratios, sizes)
                    _extrapolated(slider, move, last_move, ratios, sizes)
            elif period >= max(periods, 1):
                break
            drift[1] = max(drift[1], period + 1.0)
            count[...] = 0
            for i in range(start, start + block):
                if periods > 0:
                    _copy(sliders[i], slider)  # what this sample sees: the last one's return
                _sample(i, q, v, out, omega, n_s, Fb, p_exc, phase, vdp_model, mu, r, p_aero,
                        aero_a, aero_b, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt,
                        sliders[min(i, sliders.shape[0] - 1)], slider_next, normal, slip, gap,
                        state, rel_u, rel_v, fric, y_vdp, power, work, normal_out, power_out,
                        state_out)
                if returned.shape[0] == q.shape[0]:
                    _copy(returned[i], slider_next)
                if periods > 0:
                    _record_discs(i - start, law, kt, normal, rel_u, slider, slider_next, discs,
                                  slips, count)
                    _copy(slider, slider_next)
        if periods > 0:
            drift[0] = max(drift[0], _moved(move, slider, sliders[start]))


@_kernel_cache.njit(fastmath=False)
def _copy(target, source):
    """``target[...] = source`` for ``(K, N, 2)`` sliders (loops: see :func:`_extrapolated`)."""
    for k in range(target.shape[0]):
        for n in range(target.shape[1]):
            for j in range(target.shape[2]):
                target[k, n, j] = source[k, n, j]


@_kernel_cache.njit(fastmath=False)
def _moved(move, slider, start):
    """``move = slider - start`` (``(K, N, 2)`` sliders [m]); returns its largest entry's
    magnitude [m] (loops: see :func:`_extrapolated`)."""
    largest = 0.0
    for k in range(move.shape[0]):
        for n in range(move.shape[1]):
            for j in range(move.shape[2]):
                move[k, n, j] = slider[k, n, j] - start[k, n, j]
                largest = max(largest, abs(move[k, n, j]))
    return largest


#: the walk's period-to-period ratio is extrapolated once two successive ratios agree to this
#: share of their distance from 1 and the moves point the same way to ``1 - ALIGNED``
RATIO_AGREEMENT, ALIGNED = 0.1, 1e-3
#: ... and lies in this range
RATIO_RANGE = (0.3, 0.9999)
#: a walk that does not shrink (rate 1 and above) is closed when its move is this many
#: times below the tolerance
WALK_GAIN = 1e6
#: a walk shrinking slower than this a period is closed onto its two-slip loop where there is
#: one (:func:`_closed_loops`)
LOOP_RATE = 0.5
#: a contact's move ratio that says it jumped onto its loop this period
JUMPED = -2.0


@_kernel_cache.njit(fastmath=False)
def _record_discs(i, law, kt, normal, rel_u, slider, slider_next, discs, slips, count):
    """Keep sample ``i``'s stick disc of every contact (centre: the tangential relative
    displacement, radius ``mu F_n / k_t`` [m]) and whether the contact slipped there (its
    slider returned elsewhere; ``count`` -1: it opened this period, no loop is closed)."""
    for c in range(slider.shape[0]):
        for s in range(slider.shape[1]):
            discs[i, c, s, 0] = rel_u[c, s, 0]
            discs[i, c, s, 1] = rel_u[c, s, 2]
            discs[i, c, s, 2] = law[L_MU] * normal[c, s] / kt[c, s]
            if count[c, s] < 0:
                continue
            if normal[c, s] <= 0.0:
                count[c, s] = -1
            elif slider_next[c, s, 0] != slider[c, s, 0] or \
                    slider_next[c, s, 1] != slider[c, s, 1]:
                if count[c, s] < 2:
                    slips[c, s, count[c, s]] = i
                count[c, s] += 1


@_kernel_cache.njit(fastmath=False)
def _closed_loops(slider, discs, slips, count, rates, last_move, ratios, sizes):
    """Move each contact that slipped at exactly two samples of the last period and walks
    slowly (its ``rates`` at least :data:`LOOP_RATE`) onto the loop its walk converges to,
    where that loop holds at every sample (its walk's records reset: the next move is the
    jump's error).

    The elastic law's return is the projection onto the sample's stick disc, so the march
    projects the slider onto the discs in turn. Two discs that a contact slips on and that
    barely meet (or barely miss each other) are a slow walk: the projections zig-zag between
    them with a period-to-period ratio ``1 - gap / radius`` (0.9999 on the small wheel's shroud
    just past its shakedown onset, the plain march 1e5 periods from its loop). Its limit is
    known: where the discs meet, the corner of their lens nearer the slider (the contact then
    sticks throughout); where they miss each other, the slider sits at the two discs' nearest
    points in turn (slipping at the two samples). The loop is taken when every other sample
    of the period sticks on it; the march goes on from there and its own test closes it."""
    n = discs.shape[0]
    for c in range(slider.shape[0]):
        for s in range(slider.shape[1]):
            if count[c, s] != 2 or rates[c, s] < LOOP_RATE:
                continue
            i1, i2 = slips[c, s, 0], slips[c, s, 1]
            x1, y1, r1 = discs[i1, c, s, 0], discs[i1, c, s, 1], discs[i1, c, s, 2]
            x2, y2, r2 = discs[i2, c, s, 0], discs[i2, c, s, 1], discs[i2, c, s, 2]
            d = math.sqrt((x2 - x1) ** 2 + (y2 - y1) ** 2)
            if d <= abs(r1 - r2) or d <= 0.0:
                continue  # one disc inside the other: no two-slip loop
            ex, ey = (x2 - x1) / d, (y2 - y1) / d
            if d <= r1 + r2:  # the lens' corner nearer the slider: a stuck loop
                a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d)
                h = math.sqrt(max(r1 * r1 - a * a, 0.0))
                px, py = x1 + a * ex - h * ey, y1 + a * ey + h * ex
                qx, qy = x1 + a * ex + h * ey, y1 + a * ey - h * ex
                w0, w1 = slider[c, s, 0], slider[c, s, 1]
                if (qx - w0) ** 2 + (qy - w1) ** 2 < (px - w0) ** 2 + (py - w1) ** 2:
                    px, py = qx, qy
                ok = True
                for i in range(n):
                    ok = ok and _inside(discs, i, c, s, px, py)
                if ok:
                    slider[c, s, 0], slider[c, s, 1] = px, py
                    _restart(c, s, last_move, ratios, sizes)
                continue
            # the nearest points: on disc 1 towards disc 2 from sample i1 to i2, then back
            ax, ay = x1 + r1 * ex, y1 + r1 * ey
            bx, by = x2 - r2 * ex, y2 - r2 * ey
            ok = True
            for i in range(n):
                if i1 < i <= i2 - 1 or i == i1:
                    ok = ok and _inside(discs, i, c, s, ax, ay)
                else:
                    ok = ok and _inside(discs, i, c, s, bx, by)
            if ok:  # the period ends after sample i2: on disc 2's nearest point
                slider[c, s, 0], slider[c, s, 1] = bx, by
                _restart(c, s, last_move, ratios, sizes)


@_kernel_cache.njit(fastmath=False)
def _restart(c, s, last_move, ratios, sizes):
    """Forget contact ``(c, s)``'s walk (it jumped: its next move is the jump's error)."""
    last_move[c, s, 0], last_move[c, s, 1] = 0.0, 0.0
    ratios[c, s], sizes[c, s] = JUMPED, 0.0


@_kernel_cache.njit(fastmath=False)
def _inside(discs, i, c, s, x, y):
    """Whether ``(x, y)`` [m] lies in sample ``i``'s stick disc of contact ``(c, s)`` (to
    1e-12 of its radius: a point on the rim is the rim's)."""
    dx, dy = x - discs[i, c, s, 0], y - discs[i, c, s, 1]
    return math.sqrt(dx * dx + dy * dy) <= discs[i, c, s, 2] * (1.0 + 1e-12)


@_kernel_cache.njit(fastmath=False)
def _walks_closed(move, sizes, rates, tolerance):
    """Whether every contact's walk has closed its loop: what is left of a geometric walk,
    its move over ``1 - rate``, within ``tolerance`` [m] (not the move alone: a walk that
    shrinks by 1e-4 a period stops 1e4 moves short of its loop, and the march's forces would
    jump where the move crosses the tolerance). ``move`` ``(K, N, 2)`` the last period's;
    ``sizes``, ``rates`` ``(K, N)`` updated (a size 0: none since a jump, the rate kept)."""
    closed = True
    for k in range(move.shape[0]):
        for n in range(move.shape[1]):
            size = math.sqrt(move[k, n, 0] ** 2 + move[k, n, 1] ** 2)
            if sizes[k, n] > 0.0:
                rates[k, n] = size / sizes[k, n]
            sizes[k, n] = size
            closed = closed and size <= tolerance * max(1.0 - rates[k, n], 1.0 / WALK_GAIN)
    return closed


@_kernel_cache.njit(fastmath=False)
def _extrapolated(slider, move, last_move, ratios, sizes):
    """Accelerate each contact's walk to its shakedown loop (contacts walk on their own: a
    slider's return depends on its own contact's motion only).

    ``slider`` (moved in place) is the sliders' state at the end of a period, ``move`` that
    period's move, ``last_move`` the previous period's (zeros: none; updated), ``ratios``
    ``(K, N)`` the ratio of the two moves before (-1: none; updated) and ``sizes`` the last
    moves' lengths (set to 0 where a contact jumped: its next move is the jump's error).

    A contact in partial slip walks towards its loop: the distance left shrinks as
    ``e_(n+1) = e_n - c e_n^p`` a period, the move ``d_n = c e_n^p``. ``p = 1`` is a
    geometric walk (the ratio ``d_(n+1) / d_n`` constant: 0.957 at every period from the 2nd
    to the 400th at the small wheel's stuck resonance); a loop that only grazes the Coulomb
    limit walks slower (``p`` about 3 on the paper wheel at 1.6 kN, 132.69 Hz: the ratio
    creeping from 0.87 to 0.999 and the plain march taking 5800-13000 periods to a move of
    1e-13 m, 1e-10 m from the loop). When two successive ratios agree
    (:data:`RATIO_AGREEMENT`) along one direction (:data:`ALIGNED`), the rest of a geometric
    walk, ``d ratio / (1 - ratio)``, is added at once (Aitken's extrapolation): the whole
    distance when ``p = 1``, its ``1 / p``-th otherwise, and the next extrapolation takes the
    next share (an estimate of ``p`` overshot and cycled). The march then goes on from there
    and its own test decides that the loop is closed: the extrapolation moves where the march
    is, never what counts as converged."""
    # loops, not array expressions: numba compiles a broadcast's shape-error message with
    # every array expression (seconds of compile time for a few lines)
    for k in range(move.shape[0]):
        for n in range(move.shape[1]):
            if ratios[k, n] == JUMPED:  # onto its loop this period (:func:`_closed_loops`)
                ratios[k, n] = -1.0
                continue
            size, last_size, dot = 0.0, 0.0, 0.0
            for j in range(2):
                size += move[k, n, j] * move[k, n, j]
                last_size += last_move[k, n, j] * last_move[k, n, j]
                dot += move[k, n, j] * last_move[k, n, j]
            size, last_size = np.sqrt(size), np.sqrt(last_size)
            ratio = -1.0  # none measured
            if size > 0.0 and last_size > 0.0 and dot >= (1.0 - ALIGNED) * size * last_size:
                ratio = dot / (last_size * last_size)
            last = ratios[k, n]
            jump = (last >= 0.0 and RATIO_RANGE[0] < ratio < RATIO_RANGE[1]
                    and abs(ratio - last) < RATIO_AGREEMENT * (1.0 - ratio))
            for j in range(2):
                if jump:
                    slider[k, n, j] += move[k, n, j] * (ratio / (1.0 - ratio))
                last_move[k, n, j] = 0.0 if jump else move[k, n, j]
            ratios[k, n] = -1.0 if jump else ratio
            if jump:
                sizes[k, n] = 0.0


@_kernel_cache.njit(fastmath=False)
def _sample(i, q, v, out, omega, n_s, Fb, p_exc, phase, vdp_model, mu, r, p_aero, aero_a,
            aero_b, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt, slider, slider_next,
            normal, slip, gap, state, rel_u, rel_v, fric, y_vdp, power, work, normal_out,
            power_out, state_out):
    """State ``i`` of :func:`_kernel_samples`."""
    _kernel(0.0, q[i], v[i], out[i], omega, n_s, Fb, p_exc, phase, vdp_model, mu, r, p_aero,
            aero_a, aero_b, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt, slider,
            slider_next, normal, slip, gap, state, rel_u, rel_v, fric, y_vdp, power, work)
    for c in range(normal.shape[0]):
        normal_out[i, c] = normal[c, 0]
        power_out[i, c] = fric[c, 0, 0] * rel_v[c, 0, 0] + fric[c, 0, 1] * rel_v[c, 0, 2]
        state_out[i, c] = state[c, 0]


@_kernel_cache.njit(fastmath=False)
def _nozzle_and_van_der_pol(t, q, v, out, omega, n_s, Fb, p_exc, phase, vdp_model, mu, r,
                            p_aero, aero_a, aero_b, y_vdp, work):
    """Nozzle (eq. 13) and Van der Pol (eqs. 1, 2/14) or aerodynamic-table generalised forces
    written into ``out``; returns their powers [W]."""
    N, m = q.shape
    p_noz = 0.0
    p_vdp = 0.0
    # nozzle excitation (eq. 13) and the Van der Pol displacements
    for s in range(N):
        FE = Fb * math.cos(n_s * omega * t - phase[s])
        y = 0.0
        yd = 0.0
        ve = 0.0
        for j in range(m):
            out[s, j] = p_exc[j] * FE
            y += p_aero[j] * q[s, j]
            yd += p_aero[j] * v[s, j]
            ve += p_exc[j] * v[s, j]
        p_noz += FE * ve
        y_vdp[s] = y
        work[s, 0] = y
        work[s, 1] = yd
    # Van der Pol: force on blade s is -F_s along the aero direction, generalised p F
    if vdp_model == 1:
        for s in range(N):
            y = work[s, 0]
            yd = work[s, 1]
            g = mu * (1.0 - (y / r) ** 2) * yd  # = -F_s (eq. 1)
            p_vdp += g * yd
            for j in range(m):
                out[s, j] += p_aero[j] * g
    elif vdp_model == 2:
        for s in range(N):  # g_s = mu (1 - (D_s/r)^2) D'_s, D_s = y_s - y_{s-1}
            sp = (s - 1) % N
            D = work[s, 0] - work[sp, 0]
            Dd = work[s, 1] - work[sp, 1]
            work[s, 2] = mu * (1.0 - (D / r) ** 2) * Dd
        for s in range(N):
            sn = (s + 1) % N
            g = work[s, 2] - work[sn, 2]  # = -F_s of eq. 2
            p_vdp += g * work[s, 1]
            for j in range(m):
                out[s, j] += p_aero[j] * g
    elif vdp_model == 3:  # table: F_s = -mu sum_j (a_j y_{s+j} + b_j y'_{s+j})
        for s in range(N):
            F = 0.0
            for j in range(N):
                t_ = (s + j) % N
                F -= aero_a[j] * work[t_, 0] + aero_b[j] * work[t_, 1]
            g = mu * F
            p_vdp += g * work[s, 1]
            for j in range(m):
                out[s, j] += p_aero[j] * g
    return p_noz, p_vdp


@_kernel_cache.njit(fastmath=False)
def _contact_forces(q, v, out, law, R, XA, XB, A_pt, B_pt, arm, T, kc, preload, kt, slider,
                    slider_next, normal, slip, gap, state, rel_u, rel_v, fric):
    """Contact forces (eqs. 16-20; the tangential law of the record ``law``:
    :mod:`wheelrom.forces.contact_law`) added to ``out``, contact states and the returned
    sliders left in the arrays; returns the tangential force's power [W]."""
    N, m = q.shape
    p_fric = 0.0
    rows = np.empty((16, 3))  # 3-vectors of one contact, as row views
    uA, uB, vA, vB, uN, vN, d, dd = rows[0], rows[1], rows[2], rows[3], rows[4], rows[5], \
        rows[6], rows[7]
    e, ed, uc, vc, ul, vl, F, FN = rows[8], rows[9], rows[10], rows[11], rows[12], rows[13], \
        rows[14], rows[15]
    for c in range(XA.shape[0]):
        L = arm[c]
        l0 = 0.0
        for a in range(3):
            l0 += (B_pt[c, a] - A_pt[c, a]) ** 2
        l0 = math.sqrt(l0)
        for s in range(N):
            sn = (s + 1) % N
            _point_motion(c, s, sn, q, v, XA, XB, uA, uB, vA, vB, uN, vN)
            # deformed arm direction e = (B' - A') / |B' - A'| and its rate (eq. 16)
            nd = 0.0
            for a in range(3):
                d[a] = B_pt[c, a] + uB[a] - A_pt[c, a] - uA[a]
                dd[a] = vB[a] - vA[a]
                nd += d[a] * d[a]
            nd = math.sqrt(nd)
            edd = 0.0
            for a in range(3):
                e[a] = d[a] / nd
                edd += e[a] * dd[a]
            for a in range(3):
                ed[a] = (dd[a] - e[a] * edd) / nd
            # relative displacement (eq. 17, change from the undeformed gap) and velocity,
            # in sector s's frame: A_{s+1} moves by R u_A(s+1)
            for a in range(3):
                RuN = R[a, 0] * uN[0] + R[a, 1] * uN[1] + R[a, 2] * uN[2]
                RvN = R[a, 0] * vN[0] + R[a, 1] * vN[1] + R[a, 2] * vN[2]
                e0 = (B_pt[c, a] - A_pt[c, a]) / l0
                uc[a] = RuN - uA[a] - L * (e[a] - e0)
                vc[a] = RvN - vA[a] - L * ed[a]
            for a in range(3):  # local frame (eq. 18)
                ul[a] = T[c, s, a, 0] * uc[0] + T[c, s, a, 1] * uc[1] + T[c, s, a, 2] * uc[2]
                vl[a] = T[c, s, a, 0] * vc[0] + T[c, s, a, 1] * vc[1] + T[c, s, a, 2] * vc[2]
            for a in range(3):
                rel_u[c, s, a] = ul[a]
                rel_v[c, s, a] = vl[a]
            Fn = max(preload[c] - kc[c, s] * ul[1], 0.0)  # eq. 19; 0: open
            gap[c, s] = ul[1]
            slip[c, s] = math.sqrt(vl[0] * vl[0] + vl[2] * vl[2])
            Ft0, Ft2, st, w0, w2 = tangential_force(law, ul[0], ul[2], vl[0], vl[2],
                                                    slider[c, s, 0], slider[c, s, 1], Fn,
                                                    kt[c, s])
            state[c, s] = st
            slider_next[c, s, 0] = w0
            slider_next[c, s, 1] = w2
            p_fric += Ft0 * vl[0] + Ft2 * vl[2]
            normal[c, s] = Fn
            fric[c, s, 0] = Ft0
            fric[c, s, 1] = Ft2
            _apply_contact_force(c, s, sn, T, R, XA, XB, Ft0, Fn, Ft2, e, L / nd, out, F, FN)
    return p_fric


@_kernel_cache.njit(fastmath=False)
def _point_motion(c, s, sn, q, v, XA, XB, uA, uB, vA, vB, uN, vN):
    """Displacements and velocities of contact ``c``'s points A and B of blade ``s`` and of A
    of the next blade ``sn`` (each in its own sector's frame) [m, m/s]."""
    m = q.shape[1]
    for a in range(3):
        x1 = 0.0
        x2 = 0.0
        x3 = 0.0
        x4 = 0.0
        x5 = 0.0
        x6 = 0.0
        for j in range(m):
            x1 += XA[c, a, j] * q[s, j]
            x2 += XB[c, a, j] * q[s, j]
            x3 += XA[c, a, j] * v[s, j]
            x4 += XB[c, a, j] * v[s, j]
            x5 += XA[c, a, j] * q[sn, j]
            x6 += XA[c, a, j] * v[sn, j]
        uA[a] = x1
        uB[a] = x2
        vA[a] = x3
        vB[a] = x4
        uN[a] = x5
        vN[a] = x6


@_kernel_cache.njit(fastmath=False)
def _apply_contact_force(c, s, sn, T, R, XA, XB, Ft0, Fn, Ft2, e, arm_scale, out, F, FN):
    """The contact force (local ``Ft0, Fn, Ft2`` [N]) on A of blade ``sn`` and, reversed and
    moved from the arm end onto A and B (``arm_scale = L / |d|``), on blade ``s``, projected
    onto their modal coordinates (added to ``out``)."""
    m = out.shape[1]
    # force on A_{s+1} in sector s's frame: T^T (F_xi, F_n, F_zeta)
    for a in range(3):
        F[a] = T[c, s, 0, a] * Ft0 + T[c, s, 1, a] * Fn + T[c, s, 2, a] * Ft2
    # blade s+1 (own frame: R^T F) at A
    for a in range(3):
        FN[a] = R[0, a] * F[0] + R[1, a] * F[1] + R[2, a] * F[2]
    for j in range(m):
        acc = 0.0
        for a in range(3):
            acc += XA[c, a, j] * FN[a]
        out[sn, j] += acc
    # arm end of blade s gets -F; moved exactly onto A and B (virtual work of
    # C' = A' + L e): F_B = (L/|d|) F_perp, F_A = -F - F_B
    Fe = 0.0
    for a in range(3):
        Fe += -F[a] * e[a]
    for j in range(m):
        acc = 0.0
        for a in range(3):
            FB = arm_scale * (-F[a] - Fe * e[a])
            FA = -F[a] - FB
            acc += XA[c, a, j] * FA + XB[c, a, j] * FB
        out[s, j] += acc
