"""The family of friction-limited orbits under the elastic law, and its band (issue #68;
docs/theory.md, "Why the friction-limited amplitude is a band").

A contact that sticks the whole period keeps its slider where its history put it: any offset
``w`` that keeps it inside its stick circle, ``|k_t (u_t(t) - w)| <= mu F_n(t)`` over the
whole period, gives another exact orbit (the slider's directions are neutral: multipliers
exactly 1, :meth:`~.slider_shooting.SliderShooting.locked`). The locked-in tangential
prestress changes the stuck contact's normal load and the others' through the wheel, so the
friction-limited amplitude depends on it: the orbits form a family, and the designer's
number is its **band**, the smallest and largest amplitude over the admissible offsets.

The family is traced on the wave's pattern wheel, the offset the same on every pattern blade
(the wave's symmetry; a history that sets blades differently leaves it, settle's histories
show where those land), one 2-vector per contact kind stuck all period, in units of the
stick radius ``r = mu F_n / k_t`` [m] (``F_n`` the orbit's normal force at ``t = 0``). Each
member is the shot with those sliders held (:meth:`~.slider_shooting.SliderShooting.solve`
``fixed``), continued from its neighbour. The amplitude is close to linear in the offset
(measured on the small wheel at 40 deg: 0.087-0.526 um across the admissible ``zeta``
offsets, 0.318-0.323 across ``xi``), so its extremes lie where the admissible region meets
the gradient's direction: the gradient from one small step along each offset component, then
the two traces along plus and minus it (:func:`_trace`) to the edge, where the held
contacts' stick margin reaches 0 (or the shot no longer closes with them held, or a held
slider moves).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from wheelrom.analysis.periodic.shooting import Orbit

#: the first step of a trace and of the gradient, in stick radii
FIRST_STEP = 0.1
#: the step grows by this after a member is found, up to ``LARGEST_STEP`` radii
GROWTH, LARGEST_STEP = 2.0, 8.0
#: the edge of the admissible region to this share of the distance traced, or this many
#: stick radii when more (halving the step): the amplitude is close to linear in the offset,
#: so the band's ends are known to about this share of the amplitude's change along it
EDGE = 0.02
#: Newton iterations of a member at the most on the last Jacobian (a chord: linear, 7-15
#: taken from a neighbour), then on fresh Jacobians (each ``2 n`` shots: where there is no
#: member, beyond the edge, the iterations spent finding that out are lost; from a
#: neighbour 2-4 suffice)
MEMBER_ITERATIONS, FRESH_ITERATIONS = 20, 6
#: a trace ends after this many stick radii at the most. The admissible region reaches far
#: beyond one radius where the wheel is soft against ``k_t``: a slider's shift then mostly
#: moves the wheel with it, and the stuck spring's force changes by a fraction of ``k_t``
#: times it (the paper wheel's shroud at 0 deg: 1.4 % of the amplitude per radius, the
#: preload's history 15 radii away)
REACH = 100.0


@dataclass
class Member:
    """One orbit of the family: ``offset`` ``(S,)`` the held sliders' shift from the
    orbit's, in stick radii (per stuck kind its ``(xi, zeta)``); ``orbit``; ``tip`` [m] the
    0-peak tip amplitude over its period's steps; ``margin`` the held contacts' least
    distance from slipping over the period, ``min (1 - |F_t| / (mu F_n))`` (0 at the
    admissible region's edge)."""

    offset: np.ndarray
    orbit: Orbit
    tip: float
    margin: float = math.nan


@dataclass
class Band:
    """The band of an elastic-law orbit's family. ``kinds``: the contact kinds stuck all
    period (their sliders held); ``radius`` ``(S // 2,)`` [m] their stick radii ``mu F_n /
    k_t`` at the orbit's ``t = 0``; ``low``, ``high`` the members of smallest and largest tip
    amplitude;
    ``start_tip`` [m] the orbit the tool found (where the march's history put it);
    ``gradient`` ``(S,)`` [m per radius] of the tip amplitude; ``members`` every traced
    orbit; ``multiplier_low`` / ``multiplier_high``: the end members' largest in-symmetry
    multiplier but the phase shift's (NaN: not computed); ``reason``: how the traces ended,
    in words."""

    kinds: tuple
    radius: np.ndarray
    low: Member
    high: Member
    start_tip: float
    gradient: np.ndarray
    members: list = field(default_factory=list)
    multiplier_low: float = math.nan
    multiplier_high: float = math.nan
    reason: str = ""

    def words(self) -> str:
        """The band in words: "friction-limited band 0.087-0.526 um over the stuck
        tieboss's admissible offsets (this orbit 0.320 um)"."""
        kinds = " and ".join(self.kinds)
        text = (f"friction-limited band {self.low.tip * 1e6:.4g}-{self.high.tip * 1e6:.4g} um "
                f"over the stuck {kinds}'s admissible offsets (this orbit "
                f"{self.start_tip * 1e6:.4g} um)")
        if math.isfinite(self.multiplier_high):
            text += (f", its largest member {'stable' if self.multiplier_high < 1 else 'unstable'}"
                     f" in symmetry ({self.multiplier_high:.4g})")
        return text


def stuck_kinds(shooting, orbit: Orbit) -> np.ndarray:
    """The contact kinds whose sliders stay put over ``orbit``'s period on every pattern
    blade (:meth:`~.slider_shooting.SliderShooting.locked`)."""
    locked = shooting.locked(orbit)[shooting.nq :].reshape(shooting.K, shooting.N, 2)
    return np.flatnonzero(locked.all(axis=(1, 2)))


def friction_band(shooting, orbit: Orbit, tip_amplitude: float,
                  multipliers=None) -> Band | None:
    """The :class:`Band` of ``orbit``'s family on ``shooting``'s pattern wheel (None when no
    contact sticks all period: the orbit is then isolated). ``tip_amplitude`` [m]: the
    orbit's, the sliders' unit in the shot; each member's tip amplitude the report's
    (:meth:`~.shooting.OrbitSamples.tip_amplitude`, from the period's samples its stick
    margin is read from); ``multipliers(orbit)``: its largest in-symmetry multiplier's
    modulus (None: not computed)."""
    kinds = stuck_kinds(shooting, orbit)
    if kinds.size == 0:
        return None
    params = shooting.flow.params
    c = params.contacts
    normal = _normal_force(shooting, orbit)  # (K,) at t = 0, blade 0
    radius = np.array([params.law.coulomb * normal[k]
                       / max(float(c.tangential[k, 0]), 1e-300) for k in kinds])
    S = 2 * kinds.size
    held = np.zeros(shooting.n, bool)
    index = shooting.nq + np.arange(shooting.K * shooting.N * 2).reshape(shooting.K,
                                                                          shooting.N, 2)
    held[index[kinds].ravel()] = True
    base = orbit.flat()

    def shifted(x: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """``x`` with the held sliders at the orbit's plus ``offset`` radii."""
        y = np.array(x, dtype=float)
        for i, k in enumerate(kinds):
            y[index[k, :, 0]] = base[index[k, :, 0]] + offset[2 * i] * radius[i]
            y[index[k, :, 1]] = base[index[k, :, 1]] + offset[2 * i + 1] * radius[i]
        return y

    chord = {"reuse": True, "matrix": None}

    def member(x: np.ndarray, period: float, offset: np.ndarray,
               fresh: int = FRESH_ITERATIONS) -> Member | None:
        """The family's orbit at ``offset`` from the state ``x`` (None: none there): Newton
        on the last Jacobian first (a chord), then, failing that, ``fresh`` iterations on
        fresh ones."""
        tries = ((True, MEMBER_ITERATIONS), (False, fresh)) \
            if chord["matrix"] is not None else ((False, MEMBER_ITERATIONS),)
        for reuse, iterations in tries:
            chord["reuse"] = reuse
            found = shooting.solve(shifted(x, offset), period, tip_amplitude, fixed=held,
                                   chord=chord, iterations=iterations)
            if found.converged:
                break
        else:
            return None
        # a held contact slipping to and fro can return its slider exactly: the shot closes,
        # but the offset is no longer free there (the edge)
        path = shooting.samples(found)
        moved = np.any(path.sliders != path.sliders[:1], axis=(0, 3))  # (K, N')
        if moved[kinds].any():
            return None
        return _member(shooting, offset.copy(), found, path, kinds)

    start = _member(shooting, np.zeros(S), orbit, shooting.samples(orbit), kinds)
    members = [start]
    gradient = _gradient(member, start, S, members)
    size = float(np.linalg.norm(gradient))
    reasons = []
    if size == 0.0:
        ends = [start, start]
        reasons.append("no offset changes the amplitude")
    else:
        direction = gradient / size
        ends = []
        for sign, name in ((-1.0, "smallest"), (1.0, "largest")):
            path, words = _trace(member, start, sign * direction)
            members.extend(path[1:])
            ends.append(path[-1])
            reasons.append(f"{name} at {np.linalg.norm(path[-1].offset):.3g} radii ({words})")
    low, high = min(members, key=lambda m: m.tip), max(members, key=lambda m: m.tip)
    band = Band(tuple(c.kinds[k] for k in kinds), radius, low, high, start.tip,
                gradient, members, reason="; ".join(reasons))
    if multipliers is not None:
        band.multiplier_low = float(multipliers(low.orbit))
        band.multiplier_high = float(multipliers(high.orbit))
    return band


def _gradient(member, start: Member, size: int, members: list) -> np.ndarray:
    """``(size,)`` [m per radius] the tip amplitude's gradient in the offset: one step of
    :data:`FIRST_STEP` along each component (the other way where there is no member), the
    members found appended to ``members``."""
    gradient = np.zeros(size)
    for j in range(size):
        step = np.zeros(size)
        step[j] = FIRST_STEP
        for sign in (1.0, -1.0):
            found = member(start.orbit.flat(), start.orbit.period, sign * step,
                           MEMBER_ITERATIONS)
            if found is not None:
                members.append(found)
                gradient[j] = sign * (found.tip - start.tip) / FIRST_STEP
                break
    return gradient


def _normal_force(shooting, orbit: Orbit) -> np.ndarray:
    """``(K,)`` [N] each contact kind's normal force on pattern blade 0 at ``orbit``'s
    ``t = 0`` (the preload plus the static and the vibration's load there)."""
    x = orbit.flat()
    nq = shooting.nq
    q = x[: nq // 2].reshape(shooting.N, shooting.m)
    v = x[nq // 2 : nq].reshape(shooting.N, shooting.m)
    forces = shooting.flow.forces()
    forces.evaluate(0.0, np.ascontiguousarray(q), np.ascontiguousarray(v),
                    x[nq:].reshape(shooting.K, shooting.N, 2))
    return forces.normal_force[:, 0].copy()


def _trace(member, start: Member, direction: np.ndarray) -> tuple[list, str]:
    """The members from ``start`` along ``direction`` (unit, in radii) to the edge of the
    admissible region, where the held contacts' :attr:`Member.margin` reaches 0: each next
    offset where the secant through the last two members' margins puts it (a little inside,
    at most :data:`GROWTH` times the last step, at least :data:`FIRST_STEP`; while the margin
    still grows, :data:`GROWTH` times the last step), halved towards the last member where
    there is none; ``(members, why it ended)``."""
    path, step = [start], FIRST_STEP
    s = 0.0
    while s < REACH:
        last = path[-1]
        if last.margin <= EDGE:
            return path, f"its held contact within {last.margin:.1%} of slipping"
        x, period = last.orbit.flat(), last.orbit.period
        if len(path) > 1:  # the secant's prediction: the members move near-affinely
            prev = path[-2]
            ratio = step / float(np.linalg.norm(last.offset - prev.offset))
            x = x + ratio * (x - prev.orbit.flat())
            period += ratio * (period - prev.orbit.period)
        found = member(x, period, (s + step) * direction)
        if found is None:
            if step <= EDGE * max(1.0, s):
                return path, f"the held contact slips beyond it (to {step:.2g} radii)"
            step *= 0.5
            continue
        path.append(found)
        s += step
        if found.margin < last.margin:  # the next step to the secant's zero, a little inside
            slope = (last.margin - found.margin) / step
            step = min(max((1 - EDGE) * found.margin / slope, FIRST_STEP), GROWTH * step,
                       LARGEST_STEP)
        else:  # still moving away from the edge: longer steps
            step = min(GROWTH * step, LARGEST_STEP)
    return path, f"the trace's reach, {REACH:g} radii"


def _member(shooting, offset: np.ndarray, orbit: Orbit, path, kinds: np.ndarray) -> Member:
    """The :class:`Member` at ``offset`` from its ``orbit`` and that orbit's period samples
    ``path`` (each integrated once: the tip amplitude and the stick margin both read it)."""
    return Member(offset, orbit, path.tip_amplitude(shooting.model.tip),
                  _margin(shooting, path, kinds))


def _margin(shooting, path, kinds: np.ndarray) -> float:
    """The held contacts' least ``1 - |F_t| / (mu F_n)`` over an orbit's steps ``path``
    (:class:`~.shooting.OrbitSamples`, the sliders each step starts from) on every pattern
    blade: how far they are from slipping (0 on the Coulomb limit; an open contact, ``F_n =
    0``, counts as 0)."""
    forces = shooting.flow.forces()
    mu = shooting.flow.params.law.coulomb
    least = math.inf
    for S in range(path.states.shape[0]):
        q, v = path.states[S]
        forces.evaluate(0.0, np.ascontiguousarray(q), np.ascontiguousarray(v),
                        path.sliders[S])
        limit = mu * forces.normal_force[kinds]  # (kinds, N')
        used = np.linalg.norm(forces.friction_force[kinds], axis=2)
        share = np.where(limit > 0, 1.0 - used / np.maximum(limit, 1e-300), 0.0)
        least = min(least, float(share.min()))
    return least
