"""The reported quantities of an exact periodic orbit, from one period at every TS step (the
same as the harmonic balance reports for its cycles: :func:`wheelrom.analysis.periodic.limit_cycle.
describe`), so either method fills one table."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from wheelrom.analysis.periodic.shooting import Orbit, Shooting
from wheelrom.forces.reference import ReferenceForces

#: the energy balance's replay: this many steps to each of the orbit's (the work integrals
#: converge with the step as the scheme does, ~h^2.5 on the paper wheel's attachment basis:
#: its stiff contact-local modes carry the friction's and the damping's work)
REPLAY_REFINE = 8


def replay_balance(flow, orbit: Orbit, refine: int = REPLAY_REFINE) -> tuple[float, float]:
    """``(closure, imbalance)`` of the energy balance over one period of ``orbit`` replayed
    from its state at ``t = 0`` in ``refine`` times its steps on its pattern wheel ``flow``:
    the works ``W`` (self-excitation and nozzle in; friction and damping out) integrated
    with the state, and the mechanical energy's change ``dE`` (kinetic, elastic, the normal
    contact springs': :meth:`~.flow.WheelFlow.energy`; the friction's work is the tangential
    force's on the wheel, its springs' release included). ``closure = |W - dE| / W_in``: the
    accounting is complete to the replay's accuracy; ``imbalance = |W| / W_in``: the cycle's
    in against out, its energy per cycle not returned (the orbit is a fixed point of the
    map at its own step, a finer flow leaves it by the step's truncation)."""
    state = orbit.flat()
    steps = max(1, orbit.steps_per_period) * refine
    end, works = flow.works(state, orbit.period, steps)
    change = flow.energy(end, tangential=False) - flow.energy(state, tangential=False)
    work_in = max(abs(float(works[0] + works[1])), 1e-300)
    total = float(works.sum())
    return abs(total - change) / work_in, abs(total) / work_in


def orbit_quantities(shooting: Shooting, orbit: Orbit, harmonics: int, lam: float) -> dict:
    """The :class:`~wheelrom.analysis.periodic.limit_cycle.Cycle` fields of ``orbit`` (per blade:
    blade 0 of the pattern; per contact kind: blade pair ``(0, 1)``, which every pair repeats
    shifted in time). ``harmonics``: ``H`` of blade 0's harmonics ``c_h`` (``(H + 1, m)``
    complex, by the DFT of the samples). Energies per cycle by the rectangle rule on the
    uniform samples (spectral for a periodic integrand); the energy balance by
    :func:`replay_balance`."""
    samples = shooting.samples(orbit)  # the elastic law's slider shot carries the sliders
    model, params = shooting.model, shooting.flow.params
    states = np.ascontiguousarray(samples.states)
    S, N, m = states.shape[0], shooting.N, shooting.m
    q, v = np.ascontiguousarray(states[:, 0]), np.ascontiguousarray(states[:, 1])
    K = len(params.contacts.kinds)
    force = np.zeros((S, N, m))
    normal, power, state = np.zeros((S, K)), np.zeros((S, K)), np.zeros((S, K), np.int8)
    # the elastic law: marched through the samples from the orbit's sliders at t = 0, each
    # sample's slider the last one's return (as the flow's steps return them)
    sliders = None if samples.sliders is None else np.ascontiguousarray(samples.sliders)
    ReferenceForces(params).evaluate_samples(q, v, force, normal, power, state, sliders,
                                             periods=0 if sliders is None else 1)
    force0 = np.zeros((S, N, m))
    quiet = dataclasses.replace(params, vdp_mu=0.0)
    ReferenceForces(quiet).evaluate_samples(q, v, force0, np.zeros((S, K)), np.zeros((S, K)),
                                            np.zeros((S, K), np.int8), sliders,
                                            periods=0 if sliders is None else 1)
    period = orbit.period
    omega = 2 * math.pi / period
    work_in = float(np.mean(np.sum((force - force0)[:, 0] * v[:, 0], axis=1))) * period
    friction = -power.mean(axis=0) * period
    Kd = model.dense_stiffness()
    Kv = (v.reshape(S, N * m) @ Kd.T)[:, :m]
    beta = shooting.flow.cfg.wheel.damping_beta
    damping = float(beta * np.mean(np.sum(Kv * v[:, 0], axis=1)) * period)
    q0 = q[:, 0]
    spectrum = np.fft.fft(q0, axis=0) / S
    c = np.zeros((harmonics + 1, m), dtype=complex)
    top = min(harmonics, (S - 1) // 2)
    c[0] = spectrum[0].real
    c[1 : top + 1] = 2 * spectrum[1 : top + 1]
    h = np.arange(harmonics + 1)
    kinetic = float(np.sum((h * omega) ** 2 * np.sum(np.abs(c) ** 2, axis=1)))
    out = float(friction.sum() + damping)
    closure, imbalance = replay_balance(shooting.flow, orbit)
    return dict(
        lam=float(lam), frequency_hz=orbit.frequency_hz, harmonics=c,
        tip_amplitude=samples.tip_amplitude(model.tip),
        tip_harmonics=np.linalg.norm(np.abs(c[1:] @ model.tip.T), axis=1),
        normal_force_range=np.stack([normal.min(axis=0), normal.max(axis=0)], axis=1),
        fractions=np.array([[np.mean(state[:, k] == s) for s in range(3)] for k in range(K)]),
        energy_in=work_in, energy_friction=friction, energy_damping=damping,
        energy_residual=closure, energy_residual_fine=imbalance,
        damping_ratio=out / (2 * math.pi * kinetic) if kinetic > 0 else math.nan,
        residual=orbit.residual, method="shooting", shooting_residual=orbit.residual,
        orbit=orbit)
