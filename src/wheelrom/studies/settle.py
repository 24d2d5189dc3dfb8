"""Where the flutter settles, over the cases (``wheelrom settle``): every case of the
``[study]`` or of the sweep's angles, in batches (``settle.batch``) handed to the MPI ranks as
they become free (:mod:`.queue`); per case the start (the fastest wave's exact orbit, from a
limit-cycle file or computed here, or the preloaded equilibrium with the unstable waves
seeded), every ND perturbed, then the wheel integrated until stationary
(:mod:`wheelrom.analysis.periodic.settle`).

Nothing computed is lost: each finished case is saved at once by the rank that computed it in
a folder beside the output (``.name.settle/case_<i>.npz``, plain arrays, no pickles, and a
JSON of its scalars, each renamed into place when complete); ``--resume`` skips the cases
found there with the same configuration; rank 0 writes the HDF5 file from them at the end
and removes the folder. A disk that fills keeps a case in memory only (a warning), and the
file is then kept in the temporary directory, as every command's
(:func:`wheelrom.runtime.outputs.save_image`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np

from wheelrom.analysis.periodic.settle import (
    Settings,
    Settled,
    settle_cases,
)
from wheelrom.analysis.periodic.window import wave_state
from wheelrom.config import Config
from wheelrom.config.settle import at_settle_step
from wheelrom.config.study import batch_key, expand, short_name
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import agree, not_a_regular_file
from wheelrom.studies.plan import batches, shared_models
from wheelrom.studies.queue import CaseQueue
from wheelrom.studies.rounds import wait_for_all
from wheelrom.studies.settle_cases import kept_folder, load_case, save_or_keep


def settings_of(cfg: Config) -> Settings:
    s = cfg.settle
    return Settings(window_periods=s.window_periods, tolerance=s.tolerance,
                    consecutive=s.consecutive, min_time=s.min_time, max_time=s.max_time,
                    bounded_span=s.bounded_span, bounded_drift=s.bounded_drift)


def sidecar_dir(out: str) -> str:
    """The folder of ``settle --out out``'s finished cases (:mod:`.settle_cases`)."""
    return kept_folder(out).path


def contact_angles(cfg: Config) -> dict:
    """A case's contact angles [deg] by kind."""
    return {k: cfg.contact(k).angle_deg for k in ("tieboss", "shroud")}


# ------------------------------------------------------------------ the start of one case
def check_cycles(path: str, cfg: Config) -> None:
    """``--cycles``, before any model is built: a limit-cycle file (``wheelrom limit-cycle
    --out``) of this configuration's wheel (the same model keys:
    :func:`~wheelrom.config.study.model_data`), whose orbits are in this model's
    coordinates. Its force, time and limit-cycle keys may differ (an orbit of another
    intensity is still a start). Anything else is one line naming the file and what is
    wrong."""
    import h5py

    from wheelrom.config.study import model_data
    from wheelrom.results.info import kind_of
    from wheelrom.results.layout import config_changes
    from wheelrom.results.limit_cycles import FORMAT as LIMIT_CYCLE_FORMAT

    if not os.path.exists(path):
        raise InputError(f"--cycles {path}: no such file")
    what = not_a_regular_file(path)  # a directory, /dev/null (a read would never end), ...
    if what:
        raise InputError(f"--cycles {path}: is {what}, not a limit-cycle file (wheelrom "
                         "limit-cycle --out)")
    fmt, kind = kind_of(path)
    if fmt != LIMIT_CYCLE_FORMAT:
        raise InputError(f"--cycles {path}: is {kind}, not a limit-cycle file (wheelrom "
                         "limit-cycle --out)")
    with h5py.File(path, "r", locking=False) as f:
        if "limit_cycle" not in f:
            raise InputError(f"--cycles {path}: its group /limit_cycle is missing (a limit-cycle "
                             "file cut short?)")
        changed = config_changes(f.attrs.get("config"), cfg, select=model_data)
    if changed:
        raise InputError(f"--cycles {path}: written for another wheel ({changed}): its orbits "
                         "are not this model's; compute the limit cycles of this "
                         "configuration")
    if cfg.settle.start != "cycle":
        raise InputError(f"--cycles {path}: settle.start = {cfg.settle.start!r} starts from "
                         "the preloaded equilibrium and reads no cycle; drop --cycles, or set "
                         "settle.start = 'cycle'")
    _check_every_case_is_held(path, cfg)


