"""Design studies across MPI ranks (``wheelrom study``): the linear stability of every case,
then transients of all cases (``full``), of the cases that decide the picture (``screen``:
both sides of every stability boundary, plus the ones the user lists) or of none
(``stability``), into one file of format ``wheelrom-sweep-2``
(:mod:`wheelrom.results.study_layout`).

Each reduced model is built once, by one rank (group ``g`` by rank ``g mod P``), and
broadcast; a case's stability and transient are computed by one rank on ``COMM_SELF`` with
the model of its group, so every number in the file is the same for any rank count. Cases are
dealt longest first to the least loaded rank (cost ~ the model's size, and the number of TS
steps for a transient); a rank integrates its cases in TS batches of cases that differ only
in their contact angles. Transients run in rounds as in ``sweep``: after every round the
file is flushed collectively, so a killed study keeps its finished rounds and ``--resume``
runs the cases still pending.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
import time

from wheelrom.config import Config
from wheelrom.config.study import Study, batch_key, expand, model_key
from wheelrom.results import layout as results
from wheelrom.results import study_layout as study_file
from wheelrom.results.info import resume_hint, study_flags
from wheelrom.rom.build import build_model
from wheelrom.runtime import interrupts
from wheelrom.runtime.environment import petsc, slepc
from wheelrom.runtime.errors import InputError, Interrupted
from wheelrom.runtime.locks import output_lock
from wheelrom.runtime.outputs import (
    create_collectively,
    output_problem,
    save_hdf5,
)
from wheelrom.studies import design_cases
from wheelrom.studies.forced_nonlinear import (
    check_nonlinear_memory,
    design_arrays,
    design_point,
    nonlinear_inputs_problem,
)
from wheelrom.studies.mistuning import (
    ForcedCases,
    analyse_case,
    case_mistuning,
    case_model,
    forced_arrays,
)
from wheelrom.studies.plan import balance, batches, group_by, selection
from wheelrom.studies.rounds import _mpi_op, check_space_collectively, run_rounds, wait_for_all
from wheelrom.studies.stability import attach_classification
from wheelrom.transient.run import check_run_memory, run_cases
from wheelrom.transient.ts import PREFIX, time_grid, ts_settings

HISTORY_BYTES = 1 << 30  # tip histories a rank holds in one batch by default (1 GiB)


def run_study(cfg: Config, out: str, comm, mode: str = "full", confirm: tuple = (),
              resume: bool = False, force: bool = False, log=print,
              options: dict | None = None, batch: int = 0,
              forced: bool = False, nonlinear: bool = False) -> dict:
    """Run the study of ``cfg`` into ``out`` (collective over the mpi4py ``comm``); returns
    :func:`wheelrom.results.study_layout.summary` of the file (on every rank).

    ``mode``: ``full``, ``screen`` or ``stability`` (module docstring); ``confirm``: case
    indices the screen runs in any case; ``batch``: cases per TS (0: all of a rank's cases
    that can share one, up to ``HISTORY_BYTES`` of tip histories); ``forced``: also the
    peak forced response of every case and its amplification factor
    (:mod:`wheelrom.studies.mistuning`); ``nonlinear``: also the nonlinear forced response of
    every case over its band with its refined peak, the friction damper's design curve
    (:mod:`wheelrom.studies.forced_nonlinear`). Raises :class:`Interrupted` after a Ctrl-C / SIGTERM
    once the finished rounds are in the file. ``out`` is locked for the whole study
    (:func:`wheelrom.runtime.locks.output_lock`): another job on it is refused before
    anything is computed.
    """
    with output_lock(out, comm):
        return _study(cfg, out, comm, mode, confirm, resume, force, log, options, batch,
                      (forced, nonlinear))


def _study(cfg: Config, out: str, comm, mode: str, confirm: tuple, resume: bool, force: bool,
           log, options: dict | None, batch: int, extras: tuple) -> dict:
    forced, nonlinear = extras
    petsc()  # PetscInitialize is collective: every rank before one builds alone
    slepc()
    say = log if comm.rank == 0 else (lambda *_: None)
    _check_arguments(mode, resume, force, batch)
    study = expand(cfg)
    if any(not 0 <= i < study.size for i in confirm):
        raise InputError(f"--confirm: case indices are 0..{study.size - 1}, got "
                         f"{', '.join(map(str, confirm))}")
    _check_cases(study, mode, batch, extras)
    settings = ts_settings(cfg, PREFIX, options)
    if len(json.dumps(settings)) > results.STATUS_LEN:
        raise InputError("too many TS options to record: pass fewer -wheel_ts_* options")
    problem = None
    if comm.rank == 0:
        try:
            problem = _output_problem(out, cfg, mode, resume, force,
                                      None if "time.step" in study.names else settings, extras,
                                      study.configs)
        except Exception as exc:  # rank 0's surprise must not leave the others waiting
            problem = InputError(f"{out}: cannot be checked for --resume ({exc})")
    problem = comm.bcast(problem)
    if problem:
        raise problem
    t0 = time.perf_counter()
    model_of, members = group_by([model_key(c) for c in study.configs])
    shape = " x ".join(map(str, study.shape))
    say(f"study: {study.size} cases of {', '.join(study.names)} ({shape}), {len(members)} "
        f"model(s), {comm.size} rank(s)")
    fresh = not (resume and os.path.exists(out))
    kept = design_cases.kept_folder(out)  # the finished nonlinear curves of this study
    if comm.rank == 0 and nonlinear and fresh and not resume:
        kept.clear()  # an earlier run's, discarded (--force; else refused above)
    wait_for_all(comm)
    if fresh:
        models = _models(study, members, range(len(members)), comm, say)
        check_space_collectively(out, _transient_bytes(cfg, study, models, mode), comm)
        t1 = time.perf_counter()
        try:
            stability, peaks, design = _stability(study, models, model_of, comm, say, extras,
                                                  (kept, resume))
        except KeyboardInterrupt:
            if not nonlinear:
                raise
            raise Interrupted(f"interrupted: the finished nonlinear forced responses are kept "
                              f"in {kept.path}; the same command with --resume reads them") \
                from None
        took = time.perf_counter() - t1
        chosen = selection(_labels(stability), study.shape, confirm, mode)
        say(f"stability{_extra_words(extras)} of {study.size} cases in {took:.1f} s "
            f"({study.size / took:.3g} cases/s on {comm.size} rank(s); models "
            f"{t1 - t0:.1f} s); {sum(c != 'none' for c in chosen)} case(s) selected for a "
            "transient")
        extra = {"mistuning": case_mistuning(study, models[0].blades), "forced": peaks,
                 "forced_nonlinear": design}
        _create(out, cfg, study, models, model_of, stability, chosen, mode, comm, extra)
        if comm.rank == 0 and nonlinear:
            kept.clear()  # every curve is in the file now
    stopped = mode != "stability" and _transients(out, cfg, study, model_of, members, comm,
                                                  batch, options, say, settings,
                                                  models if fresh else None)
    wait_for_all(comm)
    import h5py

    with h5py.File(out, "r", locking=False) as f:
        done = study_file.summary(f)
    if stopped:
        hint = resume_hint(out, cfg.source, done["transients"], "study",
                           study_flags(mode, forced, nonlinear))
        raise Interrupted(f"interrupted: the finished rounds are saved in {out}; {hint}")
    say(f"study finished in {time.perf_counter() - t0:.1f} s")
    return done


def _check_cases(study: Study, mode: str, batch: int, extras: tuple) -> None:
    """What the cases ask that cannot be done, refused before anything is computed (each
    was stored as every case's failure, exit 0): a forced response without a nozzle force, a
    nonlinear one on a mistuned wheel, a transient or a nonlinear curve that does not fit in
    the memory."""
    forced, nonlinear = extras
    checks = [("--forced", forced, _no_force),
              ("--forced-nonlinear", nonlinear, nonlinear_inputs_problem)]
    for option, asked, problem in checks:
        found = [(i, why) for i, why in enumerate(map(problem, study.configs)) if why] \
            if asked else []
        if found:
            i, why = found[0]
            which = "every case" if len(found) == study.size and len({w for _, w in found}) \
                == 1 else f"case {i} ({study.label(i)})"
            raise InputError(f"study {option}, {which}: {why}")
    if nonlinear:  # the grid of forced.points (at least 3) and the band's two resonances
        for case in {(c.forced, c.wheel, c.contacts): c for c in study.configs}.values():
            f = case.forced
            check_nonlinear_memory(case, f.harmonics, max(f.points, 3) + 2,
                                   f"study --forced-nonlinear at forced.harmonics {f.harmonics}"
                                   f" over forced.points {f.points}")
    if mode != "stability":  # every case's transient fits (a batch of them at once)
        sized = {(c.time, c.output, c.wheel, tuple(c.contacts.enabled_kinds())): c
                 for c in study.configs}  # what a run's memory depends on
        for case in sized.values():
            check_run_memory(case, min(batch, study.size) or 1)


def _no_force(cfg: Config) -> str | None:
    """Why a linear forced response of ``cfg`` is nothing to compute (None: it is)."""
    if cfg.excitation.force <= 0:
        return "excitation.force = 0: the nozzle force is off, nothing is forced"
    return None


def _check_arguments(mode: str, resume: bool, force: bool, batch: int) -> None:
    if mode not in study_file.MODES:
        raise InputError(f"study mode must be one of {', '.join(study_file.MODES)}, not {mode!r}")
    if resume and force:
        raise InputError("--resume and --force exclude each other (complete the file, or "
                         "start it again)")
    if batch < 0:
        raise InputError(f"--batch {batch}: must be >= 0 (0: every case of a rank that fits)")


def _output_problem(out: str, cfg: Config, mode: str, resume: bool, force: bool,
                    settings: dict | None, extras: tuple, configs: list) -> InputError | None:
    """Why ``out`` must not be written (None: go ahead); ``settings``: the TS settings the
    finished cases must have used (None: not checked, a study of ``time.step``). A study
    that will compute nonlinear curves (``extras[1]``, its file not there yet) keeps them
    in a folder beside ``out``, checked as every such folder is
    (:meth:`~wheelrom.studies.kept_cases.KeptCases.problem`; ``configs``: its cases)."""
    problem = output_problem(out, force=resume or force)
    if problem is None and extras[1] and not (resume and os.path.exists(out)):
        problem = design_cases.kept_folder(out).problem(configs, resume, force)
    if problem or not (resume and os.path.exists(out)):
        return problem
    why = study_file.resume_problem(out, cfg, mode, *extras)
    if why is None and mode != "stability" and settings is not None:
        why = results.options_problem(out, settings)
    return InputError(why) if why else None


def _models(study: Study, members: list[list[int]], wanted, comm, say) -> list:
    """The reduced model of every group in ``wanted`` (else None): group ``g`` built by rank
    ``g mod P`` on ``COMM_SELF`` (the ranks build their groups at the same time), then
    broadcast from there."""
    built, failure = {}, None
    for g, cases in enumerate(members):
        if g in wanted and g % comm.size == comm.rank and failure is None:
            try:  # tuned: every case puts its own mistuning on it (case_model)
                built[g] = dataclasses.replace(build_model(study.configs[cases[0]],
                                                           petsc().COMM_SELF), mistuning=None)
            except Exception as exc:  # told to every rank: no rank waits for a lost model
                failure = f"model {g + 1} (case {cases[0]}: {study.label(cases[0])}): {exc}"
    wait_for_all(comm)
    failures = [f for f in comm.allgather(failure) if f]
    if failures:
        raise InputError("; ".join(failures)[:2000])
    models = [comm.bcast(built.get(g), root=g % comm.size) if g in wanted else None
              for g in range(len(members))]
    for g, model in enumerate(models):
        if model is not None:
            say(f"model {g + 1}/{len(members)} ({len(members[g])} case(s)): {model.blades} "
                f"blades x {model.modes} modes, built by rank {g % comm.size} in "
                f"{model.info['build_s']:.1f} s")
    return models


def _stability(study: Study, models: list, model_of: list[int], comm, say,
               extras: tuple = (False, False), kept: tuple = (None, False)) -> tuple:
    """``/stability`` of every case
    (:func:`wheelrom.results.study_layout.stability_arrays`), ``/forced``
    (:func:`wheelrom.studies.mistuning.forced_arrays`) when ``extras[0]`` and
    ``/forced_nonlinear`` (:func:`wheelrom.studies.forced_nonlinear.design_arrays`) when
    ``extras[1]`` (else None) on every rank: each rank analyses its share (balanced by model
    size; the nonlinear curves weigh most), rank 0 assembles. ``kept = (folder, resume)``:
    each nonlinear curve is saved in the folder as it finishes, and with ``resume`` read
    from it instead of computed (:mod:`wheelrom.studies.design_cases`)."""
    forced, nonlinear = extras
    costs = [models[g].blades * models[g].modes ** 3 for g in model_of]
    mine = balance(costs, comm.size)[comm.rank]
    peaks = ForcedCases(study, models, model_of) if forced else None
    found, last = [], time.perf_counter()
    for k, i in enumerate(mine):
        found.append((i, *analyse_case(study, models, model_of, i, peaks),
                      _design_point(study, models, model_of, i, *kept, say)
                      if nonlinear else None))
        if time.perf_counter() - last > 2.0 or k == len(mine) - 1:
            last = time.perf_counter()
            say(f"  stability{_extra_words(extras)}: {k + 1}/{len(mine)} of rank 0's cases")
    wait_for_all(comm)
    gathered = comm.gather(found, root=0)
    arrays = None
    if comm.rank == 0:
        ordered = sorted((item for part in gathered for item in part), key=lambda it: it[0])
        arrays = (study_file.stability_arrays([it[1] for it in ordered]),
                  forced_arrays([it[2] for it in ordered], study, models[0].blades)
                  if forced else None,
                  design_arrays([it[3] for it in ordered]) if nonlinear else None)
    return comm.bcast(arrays)


def _design_point(study: Study, models: list, model_of: list[int], i: int, folder,
                  resume: bool, say):
    """Case ``i``'s :func:`wheelrom.studies.forced_nonlinear.design_point` (read from
    ``folder`` with ``resume`` when a finished one of the same configuration is there,
    else computed and saved there), or the text of its failure (recorded; never a hang of
    the other ranks)."""
    point = design_cases.load_point(folder, i, study.configs[i], warn) if resume else None
    if point is not None:
        say(f"  case {i}: its nonlinear forced response kept from the interrupted run")
        return point
    try:
        point = design_point(case_model(models, model_of, study, i), study.configs[i])
    except Exception as exc:
        return f"{type(exc).__name__}: {exc}"
    try:
        if not design_cases.save_point(folder, i, study.configs[i], point):
            warn(f"{folder.path}: the disk is full; case {i}'s curve is kept in memory only")
    except OSError as exc:
        warn(f"{folder.path}: case {i}'s curve not saved ({exc}); kept in memory only")
    return point


def warn(message: str) -> None:
    """A warning from any rank (stderr: rank 0's log is not every rank's)."""
    print(f"wheelrom: warning: {message}", file=sys.stderr, flush=True)


def _extra_words(extras: tuple) -> str:
    forced, nonlinear = extras
    return " and forced response" * forced + " and nonlinear forced response" * nonlinear


def _labels(stability: dict) -> list[str]:
    return [v.decode().partition(":")[0] for v in stability["verdict"]]


def _create(out, cfg, study, models, model_of, stability, chosen, mode, comm,
            extra: dict) -> None:
    """The file with its full layout (serially by rank 0 for ``stability``, else
    collectively), under a temporary name renamed into place when complete; ``extra``:
    :func:`wheelrom.results.study_layout.create`'s ``mistuning`` and ``forced``."""

    if mode == "stability":
        failure = None
        if comm.rank == 0:  # built in memory: a full disk keeps it in $TMPDIR
            failure = save_hdf5(out, lambda f: study_file.create(
                f, cfg, study, models, model_of, stability, chosen, mode, **extra),
                "")
        wait_for_all(comm)
        failure = comm.bcast(failure)
        if failure:
            raise failure
        return
    create_collectively(out, comm, lambda f: study_file.create(f, cfg, study, models, model_of,
                                                               stability, chosen, mode, **extra))


