"""The ``[flutter]`` section and its aerodynamic damping table (``flutter.model = "table"``): read,
checked row by row and brought to one convention -- a value per nodal diameter ``k = 0..N-1`` of
the wave in which blade ``s + 1`` *leads* blade ``s`` by ``sigma_k = 2 pi k / N`` (``y_s ~
cos(omega t + s sigma_k)``, ``omega > 0``), damping positive = stabilising. Part of
:mod:`wheelrom.config`; the conversion to influence coefficients needs the reduced model and
lives in :mod:`wheelrom.forces.aero`. Conventions and a worked example: docs/theory.md,
"Aerodynamic damping table".

The file is CSV with a header; ``#`` starts a comment. Columns (any order):

- ``nd`` (integer; ``k`` and ``k - N`` are the same wave) or ``ibpa_deg`` (phase angle
  [deg], interpolated linearly and periodically between the given angles);
- ``damping_ratio`` (of the selected segment mode's family, ``|zeta| < 1``), or
  ``aero_damping`` [N s/m] with optional ``aero_stiffness`` [N/m]: the aerodynamic force on a
  blade along its aerofoil's ``y`` direction, ``F = -(k_a y + c_a y')`` for that wave;
- optional ``frequency_hz``: the frequency the values were computed at (default: the
  family's frequency in the reduced model, contacts open).
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wheelrom.config.values import (
    beside_toml,
    file_stamp,
    input_file_problem,
    path_problem,
    quoted,
)
from wheelrom.config.values import field_key as _key


@dataclass(frozen=True)
class FlutterConfig:
    model: str = field(
        default="relative",
        metadata=_key(
            "-",
            "self-excitation: Van der Pol 'relative' (eq. 2), 'absolute' (eq. 1), 'off', or "
            "'table' (aerodynamic damping per nodal diameter from flutter.table)",
            choices=("relative", "absolute", "off", "table"),
        ),
    )
    mu: float = field(default=100.0, metadata=_key("N s/m", "Van der Pol intensity mu", min=0.0,
                                                   max=1e6))
    r: float = field(
        default=5e-3, metadata=_key("m", "amplitude where negative damping turns positive", gt=0.0,
                                    max=1.0)
    )
    mode: int | str = field(
        default="auto",
        metadata=_key(
            "-",
            "segment mode the Van der Pol force acts on: 'auto' (the paper's 'one selected "
            "mode of each blade': the lowest whose aero y motion is at least half its tip "
            "motion, the first bending mode), a mode number (0-based) or -1 (every mode)",
            min=-1,
        ),
    )
    table: str = field(
        default="",
        metadata=_key("-", "CSV of the aerodynamic damping per nodal diameter (flutter.model = "
                      "'table'; docs/theory.md 'Aerodynamic damping table'): a column 'nd' or "
                      "'ibpa_deg', and 'damping_ratio' or 'aero_damping' [N s/m] (with "
                      "optional 'aero_stiffness' [N/m]), optional 'frequency_hz'; relative "
                      "to the TOML"),
    )
    table_phase: str = field(
        default="lead",
        metadata=_key("-", "what the table's ND k / phase angle sigma means: 'lead' (blade "
                      "s+1 leads blade s by sigma = 2 pi k / N, wheelrom's convention) or "
                      "'lag' (blade s+1 lags by sigma)", choices=("lead", "lag")),
    )
    table_directions: str = field(
        default="both",
        metadata=_key("-", "'both': the table covers both travelling directions (ND 0..N-1, "
                      "or -N/2..N/2, or phase angles around the circle); 'symmetric': ND "
                      "0..N/2 (0..180 deg), the same value for both directions",
                      choices=("both", "symmetric")),
    )
    table_sign: int = field(
        default=0,
        metadata=_key("-", "sign of the table's damping: 1 positive = stabilising (the flow "
                      "takes energy out), -1 positive = destabilising (aerodynamic work on "
                      "the blade), 0 = 1 after a check that the damping is not negative at "
                      "most phase angles (the usual sign mistake)", min=-1, max=1),
    )
    table_scale: float = field(
        default=1.0,
        metadata=_key("-", "factor on the table's aerodynamic coefficients (the flutter "
                      "margin is the factor at which the wheel flutters)", min=0.0,
                      max=1e3),
    )


PHASE_COLUMNS = ("nd", "ibpa_deg")
VALUE_COLUMNS = ("damping_ratio", "aero_damping", "aero_stiffness", "frequency_hz")
#: share of the nodal diameters with negative damping above which the sign looks flipped
SIGN_SUSPECT = 0.5


@dataclass(frozen=True)
class AeroTable:
    """A checked table per ND ``k = 0..N-1`` (lead convention, stabilising positive, the
    sign and ``directions`` applied): ``damping_ratio`` ``(N,)`` or None; ``aero_damping``
    [N s/m] and ``aero_stiffness`` [N/m] ``(N,)`` or None; ``frequency_hz`` ``(N,)`` or None."""

    damping_ratio: np.ndarray | None
    aero_damping: np.ndarray | None
    aero_stiffness: np.ndarray | None
    frequency_hz: np.ndarray | None


def read_aero_table(name: str, source: str, blades: int, phase: str = "lead",
                    directions: str = "both", sign: int = 0) -> AeroTable:
    """The table ``name`` (``flutter.table``, relative to the TOML ``source``) for a wheel of
    ``blades``; ``phase``, ``directions``, ``sign``: ``flutter.table_phase``,
    ``table_directions``, ``table_sign``. ``ValueError`` naming the file and the line."""
    path = beside_toml(name, source)
    header, rows = _read_rows(name, os.path.abspath(path), file_stamp(path))
    return _per_nd(name, header, rows, blades, phase, directions, sign)


@functools.lru_cache(maxsize=16)
def _read_rows(name: str, path: str, stamp) -> tuple[tuple[str, ...], tuple]:
    """``(header, rows)``: the column names and ``(line, values)`` per data row."""
    why = input_file_problem(path)
    if why:
        raise ValueError(f"{name}: {why}")
    try:
        with open(path, encoding="utf-8-sig") as fh:  # a BOM (Excel) is not data
            lines = fh.read().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: cannot be read ({exc})") from None
    header, rows = None, []
    for number, raw in enumerate(lines, start=1):
        text = raw.split("#")[0].strip()
        if not text:
            continue
        words = [w.strip() for w in text.split(",")]
        if header is None:
            header = tuple(w.lower() for w in words)
            _check_header(name, number, header)
            continue
        if len(words) != len(header):
            raise ValueError(f"{name}: line {number} has {len(words)} values for the "
                             f"{len(header)} columns {', '.join(header)}")
        values = []
        for column, word in zip(header, words, strict=True):
            try:
                value = float(word)
            except ValueError:
                raise ValueError(f"{name}: line {number}, {column} = {quoted(word)} is not a "
                                 "number") from None
            if not math.isfinite(value):
                raise ValueError(f"{name}: line {number}, {column} = {word} is not finite")
            values.append(value)
        rows.append((number, tuple(values)))
    if header is None:
        raise ValueError(f"{name}: no header line (e.g. 'nd,damping_ratio')")
    if not rows:
        raise ValueError(f"{name}: a header but no rows")
    return header, tuple(rows)


def _check_header(name: str, line: int, header: tuple[str, ...]) -> None:
    known = PHASE_COLUMNS + VALUE_COLUMNS
    for column in header:
        if column not in known:
            raise ValueError(f"{name}: line {line}: unknown column {quoted(column)} (known: "
                             f"{', '.join(known)})")
    for column in set(header):
        if header.count(column) > 1:
            raise ValueError(f"{name}: line {line}: column {column!r} appears twice")
    phases = [c for c in header if c in PHASE_COLUMNS]
    if len(phases) != 1:
        raise ValueError(f"{name}: line {line}: needs exactly one of the columns 'nd' or "
                         f"'ibpa_deg', found {phases or 'none'}")
    if ("damping_ratio" in header) == ("aero_damping" in header):
        raise ValueError(f"{name}: line {line}: needs exactly one of the columns "
                         "'damping_ratio' or 'aero_damping'")
    if "aero_stiffness" in header and "aero_damping" not in header:
        raise ValueError(f"{name}: line {line}: 'aero_stiffness' goes with 'aero_damping' "
                         "(a damping ratio has no stiffness part)")


def _per_nd(name, header, rows, N, phase, directions, sign) -> AeroTable:
    lines = np.array([line for line, _ in rows])
    data = np.array([values for _, values in rows], dtype=float)
    col = {c: data[:, i] for i, c in enumerate(header)}
    _check_values(name, lines, col)
    symmetric = directions == "symmetric"
    if "nd" in col:
        index = _nd_rows(name, lines, col["nd"], N, phase, symmetric)

        def at_nd(values):
            return values[index]
    else:
        sigma = _ibpa_points(name, lines, col["ibpa_deg"], phase, symmetric)

        def at_nd(values):
            return _periodic_interpolation(sigma, values, 360.0 * np.arange(N) / N, symmetric)

    per_nd = {c: at_nd(v) for c, v in col.items() if c in VALUE_COLUMNS}
    damping = per_nd.get("damping_ratio", per_nd.get("aero_damping"))
    negative = damping < 0.0
    if sign == 0 and negative.mean() > SIGN_SUSPECT:
        raise ValueError(
            f"{name}: the aerodynamic damping is negative at {negative.sum()} of {N} nodal "
            f"diameters; wheelrom reads positive values as stabilising (the flow takes energy "
            f"out), and a flutter table is positive at most phase angles. If the table counts "
            f"the aerodynamic work on the blade (positive = destabilising), set "
            f"flutter.table_sign = -1; if it is right as it is, set flutter.table_sign = 1")
    factor = -1.0 if sign == -1 else 1.0
    stiffness = per_nd.get("aero_stiffness")
    if "aero_damping" in per_nd and stiffness is None:
        stiffness = np.zeros(N)
    return AeroTable(
        damping_ratio=factor * per_nd["damping_ratio"] if "damping_ratio" in per_nd else None,
        aero_damping=factor * per_nd["aero_damping"] if "aero_damping" in per_nd else None,
        aero_stiffness=factor * stiffness if stiffness is not None else None,
        frequency_hz=per_nd.get("frequency_hz"),
    )


def _check_values(name, lines, col) -> None:
    """Unphysical values, named by line."""
    checks = (
        ("damping_ratio", lambda v: np.abs(v) >= 1.0,
         "is not below 1 in magnitude (a damping ratio; aerodynamic damping of a blade row is "
         "a few per cent at most)"),
        ("frequency_hz", lambda v: v <= 0.0, "is not positive"),
    )
    for column, bad, why in checks:
        if column in col:
            wrong = np.flatnonzero(bad(col[column]))
            if wrong.size:
                i = wrong[0]
                raise ValueError(f"{name}: line {lines[i]}, {column} = {col[column][i]:g} {why}")


def _first_duplicate(keys: np.ndarray):
    """``(i, j)`` the first two rows with the same key, or None."""
    seen = {}
    for i, key in enumerate(keys):
        if key in seen:
            return seen[key], i
        seen[key] = i
    return None


def _nd_rows(name, lines, nd, N, phase, symmetric) -> np.ndarray:
    """Row index per ND ``0..N-1`` (lead convention) of an ``nd`` table."""
    whole = np.round(nd)
    wrong = np.flatnonzero(whole != nd)
    if wrong.size:
        i = wrong[0]
        raise ValueError(f"{name}: line {lines[i]}, nd = {nd[i]:g} is not an integer")
    nd = whole.astype(int)
    if symmetric:
        far = np.flatnonzero((nd < 0) | (nd > N // 2))
        if far.size:
            i = far[0]
            raise ValueError(f"{name}: line {lines[i]}, nd = {nd[i]}: a symmetric table "
                             f"(flutter.table_directions) gives ND 0..{N // 2}")
        keys = nd
    else:
        far = np.flatnonzero((nd <= -N) | (nd >= N))
        if far.size:
            i = far[0]
            raise ValueError(f"{name}: line {lines[i]}, nd = {nd[i]} is outside -{N - 1}..{N - 1} "
                             f"for {N} blades")
        keys = nd % N
        if phase == "lag":
            keys = (-nd) % N
    twice = _first_duplicate(keys)
    if twice:
        i, j = twice
        raise ValueError(f"{name}: lines {lines[i]} and {lines[j]} give the same nodal diameter "
                         f"(nd = {nd[i]} and {nd[j]} for {N} blades)")
    wanted = np.arange(N // 2 + 1) if symmetric else np.arange(N)
    missing = np.setdiff1d(wanted, keys)
    if missing.size:
        shown = missing if phase == "lead" or symmetric else (-missing) % N
        listed = ", ".join(str(k) for k in shown[:10]) + (" ..." if missing.size > 10 else "")
        span = f"0..{N // 2}" if symmetric else f"0..{N - 1} (or -{(N - 1) // 2}..{N // 2})"
        raise ValueError(f"{name}: nodal diameter(s) {listed} missing: the table must give "
                         f"every ND {span} of the {N}-blade wheel (or use 'ibpa_deg' to "
                         "interpolate)")
    index = np.empty(N, dtype=int)
    where = {int(k): i for i, k in enumerate(keys)}
    for k in range(N):
        index[k] = where[min(k, N - k)] if symmetric else where[k]
    return index


def _ibpa_points(name, lines, ibpa, phase, symmetric) -> np.ndarray:
    """The table's phase angles [deg] in the lead convention on [0, 360) (checked)."""
    if symmetric:
        far = np.flatnonzero((ibpa < 0.0) | (ibpa > 180.0))
        if far.size:
            i = far[0]
            raise ValueError(f"{name}: line {lines[i]}, ibpa_deg = {ibpa[i]:g}: a symmetric "
                             "table gives 0..180 deg")
        sigma = ibpa.copy()
    else:
        sigma = np.mod(-ibpa if phase == "lag" else ibpa, 360.0)
    twice = _first_duplicate(np.round(sigma, 9) % 360.0)
    if twice:
        i, j = twice
        raise ValueError(f"{name}: lines {lines[i]} and {lines[j]} give the same phase angle "
                         f"({ibpa[i]:g} and {ibpa[j]:g} deg)")
    if sigma.size < 2:
        raise ValueError(f"{name}: one phase angle; interpolation needs at least two")
    return sigma