def _check_every_case_is_held(path: str, cfg: Config) -> None:
    """Every case of ``cfg`` is a case of the limit-cycle file ``path`` (the angles of its
    enabled contacts are a row of its table), else one line naming the cases it does not
    hold and the angles it does: a ``--cycles`` of other angles was silently ignored (each
    cycle computed again). A case it holds without a cycle starts from the preloaded
    equilibrium, its start saying why (:func:`_start`)."""
    import h5py

    from wheelrom.studies.kept_cases import case_numbers

    with h5py.File(path, "r", locking=False) as f:
        g = f["limit_cycle"]
        table = g["angles_deg"][()] if "angles_deg" in g else np.zeros((0, 2))
    configs = expand(cfg).configs
    wanted = [_enabled(c, contact_angles(c)) for c in configs]
    missing = [i for i, angles in enumerate(wanted) if not _rows(table, angles)]
    if not missing:
        return
    held = [_angle_words(dict(zip(("tieboss", "shroud"), row, strict=True))) or "no contacts"
            for row in table]
    holds = f"it holds {'; '.join(held[:3])}{' ...' if len(held) > 3 else ''}" if held else \
        "it holds no case"
    raise InputError(f"--cycles {path}: holds no limit cycle for {case_numbers(missing)} "
                     f"({_angle_words(wanted[missing[0]]) or 'no contacts'}"
                     f"{', ...' if len(missing) > 1 else ''}): {holds}; give the limit-cycle "
                     "file of these angles, or no --cycles (their cycles are then computed "
                     "here)")


def _rows(table: np.ndarray, angles: dict) -> list[int]:
    """The rows of a limit-cycle file's ``angles_deg`` table ``(C, 2)`` (tieboss, shroud;
    NaN for a contact not enabled) at the enabled contacts' ``angles`` [deg]."""
    want = np.array([angles.get("tieboss", np.nan), angles.get("shroud", np.nan)])
    return [i for i, row in enumerate(table)
            if np.allclose(row, want, equal_nan=True, atol=1e-9)]


def _enabled(cfg: Config, angles: dict) -> dict:
    """The angles of the enabled contacts (a limit-cycle file holds NaN for a disabled one)."""
    return {k: v for k, v in angles.items() if cfg.contact(k).enabled}


def _angle_words(angles: dict) -> str:
    """``tieboss 45 deg, shroud 60 deg`` (NaN: a contact not enabled, left out)."""
    return ", ".join(f"{k} {v:g} deg" for k, v in angles.items() if np.isfinite(v))


def _case_waves(g, angles: dict):
    """Per case of a limit-cycle file's ``/limit_cycle`` group ``g`` at ``angles`` (none
    without its table), the list of its wave groups with at least one cycle."""
    if "angles_deg" not in g:
        return
    for i in _rows(g["angles_deg"][()], angles):
        case = g.get(f"case_{i}", {})
        yield [case[n] for n in case if n.startswith("wave_") and "cycles" in case[n]
               and case[n]["cycles"]["tip_amplitude"].shape[0] > 0]


