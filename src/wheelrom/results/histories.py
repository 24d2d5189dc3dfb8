"""The stored histories of a results file (docs/output.md): the tip history
``/cases/tip_history`` with its times ``/cases/sample_time`` (every k-th statistics sample,
``output.history_rate_hz``) and the modal state history ``/cases/state_history`` with
``/cases/state_time`` (``output.state_rate_hz``), from which any field of the wheel can be
reconstructed after the run. Their datasets are chunked by case and about a megabyte of
samples, so reading one case's window touches only that window.

What a case costs in the file is :func:`case_bytes` (preallocated: a parallel HDF5 file
allocates every dataset when it is created).
"""

from __future__ import annotations

import numpy as np

from wheelrom.runtime.errors import InputError

CHUNK_BYTES = 1 << 20  # about this many bytes of samples per chunk
STATE_COLUMNS = "q [sqrt(kg) m], q' [sqrt(kg) m/s]"


def _chunk(S: int, row_bytes: int) -> int:
    """Samples per chunk: about :data:`CHUNK_BYTES`, splitting ``S`` samples into equal
    chunks (a parallel file allocates whole chunks: the last one is filled too)."""
    target = max(1, min(S, CHUNK_BYTES // max(row_bytes, 1)))
    return -(-S // -(-S // target))


def create_histories(cases, C: int, grid, N: int, m: int) -> None:
    """The history datasets of ``C`` cases on the :class:`~wheelrom.transient.ts.TimeGrid`
    ``grid`` (collective under MPI: every rank calls it identically). A history whose rate
    is 0 has no datasets."""
    nan = dict(dtype="f8", fillvalue=np.nan)
    if grid.history_every:
        S = grid.history_max
        cases.create_dataset("sample_time", (C, S), **nan)
        cases.create_dataset("tip_history", (C, S, N, 3), chunks=(1, _chunk(S, 24 * N), N, 3),
                             **nan)
        cases["tip_history"].attrs["every"] = grid.history_every
    if grid.state_every:
        S2 = grid.state_max
        cases.create_dataset("state_time", (C, S2), **nan)
        cases.create_dataset("states_done", (C,), dtype="i8")
        shape = (C, S2, 2, N, m)
        cases.create_dataset("state_history", shape,
                             chunks=(1, _chunk(S2, 16 * N * m), 2, N, m), **nan)
        cases["state_history"].attrs["columns"] = STATE_COLUMNS
        cases["state_history"].attrs["every"] = grid.state_every


def write_histories(cases, i: int, res) -> None:
    """Case ``i``'s histories from its :class:`~wheelrom.transient.problem.CaseResult`."""
    s = res.sample_time.size
    if s and "tip_history" in cases:
        cases["sample_time"][i, :s] = res.sample_time
        cases["tip_history"][i, :s] = res.tip_history
    s2 = res.state_time.size
    if "state_history" in cases:
        cases["states_done"][i] = s2
        if s2:
            cases["state_time"][i, :s2] = res.state_time
            m = res.state_history.shape[-1]  # a study's case may have fewer modes than the widest
            cases["state_history"][i, :s2, ..., :m] = res.state_history


def case_bytes(cases) -> dict[str, int]:
    """Bytes per case of every per-case dataset of a ``/cases`` group (shape ``(C, ...)``),
    as preallocated: name -> bytes, largest first."""
    C = cases["status"].shape[0]
    out = {}

    def visit(name, obj):
        shape = getattr(obj, "shape", None)
        if shape and shape[0] == C and name != "window_end":
            out[name] = int(np.prod(shape[1:], dtype=np.int64)) * obj.dtype.itemsize

    cases.visititems(visit)
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def state_window(cases, path: str, case: int, window: tuple[float, float] | None = None,
                 modes: int | None = None):
    """``(times (S,), states (S, 2, N, m))`` of case ``case``'s modal state history within
    ``window`` ``(a, b)`` [s] (None: all of it); ``modes``: the case's mode count ``m`` when
    the file is wider (a study of ``wheel.modes_per_segment``). One line naming the file when
    it has none."""
    if "state_history" not in cases:
        raise InputError(f"{path} has no state history: rerun with output.state_rate_hz > 0 "
                         "(e.g. --set output.state_rate_hz=2000)")
    times, states = _history(cases, path, case, window, "state")
    return times, states[..., :modes]


def tip_window(cases, path: str, case: int, window: tuple[float, float] | None = None):
    """``(times (S,), tips (S, N, 3))`` of case ``case``'s tip history within ``window``."""
    if "tip_history" not in cases:
        raise InputError(f"{path} has no tip history (output.history_rate_hz = 0) and no "
                         "state history: rerun with output.history_rate_hz > 0")
    return _history(cases, path, case, window, "tip")


# the datasets of each history: (values, sample times, rows filled per case)
_HISTORY = {"state": ("state_history", "state_time", "states_done"),
            "tip": ("tip_history", "sample_time", "samples_done")}


def _history(cases, path: str, case: int, window, kind: str):
    """``(times, values)`` of one case's ``kind`` history (``_HISTORY``) within ``window``."""
    values, times, done = _HISTORY[kind]
    t = cases[times][case, : int(cases[done][case])]
    lo, hi = _window_rows(t, window, path, f"{kind} history")
    return t[lo:hi], cases[values][case, lo:hi]


def _window_rows(t: np.ndarray, window, path: str, what: str) -> tuple[int, int]:
    """Rows of the sample times ``t`` inside ``window`` ``(a, b)`` [s], ends included."""
    if t.size == 0:
        raise InputError(f"{path}: the case has no {what} samples (it failed at the start?)")
    if window is None:
        return 0, t.size
    a, b = window
    lo, hi = int(np.searchsorted(t, a - 1e-12)), int(np.searchsorted(t, b + 1e-12, "right"))
    if hi <= lo:
        raise InputError(f"--window {a:g}:{b:g}: no {what} sample in it (the case has "
                         f"samples from {t[0]:.6g} to {t[-1]:.6g} s)")
    return lo, hi