def _transients(out, cfg, study, model_of, members, comm, batch, options, say, settings,
                models) -> bool:
    """Run the pending cases of the file in rounds (module docstring); returns whether a stop
    was requested."""
    import h5py

    with h5py.File(out, "r", locking=False) as f:  # every rank reads the same statuses
        status = results.statuses(f)
    todo = [i for i, s in enumerate(status) if s == "pending"]
    if models is None:  # resuming: the models of the pending cases only
        models = _models(study, members, {model_of[i] for i in todo}, comm, say)
    costs = [models[model_of[i]].modes ** 2 * _steps(study.configs[i]) for i in todo]
    mine = [todo[j] for j in balance(costs, comm.size)[comm.rank]]
    keys = [batch_key(c) for c in study.configs]
    plan = batches(mine, keys, batch or _memory_width(cfg, models))
    rounds = comm.allreduce(len(plan), op=_mpi_op("MAX"))
    say(f"{len(todo)} transient(s) to run on {comm.size} rank(s) in {rounds} round(s)")

    def run_batch(chunk, progress):
        # a batch shares its mistuning (batch_key): the first case's model is every case's
        contacts = [study.configs[i].contacts for i in chunk]
        angles = [{"tieboss": c.tieboss.angle_deg, "shroud": c.shroud.angle_deg}
                  for c in contacts]
        return run_cases(case_model(models, model_of, study, chunk[0]), study.configs[chunk[0]],
                         angles, options=options, progress=progress)

    def line(i, st, wall, _width, _compiled, verdict):
        wall_text = f"{wall:.3g} s" if math.isfinite(wall) else "-"
        return f"[case {i}/{len(status) - 1}] {study.label(i)}: {st} ({wall_text}); {verdict}"

    with interrupts.deferred(), h5py.File(out, "r+", driver="mpio", comm=comm) as f:
        fastest = _fastest_modes(f)  # each case's linear verdict, already in the file

        def attach(i, res):
            if fastest[i] is None:  # the case's stability analysis failed
                res.classification = "unknown (linear analysis failed: see /stability)"
            else:
                attach_classification(res, *fastest[i])

        return run_rounds(f, plan, comm, run_batch, settings, attach, line, say, cfg.time.end)