def _cycle_from_file(path: str, angles: dict, blades: int):
    """``(state (2, N, m), frequency [Hz], tip amplitude [m], sliders (K, N, 2) [m] or
    None)`` of the case with ``angles`` in a limit-cycle file: its first exact orbit (under
    the elastic law with its sliders), else its first harmonic-balance cycle (every blade
    from blade 0's harmonics: :func:`~wheelrom.analysis.periodic.harmonic_balance.
    wave_state`); None."""
    import h5py

    with h5py.File(path, "r", locking=False) as f:
        for waves in _case_waves(f["limit_cycle"], angles):
            for w in waves:
                c = w["cycles"]
                for j in range(c["tip_amplitude"].shape[0]):
                    if "orbit_state" in c and np.all(np.isfinite(c["orbit_state"][j])):
                        state = c["orbit_state"][j]
                        every = np.arange(blades) % state.shape[1]
                        sliders = c["orbit_sliders"][j][:, every] if "orbit_sliders" in c \
                            else None
                        return (state[:, every], 1.0 / c["orbit_period"][j],
                                c["tip_amplitude"][j], sliders, _largest_multiplier(c, j))
            for w in (w for w in waves if "harmonics" in w["cycles"]):  # no exact orbit: the
                c = w["cycles"]                                         # balance's cycle
                hz = float(c["frequency_hz"][0])
                q, v = wave_state(c["harmonics"][0], int(w.attrs["wave"]), blades,
                                  2 * math.pi * hz)
                return np.stack([q, v]), hz, c["tip_amplitude"][0], None, math.nan
    return None


def band_from_file(path: str, angles: dict) -> tuple[float, float, float, int] | None:
    """``(smallest, largest, orbit [m], nodal diameter)``: the band of the first exact orbit
    with one of the case with ``angles`` in a limit-cycle file (under the elastic law: its
    friction-limited orbits over the stuck contacts' offsets,
    :mod:`~wheelrom.analysis.periodic.family`) and its wave's ND; None without."""
    import h5py

    with h5py.File(path, "r", locking=False) as f:
        for wave in (w for waves in _case_waves(f.get("limit_cycle", {}), angles)
                     for w in waves):
            c = wave["cycles"]
            for row in (c["band"][()] if "band" in c else ()):
                if np.all(np.isfinite(row)):
                    return (float(row[0]), float(row[1]), float(row[2]),
                            int(wave.attrs.get("nodal_diameter", -1)))
    return None


#: the keys that choose how a case's motion started, not its wheel: cases that differ only in
#: them are histories of one case, whose friction-limited ends may differ under the elastic law
#: (docs/theory.md "Why the friction-limited amplitude is a band")
HISTORY_KEYS = ("settle.start", "settle.seed", "settle.seed_amplitude", "settle.perturbation")


def histories(rows: list[dict], band_of=None) -> list[dict]:
    """The cases of :func:`summary` ``rows`` that are histories of one case (the same angles
    and parameters but :data:`HISTORY_KEYS`), two or more a group: per group its ``label``
    (the case's), ``members`` (row indices), each member's ``history`` (its keys in words)
    and range ``(low, high)`` [m] (the largest blade over the last span, or its settled
    amplitude), the ``spread`` (lowest low, highest high) [m], and with ``band_of(angles)``
    (:func:`band_from_file`) the ``band`` and each member's place against it: ``"inside"``,
    ``"above"``, ``"below"`` or ``"across"`` its edges; ``nd``: each member's dominant ND and
    its energy share in the last window (``(-1, 0)``: not known)."""
    groups: dict[str, tuple[dict, list[int]]] = {}
    for i, row in enumerate(rows):
        case = {k: v for k, v in row["parameters"].items() if k not in HISTORY_KEYS}
        key = repr((sorted(row["angles_deg"].items()), sorted(case.items())))
        groups.setdefault(key, (case, []))[1].append(i)
    out = []
    for case, members in groups.values():
        if len(members) < 2:
            continue
        first = rows[members[0]]
        label = ", ".join([first["label"], *(f"{k} {v}" for k, v in case.items()
                                             if k not in ("contacts.tieboss.angle_deg",
                                                          "contacts.shroud.angle_deg"))])
        ranges, words, waves = [], [], []
        for i in members:
            row = rows[i]
            energy = row.get("nd_energy") or []
            waves.append((int(np.argmax(energy)), float(max(energy))) if energy else (-1, 0.0))
            span = row.get("band_m")
            if span is not None:
                ranges.append((span["low"], span["high"]))
            elif "amplitude_m" in row:
                ranges.append((row["amplitude_m"]["max"],) * 2)
            else:
                ranges.append((math.nan, math.nan))
            keys = {k: v for k, v in row["parameters"].items() if k in HISTORY_KEYS}
            words.append(", ".join(f"{k.split('.')[-1]} {v}" for k, v in keys.items())
                         or row.get("start", ""))
        lows, highs = np.array([r[0] for r in ranges]), np.array([r[1] for r in ranges])
        group = {"label": label, "members": members, "history": words,
                 "range_m": ranges, "nd": waves,
                 "spread_m": (float(np.nanmin(lows)), float(np.nanmax(highs)))
                 if np.any(np.isfinite(lows)) else (math.nan, math.nan)}
        band = band_of(first["angles_deg"]) if band_of is not None else None
        if band is not None:
            group["band_m"] = band
            group["place"] = [_place(r, band) for r in ranges]
        out.append(group)
    return out


