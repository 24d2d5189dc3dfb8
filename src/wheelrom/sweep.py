"""Angle sweeps across MPI ranks into one parallel HDF5 file (layout: ``docs/output.md``).

The reduced model is built once on rank 0 and broadcast, so case results cannot depend on
the number of ranks. The pending cases (tie-boss angle x shroud angle) are dealt round-robin
to the ranks; each rank integrates its cases in batches of ``batch`` cases, one TS on
``COMM_SELF`` per batch (:func:`wheelrom.transient.run_cases`: a case's result is bitwise the
same in any batch). Rounds: every rank integrates one batch, then all ranks write their cases
into preallocated datasets and flush collectively. A sweep killed at any moment therefore
leaves a file holding every case of every finished round; ``--resume`` runs the cases still
pending. ``batch = 0`` (default) puts all of a rank's cases in one batch: fastest, but a kill
loses the whole round; ``batch = 1`` writes every case as soon as it is done.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import time

import numpy as np

from wheelrom import config as config_mod
from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.cyclic import ReducedModel, build_model
from wheelrom.errors import InputError
from wheelrom.transient import N_WORK, WORK_NAMES, CaseResult, run_cases

STATUS_LEN = 256
FORMAT = "wheelrom-sweep-1"


def case_angles(cfg: Config) -> np.ndarray:
    """``(C, 2)`` (tie-boss, shroud) angle of every case [deg], tie-boss major."""
    pairs = itertools.product(cfg.sweep.tieboss_angles_deg, cfg.sweep.shroud_angles_deg)
    return np.array(list(pairs), dtype=float).reshape(-1, 2)


def n_windows(cfg: Config) -> int:
    return max(1, int(round(cfg.time.end / cfg.time.window)))


def n_samples_max(cfg: Config) -> int:
    return int(math.ceil(cfg.time.end * cfg.output.sample_rate_hz)) + 2


def _case_angles(angles: np.ndarray) -> dict:
    return {"tieboss": float(angles[0]), "shroud": float(angles[1])}


def write_model(group, model: ReducedModel) -> None:
    """Reduced-model data (``/model``): small arrays, written by one rank or serially."""
    from scipy.sparse import csr_matrix

    K = csr_matrix(model.dense_stiffness())
    red = group.create_group("reduced")
    red["K/data"], red["K/indices"], red["K/indptr"] = K.data, K.indices, K.indptr
    red["K/shape"] = np.array(K.shape)
    group["segment_hz"] = model.segment_hz
    group["A0"], group["A1"] = model.A0, model.A1
    group["excitation"], group["aero"], group["tip"] = model.excitation, model.aero, model.tip
    group["frequencies_by_nd"] = model.frequencies_by_nodal_diameter()
    for kind, XA in model.contact_A.items():
        group[f"contacts/{kind}/A_shape"] = XA
        group[f"contacts/{kind}/B_shape"] = model.contact_B[kind]
        group[f"contacts/{kind}/points"] = model.contact_points[kind]
    for kind, table in model.contact_stiffness.items():
        group[f"contacts/{kind}/stiffness"] = table
    group.attrs["blades"] = model.blades
    group.attrs["modes"] = model.modes
    group.attrs["info"] = json.dumps(model.info, default=float)


def _create_layout(f, cfg: Config, model: ReducedModel) -> None:
    """Collective creation of every dataset (all ranks call this identically)."""
    C = case_angles(cfg).shape[0]
    W = n_windows(cfg)
    S = n_samples_max(cfg)
    N = model.blades
    f.attrs["format"] = FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    cases = f.create_group("cases")
    cases.create_dataset("angles_deg", data=case_angles(cfg))
    cases.attrs["angle_columns"] = "tieboss, shroud"
    st = cases.create_dataset("status", (C,), dtype=f"S{STATUS_LEN}")
    cases.create_dataset("wall_s", (C,), dtype="f8", fillvalue=np.nan)
    cases.create_dataset("steps", (C,), dtype="i8")
    cases.create_dataset("batch", (C,), dtype="i8")
    cases.create_dataset("windows_done", (C,), dtype="i8")
    cases.create_dataset("samples_done", (C,), dtype="i8")
    cases.create_dataset("options", (C,), dtype=f"S{STATUS_LEN}")
    cases.create_dataset(
        "window_end", data=np.minimum((np.arange(W) + 1) * cfg.time.window, cfg.time.end)
    )
    nan = dict(dtype="f8", fillvalue=np.nan)
    cases.create_dataset("max_tip_amplitude", (C, W), **nan)
    cases.create_dataset("nd_spectrum", (C, W, N // 2 + 1), **nan)
    cases.create_dataset("energy", (C, W), **nan)
    cases.create_dataset("energy0", (C,), **nan)
    cases.create_dataset("work", (C, W, N_WORK), **nan)
    cases["work"].attrs["columns"] = ", ".join(WORK_NAMES)
    cases.create_dataset("sample_time", (C, S), **nan)
    cases.create_dataset("tip_history", (C, S, N, 3), chunks=(1, S, N, 3), **nan)
    for kind in CONTACT_KINDS:
        cases.create_dataset(f"min_normal_force/{kind}", (C, W), **nan)
        cases.create_dataset(f"open_fraction/{kind}", (C, W), **nan)
    model_group = f.create_group("model")
    # every rank writes the same small model arrays; identical values, so this is safe and
    # keeps creation collective
    write_model(model_group, model)
    st[...] = np.array([b"pending"] * C, dtype=f"S{STATUS_LEN}")


def _write_case(cases, i: int, res: CaseResult) -> None:
    w = res.window_end.size
    s = res.sample_time.size
    cases["status"][i] = res.status.encode()[:STATUS_LEN]
    cases["wall_s"][i] = res.wall_s
    cases["steps"][i] = res.steps
    cases["batch"][i] = res.batch
    cases["windows_done"][i] = w
    cases["samples_done"][i] = s
    cases["options"][i] = json.dumps(res.options).encode()[:STATUS_LEN]
    cases["energy0"][i] = res.energy0
    if w:
        cases["max_tip_amplitude"][i, :w] = res.max_tip_amplitude
        cases["nd_spectrum"][i, :w] = res.nd_spectrum
        cases["energy"][i, :w] = res.energy
        cases["work"][i, :w] = res.work
        for kind, values in res.min_normal_force.items():
            cases[f"min_normal_force/{kind}"][i, :w] = values
            cases[f"open_fraction/{kind}"][i, :w] = res.open_fraction[kind]
    if s:
        cases["sample_time"][i, :s] = res.sample_time
        cases["tip_history"][i, :s] = res.tip_history


def run_sweep(
    cfg: Config,
    out: str,
    resume: bool = False,
    force: bool = False,
    comm=None,
    log=print,
    options: dict | None = None,
    model_comm: str = "rank0",
    batch: int = 0,
) -> int:
    """Run the sweep of ``cfg`` into ``out``; returns the number of failed cases.

    Collective over ``comm`` (mpi4py, default ``COMM_WORLD``). Progress lines go to ``log``
    on rank 0. ``model_comm``: ``"rank0"`` builds the model on rank 0 and broadcasts it
    (results independent of the number of ranks); ``"world"`` runs the segment eigen-solve
    distributed over all ranks (for segments too large for one rank; the modes then agree
    with a serial build to the eigen-solver tolerance, not bitwise). ``batch``: cases per TS
    on a rank (0: all of the rank's cases at once; see the module docstring).
    """
    import h5py
    from mpi4py import MPI

    from wheelrom._environment import petsc, slepc

    # PetscInitialize is collective on COMM_WORLD: every rank initialises before rank 0
    # alone builds the model
    petsc()
    slepc()
    comm = comm or MPI.COMM_WORLD
    rank, size = comm.rank, comm.size
    say = log if rank == 0 else (lambda *_: None)

    # check the input and decide what to do with the output file before computing anything
    if batch < 0:
        raise InputError(f"--batch must be >= 0, not {batch}")
    problem = None
    if rank == 0:
        exists = os.path.exists(out)
        if exists and not (resume or force):
            problem = f"{out} exists: pass --resume to complete it or --force to overwrite it"
        elif exists and resume:
            problem = _check_resumable(out, cfg)
    problem = comm.bcast(problem)
    if problem:
        raise InputError(problem)
    mode = "r+" if (resume and os.path.exists(out)) else "w"

    t0 = time.perf_counter()
    model = None
    if model_comm == "world":
        model = build_model(cfg, petsc().COMM_WORLD, log=say)
    elif model_comm == "rank0":
        if rank == 0:
            model = build_model(cfg, petsc().COMM_SELF, log=say)
        model = comm.bcast(model)
    else:
        raise InputError(f"model_comm must be 'rank0' or 'world', not {model_comm!r}")
    say(
        f"model ready in {time.perf_counter() - t0:.1f} s: {model.blades} blades x "
        f"{model.modes} modes"
    )

    angles = case_angles(cfg)
    C = angles.shape[0]
    with h5py.File(out, mode, driver="mpio", comm=comm) as f:
        if mode == "w":
            _create_layout(f, cfg, model)
            f.flush()
        status = np.array([s.decode() for s in f["cases/status"][:]])
        todo = [i for i in range(C) if status[i] == "pending"]
        say(f"{C} cases, {len(todo)} to run on {size} rank(s)")
        done = C - len(todo)
        mine = todo[rank::size]
        per_rank = math.ceil(len(todo) / size)
        width = batch or max(per_rank, 1)
        rounds = math.ceil(per_rank / width)
        chunks = [mine[r * width : (r + 1) * width] for r in range(rounds)]
        t_sweep = time.perf_counter()
        for r, chunk in enumerate(chunks):
            results: list[CaseResult] = []
            if chunk:
                progress = _progress_printer(say, len(chunk), cfg.time.end, r, rounds)
                try:
                    results = run_cases(model, cfg, [_case_angles(angles[i]) for i in chunk],
                                        options=options, progress=progress)  # fmt: skip
                except Exception as exc:  # a solver error fails this batch, not the sweep
                    results = [
                        CaseResult(status=f"failed: {type(exc).__name__}: {exc}") for _ in chunk
                    ]
                for i, res in zip(chunk, results, strict=True):
                    _write_case(f["cases"], i, res)
            f.flush()  # collective: every finished round is on disk
            pairs = zip(chunk, results, strict=True)
            report = [(i, res.status, res.wall_s, res.batch) for i, res in pairs]
            info = comm.gather(report, root=0)
            if rank == 0:
                finished = [item for part in info for item in part]
                elapsed = time.perf_counter() - t_sweep
                eta = elapsed / (r + 1) * (rounds - r - 1)
                for i, st, wall, width_used in sorted(finished):
                    done += 1
                    tb, sh = angles[i]
                    share = f"{wall:.1f} s" if width_used == 1 else (
                        f"{wall:.1f} s, batch of {width_used}"
                    )  # fmt: skip
                    say(
                        f"[{done}/{C}] tie-boss {tb:g} deg, shroud {sh:g} deg: {st} "
                        f"({share}); about {eta:.0f} s left"
                    )
        failed = int(sum(1 for s in f["cases/status"][:] if s.decode().startswith("failed")))
    say(f"sweep finished in {time.perf_counter() - t0:.1f} s; {failed} case(s) failed")
    return failed


def _progress_printer(say, cases: int, t_end: float, round_index: int, rounds: int):
    """Progress of a long batch (rank 0's view): about every tenth of the simulated time."""
    t0 = time.perf_counter()
    last = [0.0]

    def progress(window, windows, t, amplitude):
        if t - last[0] < 0.1 * t_end and window < windows:
            return
        last[0] = t
        elapsed = time.perf_counter() - t0
        left = elapsed * (t_end - t) / max(t, 1e-300)
        say(
            f"  round {round_index + 1}/{rounds}: {cases} case(s), t = {t:.4g} of {t_end:g} s, "
            f"largest tip amplitude {amplitude:.3g} m, {elapsed:.0f} s, about {left:.0f} s left"
        )

    return progress


def _check_resumable(out: str, cfg: Config) -> str | None:
    import h5py

    try:
        with h5py.File(out, "r") as f:
            if f.attrs.get("format") != FORMAT:
                return f"{out} is not a wheelrom sweep file"
            if f.attrs.get("config") != config_mod.to_toml(cfg):
                return (
                    f"{out} was written for a different configuration "
                    "(compare 'wheelrom config show'); use --force to start again"
                )
    except OSError as exc:
        return f"{out} cannot be opened for --resume ({exc}); use --force to start again"
    return None