def _transient_bytes(cfg, study, models, mode: str) -> int:
    """The bytes of the study file's transient datasets and models (what dominates it; the
    stability part is a few arrays per case), estimated before anything is computed."""
    if mode == "stability":
        return 0
    angles = study_file.case_angles(study)
    modes = max(m.modes for m in models)
    return results.layout_bytes(lambda f: [
        results.create_layout(f, cfg, models[0], angles, modes=modes),
        *(results.write_model(f.create_group(f"models/{g}"), m) for g, m in enumerate(models))])


def _fastest_modes(f) -> list:
    """Per case ``(growth rate [1/s], ND, frequency [Hz])`` of its fastest linear mode from
    ``/stability`` (stored fastest first), None where the analysis failed."""
    verdict = f["stability/verdict"][()]
    growth = f["stability/growth_rate"][:, 0]
    nd = f["stability/nodal_diameter"][:, 0]
    hz = f["stability/frequency_hz"][:, 0]
    return [None if v.startswith(b"failed") else (float(g), int(k), float(h))
            for v, g, k, h in zip(verdict, growth, nd, hz, strict=True)]


def _memory_width(cfg: Config, models: list) -> int:
    """The default batch width: the cases whose stored histories (tip ``(S, N, 3)``, state
    ``(S', 2, N, m)``) fit in ``HISTORY_BYTES`` per rank (a batch holds them all until it is
    written)."""
    N = max(m.blades for m in models if m is not None)
    m = max(m.modes for m in models if m is not None)
    grid = time_grid(cfg)
    per_case = 8 * (3 * N * grid.history_max + 2 * N * m * grid.state_max)  # [bytes]
    return max(1, HISTORY_BYTES // max(per_case, 1))


def _steps(cfg: Config) -> float:
    return cfg.time.end / cfg.time.step