def _place(span: tuple[float, float], band: tuple) -> str:
    """Where a history's range ``(low, high)`` [m] lies against a band ``(low, high, ...)``."""
    low, high = span
    if not (math.isfinite(low) and math.isfinite(high)):
        return "unknown"
    if low >= band[0] and high <= band[1]:
        return "inside"
    if low > band[1]:
        return "above"
    if high < band[0]:
        return "below"
    return "across"


def history_words(group: dict) -> str:
    """One group of :func:`histories` in words."""
    low, high = group["spread_m"]
    text = (f"histories of {group['label']}: {len(group['members'])} end at "
            f"{low * 1e6:.3g}-{high * 1e6:.3g} um (" + "; ".join(
                f"{w}: {r[0] * 1e6:.3g}-{r[1] * 1e6:.3g}"
                for w, r in zip(group["history"], group["range_m"], strict=True)) + ")")
    if "band_m" in group:
        b = group["band_m"]
        places = group["place"]
        inside = places.count("inside")
        text += (f"; the band of its friction-limited orbits {b[0] * 1e6:.3g}-"
                 f"{b[1] * 1e6:.3g} um holds {inside} of them")
        wave = b[3]
        outside = [(w, p, nd) for w, p, nd in zip(group["history"], places, group["nd"],
                                                  strict=True) if p != "inside"]
        left = [(w, p, nd) for w, p, nd in outside if wave >= 0 and nd[0] not in (-1, wave)]
        kept = [(w, p, nd) for w, p, nd in outside if (w, p, nd) not in left]
        if left:  # another ND took the energy: the band's wave is unstable in the whole wheel
            text += ("; " + ", ".join(f"{w} {p}, ND {nd[0]} {nd[1]:.0%}" for w, p, nd in left)
                     + f": the flutter left the band's wave (ND {wave}) for another, its orbits "
                     "unstable in the whole wheel")
        if kept:  # the same wave, other offsets: blades that slipped differently
            text += ("; " + ", ".join(f"{w} {p}" for w, p, _ in kept) + ": in the band's wave,"
                     " its blades slipping differently (offsets outside the band's "
                     "pattern-symmetric ones)")
    return text


def _largest_multiplier(c, j: int) -> float:
    """The largest non-trivial multiplier modulus that made cycle ``j`` of a limit-cycle
    file's ``cycles`` group ``c`` unstable (``floquet_multiplier`` where ``stable`` is 0: the
    in-symmetry one at the finest step or the whole wheel's); NaN for a cycle stable,
    uncertain or not examined (no hold: a neutral phase shift's 1 is no instability)."""
    if "stable" not in c or "floquet_multiplier" not in c or int(c["stable"][j]) != 0:
        return math.nan
    return float(c["floquet_multiplier"][j])


