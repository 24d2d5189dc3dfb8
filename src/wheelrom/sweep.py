"""Angle sweeps across MPI ranks into one parallel HDF5 file (layout: ``docs/output.md``).

The reduced model is built once on rank 0 and broadcast, so case results cannot depend on
the number of ranks. Cases (tie-boss angle x shroud angle) are processed in rounds: in each
round every rank integrates one case on ``COMM_SELF``, then all ranks write their case into
preallocated datasets and flush collectively. A sweep killed at any moment therefore leaves a
file holding every case of every finished round; ``--resume`` runs the cases still pending.
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
from wheelrom.transient import N_WORK, WORK_NAMES, CaseResult, run_case

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


def _case_config(cfg: Config, angles: np.ndarray) -> Config:
    return cfg.replace(
        **{
            "contacts.tieboss.angle_deg": float(angles[0]),
            "contacts.shroud.angle_deg": float(angles[1]),
        }
    )


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
) -> int:
    """Run the sweep of ``cfg`` into ``out``; returns the number of failed cases.

    Collective over ``comm`` (mpi4py, default ``COMM_WORLD``). Progress lines go to ``log``
    on rank 0. ``model_comm``: ``"rank0"`` builds the model on rank 0 and broadcasts it
    (results independent of the number of ranks); ``"world"`` runs the segment eigen-solve
    distributed over all ranks (for segments too large for one rank; the modes then agree
    with a serial build to the eigen-solver tolerance, not bitwise).
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

    # decide what to do with the output file before computing anything
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
        walls: list[float] = []
        t_sweep = time.perf_counter()
        for r0 in range(0, len(todo), size):
            batch = todo[r0 : r0 + size]
            mine = batch[rank] if rank < len(batch) else None
            res = None
            if mine is not None:
                case_cfg = _case_config(cfg, angles[mine])
                try:
                    res = run_case(model, case_cfg, options=options)
                except Exception as exc:  # a solver error fails this case, not the sweep
                    res = CaseResult(status=f"failed: {type(exc).__name__}: {exc}")
                _write_case(f["cases"], mine, res)
            f.flush()  # collective: every finished round is on disk
            info = comm.gather(
                (mine, res.status if res else None, res.wall_s if res else None), root=0
            )
            if rank == 0:
                for i, st, wall in info:
                    if i is None:
                        continue
                    done += 1
                    walls.append(wall)
                    tb, sh = angles[i]
                    left = len(todo) - (r0 + len(batch))
                    per_round = (time.perf_counter() - t_sweep) / (r0 // size + 1)
                    eta = per_round * math.ceil(left / size)
                    say(
                        f"[{done}/{C}] tie-boss {tb:g} deg, shroud {sh:g} deg: {st} "
                        f"({wall:.1f} s); about {eta:.0f} s left"
                    )
        failed = int(sum(1 for s in f["cases/status"][:] if s.decode().startswith("failed")))
    say(f"sweep finished in {time.perf_counter() - t0:.1f} s; {failed} case(s) failed")
    return failed


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
