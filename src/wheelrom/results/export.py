"""One case of a results file as CSV for spreadsheet users (``wheelrom export``).

Two tables (docs/output.md gives the datasets they come from):

- ``tips``: one row per output sample: ``time_s``, then ``x_m``, ``y_m``, ``z_m`` of the tip
  of every blade (``blade<s>_x_m`` ...), sector frames (x radial, y tangential, z axial);
- ``windows``: one row per window: its end time, the largest tip amplitude, the smallest
  normal force and the open fraction of every contact kind, the energy, the cumulative works
  and the amplitude of every nodal-diameter component.

- ``contact_forces`` (a file with a modal state history, ``output.state_rate_hz > 0``): one
  row per state sample: ``time_s``, then per contact kind and blade pair ``(s, s+1)`` the
  normal force, the friction force (xi, zeta) and the relative displacement (xi, eta, zeta)
  of the contact, evaluated from the stored state by the solver's reference force model
  (:mod:`wheelrom.results.reconstruct`).

Numbers are written with 17 significant digits, so a CSV reads back to the same doubles.
"""

from __future__ import annotations

import numpy as np

from wheelrom.results.info import not_case_file
from wheelrom.results.layout import FORMAT, check_readable, open_file
from wheelrom.results.study_layout import FORMAT as STUDY_FORMAT
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import check_output, replacing

TABLES = ("tips", "windows")


def case_tables(path: str, case: int,
                what=TABLES) -> dict[str, tuple[list[str], np.ndarray]]:
    """``{table: (header, rows)}`` of the tables ``what`` of case ``case`` (0-based, as
    ``wheelrom info`` lists them) of the results file at ``path``."""
    with open_file(path) as f:
        if f.attrs.get("format") not in (FORMAT, STUDY_FORMAT) or "cases" not in f:
            raise not_case_file(path, f, "export", (FORMAT, STUDY_FORMAT))
        c = f["cases"]
        if "max_tip_amplitude" not in c:
            raise InputError(f"{path}: a --stability-only study: no transient to export")
        total = c["status"].shape[0]
        if not 0 <= case < total:
            raise InputError(f"--case {case}: the file has cases 0..{total - 1}")
        status = c["status"][case].decode()
        if status in ("pending", "skipped"):
            raise InputError(f"--case {case} is {status}: no transient computed to export")
        tables = {"tips": lambda: _tips(c, case, path), "windows": lambda: _windows(c, case)}
        out = {name: tables[name]() for name in what if name in tables}
    if "contact_forces" in what:
        out["contact_forces"] = _contact_forces(path, case)
    return out


def _contact_forces(path: str, case: int) -> tuple[list[str], np.ndarray]:
    from wheelrom.results.reconstruct import case_contacts

    histories = case_contacts(path, case)
    header, columns = ["time_s"], []
    for kind, h in histories.items():
        if not columns:
            columns.append(h.time)
        for s in range(h.normal_force.shape[1]):
            header += [f"{kind}{s}_normal_N", f"{kind}{s}_friction_xi_N",
                       f"{kind}{s}_friction_zeta_N", f"{kind}{s}_relative_xi_m",
                       f"{kind}{s}_relative_eta_m", f"{kind}{s}_relative_zeta_m"]
            columns += [h.normal_force[:, s], *h.friction_force[:, s].T,
                        *h.relative_displacement[:, s].T]
    if not columns:
        raise InputError(f"{path}: case {case} has no contacts")
    return header, np.column_stack(columns)


def _tips(c, case: int, path: str) -> tuple[list[str], np.ndarray]:
    if "tip_history" not in c:
        raise InputError(f"{path} has no tip history (output.history_rate_hz = 0): export "
                         "--what windows")
    samples = int(c["samples_done"][case])
    tips = c["tip_history"][case, :samples]  # (S, N, 3)
    header = ["time_s"] + [f"blade{s}_{axis}_m" for s in range(tips.shape[1]) for axis in "xyz"]
    rows = np.column_stack([c["sample_time"][case, :samples], tips.reshape(samples, -1)])
    return header, rows


def _windows(c, case: int) -> tuple[list[str], np.ndarray]:
    w = int(c["windows_done"][case])
    header, columns = ["window_end_s", "max_tip_amplitude_m"], [
        c["window_end"][:w], c["max_tip_amplitude"][case, :w]]
    for kind in sorted(c["min_normal_force"]):
        header += [f"min_normal_force_{kind}_N", f"open_fraction_{kind}"]
        columns += [c[f"min_normal_force/{kind}"][case, :w], c[f"open_fraction/{kind}"][case, :w]]
        if f"slip_fraction/{kind}" in c:  # files before issue #44 have none
            header.append(f"slip_fraction_{kind}")
            columns.append(c[f"slip_fraction/{kind}"][case, :w])
    header.append("energy_J")
    columns.append(c["energy"][case, :w])
    names = [n.strip() for n in c["work"].attrs["columns"].split(",")]
    header += [f"work_{name}_J" for name in names]
    columns += list(c["work"][case, :w].T)
    spectrum = c["nd_spectrum"][case, :w]  # (W, N//2 + 1)
    header += [f"nd{k}_amplitude_m" for k in range(spectrum.shape[1])]
    columns += list(spectrum.T)
    return header, np.column_stack(columns)


def table_paths(prefix: str, what=TABLES) -> list[str]:
    """``<prefix>_<table>.csv`` of each table in ``what``."""
    return [f"{prefix}_{name}.csv" for name in what]


def write_tables(tables: dict, prefix: str, what=TABLES) -> list[str]:
    """Write ``<prefix>_<table>.csv`` for each table in ``what`` (each complete or not at
    all: written under a temporary name); returns the paths."""
    for name, path in zip(what, table_paths(prefix, what), strict=True):
        header, rows = tables[name]
        with replacing(path) as partial:
            np.savetxt(partial, rows, delimiter=",", header=",".join(header), comments="",
                       fmt="%.17g")
    return table_paths(prefix, what)


def export_case(path: str, case: int, prefix: str, what: str = "all",
                force: bool = False) -> list[str]:
    """``wheelrom export``: the tables ``what`` (``"all"`` = tips and windows, ``"tips"``,
    ``"windows"`` or ``"contact_forces"``) of case ``case`` of ``path`` as
    ``<prefix>_<table>.csv``; the input is checked readable, then the output files
    (existing ones need ``force``), before anything is read. Returns the paths written."""
    tables = TABLES if what == "all" else (what,)
    check_readable(path)  # the input first: its problem is the one the user must fix first
    for target in table_paths(prefix, tables):
        check_output(target, force, "--csv")
    return write_tables(case_tables(path, case, tables), prefix, tables)