def unstable_hold(multiplier: float, frequency_hz: float, perturbation: float) -> float:
    """The time [s] a perturbation of relative size ``perturbation`` needs to grow to the
    orbit's own size at ``multiplier`` per period of ``frequency_hz`` (0 when the multiplier
    is not above 1 or not known): before it, the windows of a start on an unstable orbit are
    stationary only because the departure has not grown yet (the paper wheel at 75 deg,
    1.0141 per period at 139.5 Hz: "settled" after 1 s on the orbit, left it at 1.5 s)."""
    if not (multiplier > 1.0 and perturbation > 0.0):
        return 0.0
    return math.log(1.0 / perturbation) / (math.log(multiplier) * frequency_hz)


def _start(model, cfg: Config, angles: dict, cycles_file: str | None, comm=None):
    """``(u0, frequency [Hz], words, cycle tip amplitude [m] or nan, hold [s])`` of one case's
    start (``hold``: on an orbit the file says is unstable, the time before which the case
    is not called settled, :func:`unstable_hold`; else 0),
    the perturbation added: ``u0`` the modal ``(q, q')`` ``(2 N m,)``, and under the elastic
    law from the preloaded equilibrium the whole state with its sliders at rest at the
    equilibrium (``(2 N m + 4 + 2 K N,)``: the seed is then a solution of the stuck
    linearisation; at rest at the seeded state they would offset the stuck springs by the
    seed itself and ring the stuck modes at its size)."""
    from wheelrom.analysis.periodic.limit_cycle import case_limit_cycles
    from wheelrom.analysis.periodic.limit_cycle import settings_of as lc_settings
    from wheelrom.transient.preload import start_perturbation

    st, N = cfg.settle, model.blades
    found, no_cycle = None, ""
    if st.start == "cycle" and cycles_file:
        # the file holds the angles of the enabled contacts only (NaN for a disabled one)
        found = _cycle_from_file(cycles_file, _enabled(cfg, angles), N)
        words = f"the exact orbit in {os.path.basename(cycles_file)}"
        if found is None:  # its continuation found none: the preload, said so
            no_cycle = f" ({os.path.basename(cycles_file)} holds no cycle at these angles)"
    if st.start == "cycle" and found is None and not cycles_file:
        lc = dataclasses.replace(lc_settings(cfg, (-1,)), method="shooting", floquet="off",
                                 refine=0)
        res = case_limit_cycles(model, cfg, lc, angles, comm)
        for branch in res.branches:
            for c in branch.cycles:
                if found is None and c.orbit is not None:
                    found = (c.orbit.wheel_state(N), c.frequency_hz, c.tip_amplitude,
                             c.orbit.wheel_sliders(N), math.nan)
                    words = f"the exact orbit of wave {branch.wave}"
    hold = 0.0
    if found is not None:
        state, frequency, amplitude, sliders, multiplier = found
        u0 = state.reshape(2, -1)
        q0 = u0[0].reshape(N, -1)
        seed = amplitude * st.perturbation
        hold = unstable_hold(multiplier, frequency, st.perturbation)
    else:  # the preloaded equilibrium, the unstable waves' growing modes seeded
        from wheelrom.analysis.periodic.hopf import unstable_seed, wave_blocks
        from wheelrom.analysis.stability import linearise

        params, q, _, J, _ = linearise(model, cfg, angles, comm)
        B0, B1 = wave_blocks(model, params, q, J)
        size, why = st.seed_amplitude, ""
        if cfg.contacts.elastic:
            size, why = _below_slip_onset(model, cfg, angles, q, B0, B1, size)
        unstable, dq, dv, fastest = unstable_seed(model, B0, B1, size, st.seed)
        frequency = float(fastest.imag) / (2 * math.pi)
        q0 = q + dq
        u0 = np.stack([q0.ravel(), dv.ravel()])
        seed = size * st.perturbation
        amplitude = math.nan
        words = (f"the preloaded equilibrium{no_cycle}, the growing modes of waves {unstable} "
                 f"seeded at {size:.3g} m{why}")
    every = cfg.replace(**{"time.perturbation": seed, "time.perturbation_waves": [],
                           "time.seed": st.seed})
    u0 = u0.copy()
    u0[0] = (q0 + start_perturbation(model, every)).ravel()
    u0 = u0.ravel()
    if cfg.contacts.elastic:  # the whole state: q, q', 4 work integrals, sliders
        from wheelrom.forces.parameters import force_parameters
        from wheelrom.forces.reference import ReferenceForces

        if found is None:  # at rest at the equilibrium: the seed solves the stuck equations
            sliders = ReferenceForces(params).sliders_at_rest(q)
        elif sliders is None:  # a harmonic-balance cycle holds none: at rest at its start
            sliders = ReferenceForces(force_parameters(model, cfg, angles)).sliders_at_rest(
                np.ascontiguousarray(q0))
            words += " (its sliders at rest there: the cycle file holds none)"
        u0 = np.concatenate([u0, np.zeros(4), np.ravel(sliders)])
    words = f"{words}, every ND perturbed at {seed:.3g} m (seed {st.seed})"
    if hold > 0:
        words += (f"; not called settled before {hold:.2g} s (its multiplier {multiplier:.5g} "
                  "per period grows that perturbation to the orbit's size by then)")
    return u0, frequency, words, float(amplitude), hold