def _periodic_interpolation(sigma, values, at, symmetric) -> np.ndarray:
    """Linear interpolation of ``values`` at ``sigma`` [deg] to ``at``, periodic over 360 deg
    (mirrored about 0 first when ``symmetric``)."""
    if symmetric:
        sigma = np.concatenate([sigma, 360.0 - sigma])
        values = np.concatenate([values, values])
    order = np.argsort(sigma)
    s, v = sigma[order], values[order]
    s = np.concatenate([s[-1:] - 360.0, s, s[:1] + 360.0])
    v = np.concatenate([v[-1:], v, v[:1]])
    return np.interp(np.mod(at, 360.0), s, v)


def aero_table_problems(cfg: Any, source: str, problems: list[str]) -> None:
    """``flutter.table`` read and checked with every other problem of the configuration."""
    fl, blades = cfg.flutter, cfg.wheel.blades
    if fl.model != "table":
        return
    if not isinstance(fl.table, str) or not fl.table:
        problems.append("flutter.table: flutter.model = 'table' needs a table file")
        return
    if not isinstance(blades, int) or path_problem(fl.table):  # the latter said by its key
        return
    try:
        table = read_aero_table(fl.table, source, blades, fl.table_phase, fl.table_directions,
                                fl.table_sign)
    except ValueError as exc:
        problems.append(f"flutter.table: {exc}")
        return
    if table.damping_ratio is not None and fl.mode == -1:
        problems.append("flutter.mode: a damping-ratio table is of one segment mode's family; "
                        "use 'auto' or a mode number (or give aero_damping in N s/m)")
