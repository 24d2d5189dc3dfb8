"""The elastic law's exact orbits (issue #44): marched on the wave's pattern wheel and shot
with the sliders in the state (:mod:`wheelrom.analysis.periodic.slider_shooting`), checked
against the whole wheel's flow, the energy balance and the stuck contact's zero dissipation."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import SMALL

SHROUD = 40.0  # the small wheel flutters in ND 6 at 490 Hz, the shroud slipping 15 %
ELASTIC = ['contacts.law="elastic"', 'time.scheme="exponential"']


def load_small_model(overrides):
    from wheelrom import config
    from wheelrom.rom.build import build_model
    from wheelrom.runtime.environment import petsc

    cfg = config.load(SMALL, overrides)
    return cfg, build_model(cfg, petsc().COMM_SELF)


@pytest.fixture(scope="module")
def elastic_orbit():
    from wheelrom.analysis.periodic.limit_cycle import case_limit_cycles, settings_of

    cfg, model = load_small_model(ELASTIC)
    angles = {"tieboss": 45.0, "shroud": SHROUD}
    res = case_limit_cycles(model, cfg, settings_of(cfg), angles)
    return cfg, model, angles, res


def test_the_elastic_orbit_is_a_periodic_orbit_of_the_whole_wheel(elastic_orbit):
    """The orbit found on the 2-blade pattern of ND 6 (state and sliders at ``t = 0``),
    repeated over the 12 blades, is a fixed point of the whole wheel's flow over one period
    in the orbit's steps: the pattern's shift of the sliders and the symmetry hold; it is
    the march's orbit (grown from half the slip onset) at 490.5 Hz (the whole wheel's
    transient settles on it: the last test)."""
    from wheelrom.analysis.periodic.flow import WheelFlow

    cfg, model, angles, res = elastic_orbit
    (branch,) = res.branches
    assert branch.nodal_diameter == 6 and len(branch.cycles) == 1, branch.end
    cycle = branch.cycles[0]
    orbit = cycle.orbit
    assert cycle.method == "shooting" and orbit.sliders is not None
    assert orbit.pattern == 2 and orbit.residual <= 1e-9
    assert cycle.frequency_hz == pytest.approx(490.5, abs=0.5)
    assert cycle.tip_amplitude == pytest.approx(0.3203e-6, rel=1e-3)
    N = model.blades
    blades = np.arange(N) % orbit.pattern
    x = np.concatenate([orbit.wheel_state(N).ravel(), orbit.sliders[:, blades].ravel()])
    flow = WheelFlow(model, cfg, angles)
    try:
        end = flow.advance(x[None], orbit.period, orbit.steps_per_period)[0]
    finally:
        flow.destroy()
    nq = 2 * N * model.modes
    vibration = np.abs(x[nq // 2 : nq]).max()
    assert np.abs(end[:nq] - x[:nq]).max() <= 1e-7 * vibration
    assert np.abs(end[nq:] - x[nq:]).max() <= 1e-7 * cycle.tip_amplitude


def test_the_elastic_orbit_balances_its_energy_and_the_stuck_contact_dissipates_nothing(
        elastic_orbit):
    """Over the period replayed at an eighth of its step the works (the self-excitation's in,
    the friction's and the damping's out) equal the change of the wheel's mechanical energy
    to 1e-5 (measured 1.4e-7: the accounting is complete across the stick-slip kinks), and
    the cycle's in-against-out there, the orbit's departure from periodicity under the finer
    flow, is a small fraction (4e-4: the step's truncation); all of the friction's
    dissipation is in the shroud: the tie-boss sticks the whole period and a stuck elastic
    contact dissipates nothing (to 1e-6 of the input, the round-off of its spring's power
    summed over the period)."""
    _, _, _, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    assert cycle.energy_in > 0 and cycle.energy_residual <= 1e-5
    assert cycle.energy_residual < cycle.energy_residual_fine < 2e-3
    open_, stick, slip = cycle.fractions[0]  # tieboss
    assert (open_, stick, slip) == (0.0, 1.0, 0.0)
    # its spring's power sums to zero over the period up to the round-off of the sum
    # (measured 7e-10 and 2.5e-9 of the input: the bound is three orders above it)
    assert abs(cycle.energy_friction[0]) <= 1e-6 * cycle.energy_in
    assert 0.05 < cycle.fractions[1, 2] < 0.3  # the shroud slips part of the period
    assert cycle.energy_friction[1] > 0.9 * cycle.energy_in


def test_the_elastic_orbits_multipliers_are_the_transients_decay(elastic_orbit):
    """The orbit's multipliers inside its symmetry (the pattern map's Jacobian without the
    sliders of the tie-boss, stuck all period: 2 blades x 2 components left out, each a
    multiplier exactly 1) against the transient itself: the pattern wheel started on the
    orbit plus 1e-6 of the eigenvector of the largest non-trivial one (real, 0.99765)
    returns at that rate per period, its distance from the orbit off the flow direction
    (the phase) measured each period (to 1e-4; measured 1e-5: the multipliers are taken on
    the orbit's event schedule, the transient in uniform steps). The verdict: stable and
    trusted, the multiplier settled over the halvings of the step (by 1e-4, where they
    stop: measured 5e-7 over the first) and the phase shift's 1 to 1e-3."""
    from wheelrom.analysis.periodic.exact import SETTLED_CHANGE
    from wheelrom.analysis.periodic.slider_shooting import SliderShooting

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    orbit = cycle.orbit
    # stable inside the 2-blade pattern (NDs 0, 6) and for the whole wheel (every ND by
    # Bloch waves, the next test), trusted at the two finest steps
    assert cycle.stable is True
    assert cycle.stability.by.startswith("monodromy of the whole wheel by Bloch waves")
    assert res.branches[0].verdict().startswith("settles at")
    mu = cycle.multipliers
    assert mu.by == "Bloch waves" and mu.nd[mu.worst] == 6 and mu.largest < 0.999
    assert 2 <= len(cycle.refined) < 5 and {nd for _, _, nd in cycle.refined} == {6}
    moduli = [mu for _, mu, _ in cycle.refined]
    assert abs(moduli[-1] - moduli[-2]) <= SETTLED_CHANGE and max(moduli) < 0.999
    assert max(moduli) - min(moduli) <= 1e-5  # every level on the events (measured 5e-7)
    assert orbit.switches is not None and orbit.switches.times.size >= 4
    shooting = SliderShooting(model, cfg, orbit.wave, angles, 1.0)
    try:
        mu = shooting.multipliers(orbit, cycle.tip_amplitude)
        assert mu["neutral"] == 4 and abs(mu["values"][mu["trivial"]] - 1.0) <= 1e-3
        values = mu["values"]
        rest = np.delete(np.arange(values.size), mu["trivial"])
        worst = rest[np.argmax(np.abs(values[rest]))]
        assert abs(values[worst].imag) < 1e-12 and values[worst].real == \
            pytest.approx(moduli[0], abs=1e-12)
        x0 = orbit.flat()
        scale = shooting._scale(x0, orbit.period, cycle.tip_amplitude)
        h = orbit.period / orbit.steps_per_period
        along = (shooting.flow.advance(x0[None], h, 1)[0] - x0) / scale
        along /= np.linalg.norm(along)
        v = mu["vectors"][:, worst].real
        x = x0 + 1e-6 * v / np.linalg.norm(v / scale)
        distance = []
        for _ in range(40):
            x = shooting.flow.advance(x[None], orbit.period, orbit.steps_per_period)[0]
            d = (x - x0) / scale
            distance.append(np.linalg.norm(d - (along @ d) * along))
    finally:
        shooting.destroy()
    rate = (distance[-1] / distance[9]) ** (1 / 30)
    assert rate == pytest.approx(values[worst].real, abs=1e-4)


def test_the_whole_wheels_multipliers_by_bloch_waves_are_its_monodromys(elastic_orbit):
    """The block-circulant identity: every multiplier of the whole 12-blade wheel about the ND 6
    orbit by Bloch waves (its 6 copies of the 2-blade pattern, the responses to pattern 0 moved
    alone through the shot's map ``F = S^{-j} phi_{T/2}``;
    :func:`~wheelrom.analysis.periodic.bloch.bloch_multipliers`) is an eigenvalue of ``S^{j N'}
    J_F^{N'}``, ``J_F`` differenced over every unknown of every blade, and back (to 1e-9;
    measured 1e-14: the same differences, rearranged; a wrong index map, Bloch sign or phase
    ``w^{p j}`` fails it, and the phase did, with ``w^{p^2 j}``, on blocks 2 and 5), and of the
    wheel's monodromy differenced over whole periods (to 1e-3; measured 2e-4: the orbit is the
    fixed point of the shot in uniform steps, so the shot's Jacobian at it to the N'-th is the
    period's to its distance from the one on events), all on the orbit's event schedule; the
    Bloch phase 0 is the pattern's own map (its largest non-trivial, 0.99764, to 1e-4). The tie-
    boss's sliders are locked in every copy (12 x 2 left out of 2 x 12 x (12 + 4)). Independent
    truth, the transient: the whole wheel started on the orbit plus 1e-6 of the eigenvector of
    the largest multiplier off the pattern's symmetry (ND 5, 0.99732) returns at that rate per
    period (to 1e-4; measured 2e-6)."""
    from wheelrom.analysis.periodic.bloch import DIFFERENCE, blade_indices, bloch_multipliers
    from wheelrom.analysis.periodic.events import Schedule
    from wheelrom.analysis.periodic.flow import WheelFlow
    from wheelrom.analysis.periodic.slider_shooting import SliderShooting

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    orbit = cycle.orbit
    shooting = SliderShooting(model, cfg, orbit.wave, angles, 1.0)
    try:
        scale = shooting._scale(orbit.flat(), orbit.period, cycle.tip_amplitude)
        keep = np.flatnonzero(~shooting.locked(orbit))
        inside = shooting.multipliers(orbit, cycle.tip_amplitude)
    finally:
        shooting.destroy()
    bloch = bloch_multipliers(model, cfg, orbit, scale, keep, angles)
    N, m, pattern = model.blades, model.modes, orbit.pattern
    copies, kinds = N // pattern, orbit.sliders.shape[0]
    assert keep.size == 2 * pattern * m + 2 * pattern and bloch.values.size == copies * keep.size
    where = np.concatenate([blade_indices(p * pattern + np.arange(pattern), N, m, kinds)[keep]
                            for p in range(copies)])
    unit = np.tile(scale[keep], copies)
    state = np.concatenate([orbit.wheel_state(N).ravel(), orbit.wheel_sliders(N).ravel()])
    probes = np.repeat(state[None], 2 * where.size, axis=0)
    rows = np.arange(where.size)
    probes[2 * rows, where] += DIFFERENCE * unit
    probes[2 * rows + 1, where] -= DIFFERENCE * unit
    shots, n = round(1 / orbit.fraction), keep.size
    tau, steps = orbit.fraction * orbit.period, orbit.steps_per_period // shots
    schedule = orbit.switches.schedule(tau / steps, N)  # the Bloch waves' shots
    flow = WheelFlow(model, cfg, angles, 1.0)
    try:
        short = flow.shift(flow.advance(probes, tau, steps, schedule=schedule), -orbit.shift)
        # the whole period on the same switches: blade s at r tau + t is blade s + r j at t
        period = Schedule(orbit.period, tuple(
            (length, count, np.roll(modes, -r * orbit.shift, axis=1))
            for r in range(shots) for length, count, modes in schedule.pieces))
        ends = flow.advance(probes, orbit.period, schedule=period)
    finally:
        flow.destroy()
    J = ((short[0::2] - short[1::2])[:, where] / (2 * DIFFERENCE) / unit).T
    # S^{j N'}: copy r of the pattern replaced by copy r + j
    shift = (np.arange(copies * n).reshape(copies, n) + orbit.shift * n) % (copies * n)
    by_shots = np.linalg.eigvals(np.linalg.matrix_power(J, shots)[shift.ravel()])
    monodromy = ((ends[0::2] - ends[1::2])[:, where] / (2 * DIFFERENCE) / unit).T
    dense, vectors = np.linalg.eig(monodromy)
    for other, tolerance in ((by_shots, 1e-9), (dense, 1e-3)):
        distance = np.abs(bloch.values[:, None] - other[None, :])
        assert distance.min(axis=1).max() < tolerance
        assert distance.min(axis=0).max() < tolerance
    values = inside["values"]
    rest = np.delete(np.arange(values.size), inside["trivial"])
    assert abs(bloch.values[bloch.worst]) == pytest.approx(abs(values[rest]).max(), abs=1e-4)
    assert bloch.nd[bloch.worst] == 6 and abs(bloch.values[bloch.trivial] - 1.0) < 1e-3
    other = next(i for i in range(bloch.values.size) if bloch.nd[i] not in (0, 6))
    assert bloch.nd[other] == 5
    v = vectors[:, np.argmin(np.abs(dense - bloch.values[other]))].real * unit
    x = state.copy()
    x[where] += 1e-6 * v / np.linalg.norm(v / unit)
    flow = WheelFlow(model, cfg, angles, 1.0)
    try:
        h = orbit.period / orbit.steps_per_period
        along = (flow.advance(state[None], h, 1)[0] - state)[where] / unit
        along /= np.linalg.norm(along)
        distance = []
        for _ in range(40):
            x = flow.advance(x[None], orbit.period, orbit.steps_per_period)[0]
            d = (x - state)[where] / unit
            distance.append(np.linalg.norm(d - (along @ d) * along))
    finally:
        flow.destroy()
    rate = (distance[-1] / distance[9]) ** (1 / 30)
    assert rate == pytest.approx(abs(bloch.values[other]), abs=1e-4)


@pytest.mark.parametrize("shroud, preload", [(SHROUD, None), (90.0, 1.0)])
def test_slip_onset_is_where_the_stuck_mode_first_changes_a_contacts_state(shroud, preload):
    """:meth:`SliderShooting.slip_onset` against the contact law itself: the stuck mode at
    0.99 of the onset amplitude, over a period of phases, keeps every closed contact closed
    and inside its stick range ``mu F_n / k_t`` and every open one open; at 1.01 of it one
    contact leaves its state. At 40 deg every contact is closed; at 90 deg with a 1 N shroud
    preload the static load opens the shroud (its gap then counts, not a zero stick range:
    a zero onset seeded nothing, measured on the paper wheel's 100 N cases)."""
    from wheelrom.analysis.periodic.hopf import wave_blocks, wave_mode
    from wheelrom.analysis.periodic.slider_shooting import SliderShooting
    from wheelrom.analysis.stability import linearise

    extra = [] if preload is None else [f"contacts.shroud.normal_preload={preload}"]
    cfg, model = load_small_model(ELASTIC + extra)
    angles = {"tieboss": 45.0, "shroud": shroud}
    params, q, _, J, _ = linearise(model, cfg, angles)
    B0, B1 = wave_blocks(model, params, q, J)
    k = int(np.argmax([wave_mode(B0[w], B1[w], 1.0)[0] for w in range(model.blades)]))
    _, _, vector = wave_mode(B0[k], B1[k], 1.0)
    shooting = SliderShooting(model, cfg, k, angles)
    try:
        onset = shooting.slip_onset(q, vector)
        forces = shooting.flow.forces()
        q0 = np.ascontiguousarray(q[: shooting.N])
        forces.evaluate(0.0, q0, np.zeros_like(q0))
        rest = forces.relative_displacement[:, :, ::2].copy()
        normal = forces.normal_force.copy()
        closed = normal > 0
        limit = params.law.coulomb * normal / params.contacts.tangential[:, : shooting.N]
        mode = shooting.unit_mode(vector)[:, : model.modes]
        changed = []
        for factor in (0.99, 1.01):
            change = False
            for phase in np.linspace(0.0, 2 * np.pi, 721):
                dq = (factor * onset * mode * np.exp(1j * phase)).real
                forces.evaluate(0.0, np.ascontiguousarray(q0 + dq), np.zeros_like(q0))
                moved = np.linalg.norm(forces.relative_displacement[:, :, ::2] - rest, axis=2)
                now = forces.normal_force > 0
                change |= bool(np.any(now != closed) or np.any(moved[closed] > limit[closed]))
            changed.append(change)
    finally:
        shooting.destroy()
    assert 0.0 < onset < 1e-4
    assert (preload is None) == bool(closed.all())
    assert changed == [False, True]


def test_the_whole_wheel_settles_on_the_elastic_orbit(elastic_orbit):
    """The whole wheel's transient from the preloaded equilibrium (settle, every unstable
    wave's growing mode seeded at half the fastest one's slip onset, every ND perturbed)
    settles in ND 6 at the exact orbit's amplitude to 2 % and its frequency to 1e-3
    (measured: 0.321-0.322 against 0.320 um; seeded at 1 um, above the orbit, the shroud's
    slip on the way down locks a prestress into the stuck tie-boss and it settled at
    0.323-0.329 um, 2.7 % above)."""
    from wheelrom.analysis.periodic.settle import Settings, settle_case
    from wheelrom.studies.settle import _start

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    cfg = cfg.replace(**{"settle.start": "preload"})
    u0, frequency, words, _, _ = _start(model, cfg, angles, None)
    assert "half the stuck mode's slip onset" in words
    out = settle_case(model, cfg, angles, u0, frequency,
                      Settings(window_periods=20, min_time=1.0, max_time=2.0))
    assert out.settled and int(np.argmax(out.nd_energy)) == 6
    assert out.amplitude.max() == pytest.approx(cycle.tip_amplitude, rel=0.02)
    assert out.classification.frequency_hz == pytest.approx(cycle.frequency_hz, rel=1e-3)


def test_settle_from_the_elastic_orbit_carries_its_sliders_and_stays_on_it(elastic_orbit):
    """``settle.start = "cycle"`` under the elastic law starts the whole wheel on the orbit
    with its sliders (the file's ``orbit_sliders``, or the orbit computed), every ND
    perturbed at 1e-3 of it: the orbit attracts the whole wheel (ND 6 is the small wheel's
    N/2), so it settles where it started, to 2e-3 (measured 4e-4); started with the sliders
    at rest at the orbit's state instead, the stuck tie-boss takes the orbit's tangential
    force as a new offset and the wheel settles 1.2 % higher (measured: another orbit of
    the family)."""
    from wheelrom.analysis.periodic.settle import Settings, settle_case
    from wheelrom.studies.settle import _start

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    u0, frequency, words, amplitude, hold = _start(model, cfg, angles, None)
    assert words.startswith("the exact orbit of wave 6") and hold == 0.0  # none computed
    n = 2 * model.size
    tiled = cycle.orbit.sliders[:, np.arange(model.blades) % 2]
    assert u0.size == n + 4 + tiled.size and np.array_equal(u0[n + 4 :], tiled.ravel())
    out = settle_case(model, cfg, angles, u0, frequency,
                      Settings(window_periods=20, min_time=0.3, max_time=1.0))
    assert int(np.argmax(out.nd_energy)) == 6
    assert out.amplitude.max() == pytest.approx(amplitude, rel=2e-3)


def test_a_start_on_an_unstable_orbit_is_not_called_settled_before_it_can_leave(
        elastic_orbit, tmp_path):
    """A settle started on an orbit whose file holds a multiplier above 1 is not called
    settled before a 1e-3 perturbation could have grown to the orbit's size at that rate
    (``ln(1e3) / (ln|mu| f)``): its first windows are stationary only because the departure
    has not grown yet (the paper wheel at 75 deg: "settled" at 1 s on a 1.014-per-period
    orbit it left at 1.5 s). The small wheel's orbit is stable inside its symmetry (0.99765,
    not decided for the wheel: no hold): from its file the case settles at 0.3-0.4 s (its
    ``min_time``); with an unstable verdict at 1.0178 in a copy of the file, not before the
    0.8 s that rate needs."""
    import math
    import shutil

    import h5py

    from wheelrom.results.limit_cycles import write_limit_cycles
    from wheelrom.studies.settle import _settle_batch, _start

    cfg, model, angles, res = elastic_orbit
    path = tmp_path / "lc.h5"
    with h5py.File(path, "w") as f:
        write_limit_cycles(f, cfg, model, [res])
    keys = {"settle.min_time": 0.3, "settle.max_time": 1.2, "settle.start": "cycle"}
    case = cfg.replace(**keys)
    frequency = res.branches[0].cycles[0].frequency_hz
    assert _start(model, case, angles, str(path))[4] == 0.0
    stable = _settle_batch(model, [case], [angles], str(path), ["stable"], None)[0]
    assert stable.settled and stable.time < 0.5
    unstable = tmp_path / "unstable.h5"
    shutil.copy(path, unstable)
    multiplier = 1.0178
    with h5py.File(unstable, "r+") as f:
        c = f["limit_cycle/case_0/wave_6/cycles"]  # an unstable verdict at that multiplier
        c["floquet_multiplier"][0], c["stable"][0] = multiplier, 0
    _, _, words, _, hold = _start(model, case, angles, str(unstable))
    assert hold == pytest.approx(math.log(1e3) / (math.log(multiplier) * frequency), rel=1e-9)
    assert 0.75 < hold < 0.85 and "not called settled before 0.8 s" in words, words
    held = _settle_batch(model, [case], [angles], str(unstable), ["held"], None)[0]
    assert held.settled and held.time >= hold


def test_a_failed_whole_wheel_keeps_the_symmetrys_verdict(elastic_orbit, monkeypatch):
    """The whole wheel's multipliers failing (a diverging perturbed flow, say) neither loses
    the orbit's multipliers inside its symmetry nor calls it stable for the wheel: the verdict
    stays "stable inside its own symmetry", undecided, with why the rest is missing."""
    import dataclasses

    from wheelrom.analysis.periodic import exact
    from wheelrom.analysis.periodic.slider_shooting import SliderShooting

    cfg, model, angles, res = elastic_orbit
    cycle = dataclasses.replace(res.branches[0].cycles[0], stability=None, refined=[],
                                multipliers=None)

    def failing(*_, **__):
        raise RuntimeError("the flow took 3 of 408 steps")

    monkeypatch.setattr(exact, "bloch_multipliers", failing)
    shooting = SliderShooting(model, cfg, cycle.orbit.wave, angles, 1.0)
    try:
        exact.elastic_stability(model, cfg, angles, cycle, shooting, 1)
    finally:
        shooting.destroy()
    assert cycle.stable is None and cycle.multipliers is None and len(cycle.refined) == 2
    assert cycle.stability.by.startswith("stable inside its own symmetry (largest 0.9976")
    assert cycle.stability.by.endswith("the whole wheel's failed (RuntimeError: the flow took "
                                       "3 of 408 steps): settle decides")


def test_the_friction_limited_orbits_form_a_band_holding_the_preload_history(elastic_orbit):
    """The tie-boss sticks the whole period: its slider's offset is neutral, and every offset
    that keeps it stuck gives another exact orbit (issue #68). The band traced over those
    offsets (:mod:`wheelrom.analysis.periodic.family`) holds the orbit found, its ends are
    exact orbits of the whole wheel with the tie-boss stuck, and the pattern's own transient
    from above the slip onset, another history, lands inside it (0.48 um, results.md)."""
    from wheelrom.analysis.periodic.flow import WheelFlow
    from wheelrom.analysis.periodic.hopf import wave_blocks, wave_mode
    from wheelrom.analysis.periodic.slider_shooting import SliderShooting
    from wheelrom.analysis.stability import linearise

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    band = cycle.band
    assert band is not None and band.kinds == ("tieboss",)
    assert band.low.tip == pytest.approx(0.087e-6, rel=0.05)
    assert band.high.tip == pytest.approx(0.526e-6, rel=0.05)
    assert band.low.tip < cycle.tip_amplitude == band.start_tip < band.high.tip
    assert band.multiplier_high < 1.0  # its largest member stable in its symmetry
    # both ends on the edge: the held tie-boss within 2 % of the Coulomb limit somewhere in
    # the period, while the orbit found keeps well inside it
    assert band.low.margin <= 0.02 and band.high.margin <= 0.02
    assert band.members[0].margin > 0.1
    N = model.blades
    flow = WheelFlow(model, cfg, angles)
    shooting = SliderShooting(model, cfg, 6, angles)
    try:
        for end in (band.low, band.high):
            orbit = end.orbit
            assert orbit.converged and orbit.residual <= 1e-9
            stuck = shooting.locked(orbit)[shooting.nq :].reshape(shooting.K, shooting.N, 2)
            assert stuck[0].all() and not stuck[1].all()  # the tie-boss held, the shroud slips
            blades = np.arange(N) % orbit.pattern
            x = np.concatenate([orbit.wheel_state(N).ravel(), orbit.sliders[:, blades].ravel()])
            after = flow.advance(x[None], orbit.period, orbit.steps_per_period)[0]
            nq = 2 * N * model.modes
            assert np.abs(after[:nq] - x[:nq]).max() <= 1e-7 * np.abs(x[nq // 2 : nq]).max()
        # another history: the stuck mode started at twice its slip onset, marched
        params, q, _, J, _ = linearise(model, cfg, angles)
        B0, B1 = wave_blocks(model, params, q, J)
        _, value, vector = wave_mode(B0[6], B1[6], 1.0)
        onset = shooting.slip_onset(q, vector)
        x = shooting.start(q, vector, 2 * onset)
        x, period, _ = shooting.march(x, 2 * np.pi / value.imag)
        history = shooting.tip_estimate(x, period)
        assert abs(history / cycle.tip_amplitude - 1) > 0.1  # another member
        assert band.low.tip < history < band.high.tip
    finally:
        shooting.destroy()
        flow.destroy()


def test_the_band_is_in_the_file_the_json_and_the_verdict(elastic_orbit, tmp_path, capsys):
    """``/limit_cycle/.../cycles/band`` holds the family's ends and the orbit, ``info --json``
    and ``limit-cycle --json``'s summary read them, and the verdict says the band."""
    import json

    import h5py

    from wheelrom.cli import main as cli
    from wheelrom.results.limit_cycles import write_limit_cycles
    from wheelrom.studies.limit_cycles import summary

    cfg, model, angles, res = elastic_orbit
    band = res.branches[0].cycles[0].band
    path = tmp_path / "lc.h5"
    with h5py.File(path, "w") as f:
        write_limit_cycles(f, cfg, model, [res])
    with h5py.File(path) as f:
        c = f["limit_cycle/case_0/wave_6/cycles"]
        np.testing.assert_array_equal(c["band"][0], [band.low.tip, band.high.tip,
                                                     band.start_tip])
        np.testing.assert_array_equal(c["band_high_offset"][0], band.high.offset)
        assert c["band_kinds"][0] == b"tieboss"
    row = summary(res)["waves"][0]["cycles"][0]["band"]
    assert row["low_m"] == band.low.tip and row["high_m"] == band.high.tip
    assert row["stuck_kinds"] == ["tieboss"]
    assert cli.main(["info", str(path), "--json"]) == 0
    cycle = json.loads(capsys.readouterr().out)["cases"][0]["waves"][0]["cycles"][0]
    assert cycle["band"]["high_m"] == pytest.approx(band.high.tip, rel=1e-15)
    assert (f"friction-limited band {band.low.tip * 1e6:.4g}-{band.high.tip * 1e6:.4g} um "
            "over the stuck tieboss's admissible offsets") in res.verdict()


def test_settle_says_where_each_history_of_a_case_ends_against_its_band(elastic_orbit,
                                                                        tmp_path, capsys):
    """Issue #68, 3: ``settle`` over a ``[study]`` of ``settle.start`` runs two histories of
    one case, the preload seeded at half the slip onset and the exact orbit with its sliders,
    and reports them as a group beside the band of the ``--cycles`` file: each history's
    range is its case's own, the spread their union, and the band (0.09-0.53 um) holds both
    (the tests above: the preload history settles at the orbit's 0.320 um to 2 %, the orbit
    stays on itself). Where the flutter would end outside it, the words say so."""
    import json

    import h5py

    from wheelrom.cli import main as cli
    from wheelrom.results.limit_cycles import write_limit_cycles

    cfg, model, angles, res = elastic_orbit
    cycle = res.branches[0].cycles[0]
    band = cycle.band
    path = tmp_path / "lc.h5"
    with h5py.File(path, "w") as f:
        write_limit_cycles(f, cfg, model, [res])
    keys = [*ELASTIC, f"contacts.tieboss.angle_deg={angles['tieboss']}",
            f"contacts.shroud.angle_deg={angles['shroud']}",
            'study.grid={"settle.start" = ["preload", "cycle"]}',
            "settle.min_time=1.0", "settle.max_time=2.0"]
    args = ["settle", str(SMALL), *[a for k in keys for a in ("--set", k)],
            "--cycles", str(path), "--json"]
    assert cli.main(args) == 0
    out = json.loads(capsys.readouterr().out)
    (group,) = out["histories"]
    assert group["members"] == [0, 1] and group["history"] == ["start preload", "start cycle"]
    assert group["band_m"] == [band.low.tip, band.high.tip, band.start_tip, 6]
    assert [nd for nd, _ in group["nd"]] == [6, 6]  # both in the band's wave
    for i, row in enumerate(out["cases"]):
        own = row["band_m"] if "band_m" in row else {"low": row["amplitude_m"]["max"],
                                                      "high": row["amplitude_m"]["max"]}
        assert group["range_m"][i] == [own["low"], own["high"]]
        assert own["low"] == pytest.approx(cycle.tip_amplitude, rel=0.03)
        assert own["high"] == pytest.approx(cycle.tip_amplitude, rel=0.03)
    lows, highs = zip(*group["range_m"], strict=True)
    assert group["spread_m"] == [min(lows), max(highs)]
    assert group["place"] == ["inside", "inside"]
    # the words, and a history outside a narrower band named with its side
    from wheelrom.studies.settle import history_words

    assert "holds 2 of them" in history_words(group)
    narrow = dict(group, band_m=(0.5 * cycle.tip_amplitude, 0.9 * cycle.tip_amplitude, 0.0,
                                 6), place=["above", "above"])
    assert "; start preload above, start cycle above: in the band's wave, its blades " \
        "slipping differently" in history_words(narrow)
    left = dict(narrow, nd=[[6, 0.9], [2, 0.7]])
    assert history_words(left).endswith(
        "; start cycle above, ND 2 70%: the flutter left the band's wave (ND 6) for another, "
        "its orbits unstable in the whole wheel; start preload above: in the band's wave, "
        "its blades slipping differently (offsets outside the band's pattern-symmetric ones)")


def test_histories_group_the_cases_that_differ_only_in_their_start():
    """Cases of one wheel that differ only in ``settle.*`` start keys are one group; another
    preload is another case, alone, and not a group; each range's place against a band: inside,
    above, below, across its edge."""
    from wheelrom.studies.settle import histories

    def row(preload, seed, low, high):
        return {"label": "tieboss 45 deg, shroud 0 deg",
                "angles_deg": {"tieboss": 45.0, "shroud": 0.0},
                "parameters": {"contacts.shroud.normal_preload": preload, "settle.seed": seed},
                "band_m": {"low": low, "high": high, "over_s": 3.0}}

    rows = [row(400.0, 0, 4e-6, 5e-6), row(400.0, 1, 6e-6, 7e-6), row(400.0, 2, 1e-6, 2e-6),
            row(400.0, 3, 3e-6, 4.5e-6), row(800.0, 0, 4e-6, 5e-6)]
    (group,) = histories(rows, lambda angles: (3.5e-6, 5.5e-6, 4.5e-6, 33))
    assert group["members"] == [0, 1, 2, 3]
    assert group["history"] == ["seed 0", "seed 1", "seed 2", "seed 3"]
    assert group["spread_m"] == (1e-6, 7e-6)
    assert group["place"] == ["inside", "above", "below", "across"]
    assert "normal_preload 400.0" in group["label"]
    assert histories(rows[:1] + rows[4:]) == []  # no two histories of one case