def _below_slip_onset(model, cfg, angles, q, B0, B1, size: float) -> tuple[float, str]:
    """``(seed [m], why)``: under the elastic law the seed at most half the fastest wave's
    slip onset (:meth:`~wheelrom.analysis.periodic.slider_shooting.SliderShooting.
    slip_onset`): a flutter that grows from small disturbances never slips a contact that
    sticks on its bounded state; a seed above that state slips it on the way down and locks a
    tangential prestress into it, and the wheel settles elsewhere (measured on the paper
    wheel at 70 deg, 3 s: seeded at 1 um, 0.43-0.45 um in ND 31 47 %; at 0.1 um, 0.35-0.40 um
    in ND 33 82 %, its exact orbit 0.369 um)."""
    from wheelrom.analysis.periodic.hopf import wave_mode
    from wheelrom.analysis.periodic.slider_shooting import SEED_FRACTION, SliderShooting

    modes = [wave_mode(B0[k], B1[k], 1.0) for k in range(model.blades)]
    k = int(np.argmax([growth for growth, _, _ in modes]))
    shooting = SliderShooting(model, cfg, k, angles)
    try:
        onset = shooting.slip_onset(q, modes[k][2])
    finally:
        shooting.destroy()
    if not 0 < SEED_FRACTION * onset < size:  # nothing slips below the configured seed
        return size, ""
    return SEED_FRACTION * onset, (f" (half the stuck mode's slip onset, below "
                                   f"settle.seed_amplitude = {size:g} m)")


# ------------------------------------------------------------------ the output
def resume_problem(path: str, cfg: Config) -> str | None:
    """Why ``--resume`` must not go on with the existing file at ``path`` (None: it may):
    ``--resume`` continues the cases kept beside a settle file not yet written, so any file
    already there is refused, only ``--force`` replaces it: another command's (the user's
    work), a settle file of another configuration (another run's), or one of this
    configuration (written once every case was done: nothing is left to resume)."""
    import h5py

    from wheelrom.results.info import kind_of
    from wheelrom.results.layout import config_changes
    from wheelrom.results.settle import FORMAT

    fmt, kind = kind_of(path)
    if fmt != FORMAT:
        return (f"--out {path}: is {kind}, not a settle file: --resume completes only a "
                "settle file; choose another --out, or --force to replace it")
    with h5py.File(path, "r", locking=False) as f:
        changed = config_changes(f.attrs.get("config"), cfg)
    if changed:
        return (f"--out {path}: was written for a different configuration ({changed}); "
                "choose another --out, or --force to replace it")
    return (f"--out {path}: already holds every case of this configuration (a settle file is "
            "written once all are done): nothing to resume; --force computes it again")


# ------------------------------------------------------------------ the cases
def run_settle(cfg: Config, out: str | None, comm=None, log=print, resume: bool = False,
               cycles_file: str | None = None, progress=None, warn=print):
    """``(model, [(angles, parameters, Settled)], folder)``: every case on rank 0 (others:
    the model and ``[]``) and the :class:`~wheelrom.studies.kept_cases.KeptCases` of ``out``
    (None without). ``warn``: a damaged saved case (rank 0 reads them). ``--resume``
    reuses a batch (``settle.batch``) whose every case was kept, and runs one kept in part
    again whole: a batch's windows depend on its members."""
    study = expand(cfg)
    rank = comm.rank if comm is not None else 0
    say = log if rank == 0 and log is not None else (lambda *_: None)
    model_of, models = shared_models(study.configs, comm, say)
    if not all(m.tuned for m in models):
        raise InputError("settle: the start from a travelling-wave cycle needs a tuned wheel")
    folder = kept_folder(out) if out else None
    mine, problem, unsaved = [], None, []
    labels = [f"[case {i}/{study.size - 1}] " + ", ".join(
        f"{short_name(k)} {v:g}" if isinstance(v, float) else f"{short_name(k)} {v}"
        for k, v in zip(study.names, study.values[i], strict=True)) for i in range(study.size)]

    def keep(i: int, done: Settled) -> None:
        parameters = dict(zip(study.names, study.values[i], strict=True))
        mine.append((i, contact_angles(study.configs[i]), parameters, done))
        say(f"{labels[i]}: {done.verdict()} ({done.wall_s:.1f} s)")

    # the batches of every case, the same whatever the number of ranks or what an interrupted
    # run kept (a batch's members decide its windows)
    plan = batches(list(range(study.size)), [batch_key(c) for c in study.configs],
                   cfg.settle.batch)
    kept: dict[int, Settled] = {}
    if resume and folder and rank == 0:  # one rank reads what is kept: the plan is its
        for i in range(study.size):      # (another rank could already be saving a case)
            done = load_case(folder, i, study.configs[i], warn)
            if done is not None:
                kept[i] = done
    whole = [b for b in plan if all(i in kept for i in b)]  # a batch kept whole is reused;
    for i in sorted(i for b in whole for i in b):           # one kept in part runs again
        say(f"{labels[i]}: kept from the interrupted run")
        keep(i, kept[i])
    todo = [b for b in plan if b not in whole]  # handed to the ranks as they become free
    if comm is not None:
        todo = comm.bcast(todo)
    queue = CaseQueue(len(todo), comm)
    try:
        for j in queue:
            chunk = todo[j]
            results = _settle_batch(models[model_of[chunk[0]]],
                                    [study.configs[i] for i in chunk],
                                    [contact_angles(study.configs[i]) for i in chunk], cycles_file,
                                    [labels[i] for i in chunk],
                                    progress if rank == 0 else None)
            for i, done in zip(chunk, results, strict=True):
                if folder:
                    save_or_keep(folder, i, study.configs[i], done, unsaved)
                keep(i, done)
    except InputError as exc:  # e.g. a window longer than max_time: told to every rank below
        problem = exc
    if comm is not None:  # polled: a rank waiting for a killed one still takes mpirun's
        wait_for_all(comm)  # SIGTERM, and says what is kept (a blocking gather never returns)
    gathered = comm.gather((mine, problem), root=0) if comm is not None else [(mine, problem)]
    queue.free()
    ordered = []
    if rank == 0:
        problem = next((p for _, p in gathered if p is not None), None)
        ordered = sorted((it for part, _ in gathered for it in part), key=lambda it: it[0])
    agree(comm, problem)  # every rank stops together: none waits for one that stopped
    return models[0], [(a, p, r) for _, a, p, r in ordered], folder


def _settle_batch(model, cfgs: list[Config], angles: list[dict], cycles_file, labels,
                  progress) -> list[Settled]:
    """Cases of one batch key (:func:`~wheelrom.config.study.batch_key`: they differ in their
    contact ``angles`` only): each one's start, then the cases whose start was found
    integrated together (:func:`~wheelrom.analysis.periodic.settle.settle_cases`); a case
    without a start is named failed, the others go on. Each at its ``settle.step`` where it
    is set (the cases keep their own configuration: the kept cases' digests)."""
    t0 = time.perf_counter()
    cfgs = [at_settle_step(c) for c in cfgs]
    out: list[Settled | None] = [None] * len(cfgs)
    starts, settings = {}, {}
    for b, cfg in enumerate(cfgs):
        try:
            starts[b] = _start(model, cfg, angles[b], cycles_file)
        except Exception as exc:  # the case is named failed, the others go on
            why = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
            out[b] = Settled(False, 0.0, status=f"failed: no start ({why})")
            continue
        hold, settings[b] = starts[b][4], settings_of(cfg)
        if hold > settings[b].min_time:  # the departure from an unstable orbit first has to grow
            settings[b] = dataclasses.replace(settings[b],
                                              min_time=min(hold, settings[b].max_time))
    started = list(starts)

    def say(j, t, w):
        if progress:  # the first window has no window before it to change against
            change = (f"window change {max(w.change):.2%}" if math.isfinite(max(w.change))
                      else "first window")
            progress(f"{labels[started[j]]}: {t:.3g} s, largest blade "
                     f"{w.amplitude.max() * 1e6:.3g} um, {change}")

    if started:
        done = settle_cases(model, cfgs[started[0]], [angles[b] for b in started],
                            [starts[b][0] for b in started], [starts[b][1] for b in started],
                            [settings[b] for b in started], cfgs[started[0]].settle.nozzle,
                            say)
        for b, result in zip(started, done, strict=True):
            result.start, result.start_amplitude = starts[b][2], starts[b][3]
            out[b] = result
    wall = (time.perf_counter() - t0) / len(cfgs)
    for result in out:
        result.wall_s = wall
    return out


def summary(angles: dict, parameters: dict, r: Settled) -> dict:
    """One case as plain data (``settle --json``)."""
    c = r.classification
    label = ", ".join(f"{k} {v:g} deg" for k, v in angles.items())
    out = {"label": label, "angles_deg": angles, "parameters": parameters,
           "verdict": r.verdict(), "settled": r.settled, "bounded": r.bounded,
           "simulated_s": r.time,
           "status": r.status, "start": r.start, "wall_s": r.wall_s,
           "windows": len(r.windows), "step_s": r.step if math.isfinite(r.step) else None,
           "step_lowered": r.step_lowered}
    trend = r.trend()
    if trend is not None:
        out["trend_per_s"] = {"rate": trend.rate, "error": trend.error,
                              "correlation": trend.correlation, "windows": trend.windows}
    band = None if r.settled else r.band()
    if band is not None:
        out["band_m"] = {"low": band[0], "high": band[1], "over_s": band[2]}
    if c is not None:
        out.update({
            "kind": c.kind, "decided_by": c.decided_by, "frequency_hz": c.frequency_hz,
            "modulation_hz": c.modulation_hz if math.isfinite(c.modulation_hz) else None,
            "modulation_depth": c.modulation_depth})
    if r.amplitude.size:
        A = r.amplitude
        out.update({
            "amplitude_m": {"max": float(A.max()), "mean": float(A.mean()),
                            "min": float(A.min()), "max_blade": int(np.argmax(A)),
                            "min_blade": int(np.argmin(A))},
            "nd_energy": [float(e) for e in r.nd_energy],
            "energy_balance": r.energy_balance,
            "contacts": [{"open": float(f[0]), "micro_slip": float(f[1]), "slip": float(f[2]),
                          "normal_force_min_n": float(n[0]), "normal_force_max_n": float(n[1])}
                         for f, n in zip(r.fractions, r.normal_force_range, strict=True)],
        })
    return out
