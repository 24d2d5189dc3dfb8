"""The configuration of mistuning and of the forced response (``[mistuning]``, ``[forced]``):
their keys and the checks that need more than one key or a file (the pattern's length, the
pattern file, the band). Part of :mod:`wheelrom.config`, which re-exports the classes."""

from __future__ import annotations

import functools
import math
import os
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from wheelrom.config.values import (
    beside_toml,
    file_stamp,
    input_file_problem,
    is_number,
    path_problem,
    quoted,
)
from wheelrom.config.values import field_key as _key

#: largest |delta_s| a pattern or a pattern file may hold (as ``mistuning.pattern``)
MISTUNING_LIMIT = 0.5


@dataclass(frozen=True)
class MistuningConfig:
    pattern: tuple[float, ...] = field(
        default=(),
        metadata=_key("-", "per-blade modal stiffness deviation delta_s (Lambda_s = (1 + "
                      "delta_s) Lambda), one per blade; [] = none", min=-0.5, max=0.5,
                      allow_empty=True),
    )
    file: str = field(
        default="",
        metadata=_key("-", "file of delta_s, one per blade, added to the pattern: CSV/text "
                      "(numbers separated by commas, spaces or lines; # comments) or .npy; "
                      "relative to the TOML; '' = none"),
    )
    alternate: float = field(
        default=0.0,
        metadata=_key("-", "alternate mistuning: +a on even blades, -a on odd ones",
                      min=-0.5, max=0.5),
    )
    std: float = field(
        default=0.0,
        metadata=_key("-", "standard deviation of random mistuning", min=0.0, max=0.2),
    )
    distribution: str = field(
        default="normal",
        metadata=_key("-", "distribution of the random mistuning: 'normal' or 'uniform' "
                      "(on +-sqrt(3) std: the same standard deviation)",
                      choices=("normal", "uniform")),
    )
    seed: int = field(default=0, metadata=_key("-", "seed of the random mistuning", min=0))


@dataclass(frozen=True)
class ForcedConfig:
    band_hz: tuple[float, ...] = field(
        default=(),
        metadata=_key("Hz", "[lo, hi] excitation frequency band of the peak search; [] = "
                      "automatic: the tuned resonance of the excited ND's mode 'family' "
                      "+-max(1 %, 2 max|delta_s|)", min=0.0, max=1e6, allow_empty=True),
    )
    family: int = field(
        default=0,
        metadata=_key("-", "mode family (0: lowest) of the excited ND the automatic band is "
                      "centred on (over the speed: its Campbell crossing with the engine "
                      "order; up to the model's modes, attachment vectors included)",
                      min=0, max=1000),
    )
    contacts: bool = field(
        default=True,
        metadata=_key("-", "contacts linearised at the preloaded equilibrium (false: K_R "
                      "and beta_D K_R alone)"),
    )
    points: int = field(
        default=41,
        metadata=_key("-", "coarse grid over the band whose local maxima are peak candidates "
                      "besides the eigenfrequencies (0: none)", min=0, max=100_000),
    )
    harmonics: int = field(
        default=5,
        metadata=_key("-", "harmonics H of the nonlinear forced response (forced-response "
                      "--nonlinear, study --forced-nonlinear)", min=1, max=64),
    )
    continuation: str = field(
        default="grid",
        metadata=_key("-", "the design study's curve (study --forced-nonlinear): 'grid' "
                      "(Newton per frequency of forced.points, from the last) or "
                      "'arclength' (the grid, then the curve traced through its folds by "
                      "pseudo-arclength continuation over the band)",
                      choices=("grid", "arclength")),
    )
    over: str = field(
        default="frequency",
        metadata=_key("-", "what the nonlinear forced response runs over: 'frequency' (the "
                      "excitation at the configured speed's stiffness) or 'speed' (the rotor "
                      "speed w / n_s of each excitation frequency w: the stiffness follows "
                      "it, centrifugal stiffening less spin softening, and the curve is the "
                      "Campbell crossing itself; needs segment.prestress at wheel.speed_hz > "
                      "0 to move the stiffness)",
                      choices=("frequency", "speed")),
    )
    exact: bool = field(
        default=True,
        metadata=_key("-", "the nonlinear peak made exact (forced-response --nonlinear, "
                      "study --forced-nonlinear): the state at the refined peak by shooting "
                      "on the transient's equations, its amplitude and Floquet multipliers in "
                      "every ND beside the harmonic balance's (about a minute on the paper "
                      "wheel); false: the balance's peak alone"),
    )


def read_mistuning_file(name: str, source: str, blades: int) -> np.ndarray:
    """``(blades,)`` delta_s of the file ``name`` (``mistuning.file``, relative to the TOML
    ``source``); raises ``ValueError`` with a message naming the file.

    The file is read once per process while it is unchanged (same path, size and
    modification time): a study validates and uses every case's configuration, which would
    otherwise read it twice per case."""
    path = beside_toml(name, source)
    values = _read_values(name, os.path.abspath(path), file_stamp(path))
    if values.size != blades:
        raise ValueError(f"{name}: {values.size} values for {blades} blades (one per blade)")
    bad = np.flatnonzero(~np.isfinite(values) | (np.abs(values) > MISTUNING_LIMIT))
    if bad.size:
        raise ValueError(f"{name}: blade {bad[0]}'s value {values[bad[0]]!r} is not a finite "
                         f"number within +-{MISTUNING_LIMIT}")
    return values.copy()


@functools.lru_cache(maxsize=16)
def _read_values(name: str, path: str, stamp) -> np.ndarray:
    """The numbers of a ``.npy`` or text file (``stamp``: its size and modification time, the
    cache key that makes an edited file read again); ``ValueError`` naming ``name``."""
    why = input_file_problem(path)
    if why:
        raise ValueError(f"{name}: {why}")
    if name.lower().endswith(".npy"):
        try:
            values = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise ValueError(f"{name}: cannot be read as .npy ({exc})") from None
        if not isinstance(values, np.ndarray):  # an .npz archive: np.load gives an NpzFile
            values.close()
            raise ValueError(f"{name}: is an .npz archive, not a single .npy array")
        if values.dtype.kind not in "iuf":
            raise ValueError(f"{name}: holds {values.dtype}, not numbers")
        return np.asarray(values, dtype=float).reshape(-1)
    try:
        with open(path, encoding="utf-8-sig") as fh:  # a BOM (Excel) is not data
            text = fh.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: cannot be read ({exc})") from None
    words = [w for line in text.splitlines() for w in
             re.split(r"[,;\s]+", line.split("#")[0]) if w]
    values = np.empty(len(words))
    for i, word in enumerate(words):
        try:
            values[i] = float(word)
        except ValueError:
            raise ValueError(f"{name}: value {i + 1} ({quoted(word)}) is not a number") from None
    return values


def mistuning_problems(cfg: Any, source: str, problems: list[str]) -> None:
    """The pattern's length and the pattern file (read here, so that a missing or short file
    is reported with every other problem of the configuration)."""
    mt, blades = cfg.mistuning, cfg.wheel.blades
    if not isinstance(blades, int):
        return
    pattern = mt.pattern
    if isinstance(pattern, tuple) and pattern and len(pattern) != blades:
        problems.append(f"mistuning.pattern: {len(pattern)} values for {blades} blades "
                        "(one per blade)")
    if isinstance(mt.file, str) and mt.file and not path_problem(mt.file):  # else said
        try:
            read_mistuning_file(mt.file, source, blades)
        except ValueError as exc:
            problems.append(f"mistuning.file: {exc}")


def forced_problems(cfg: Any, problems: list[str]) -> None:
    """``forced.band_hz``: empty or ``[lo, hi]`` with ``lo < hi``; ``forced.family`` below
    the segment modes of a free-interface basis (a basis with attachment or enrichment
    vectors holds more families: :func:`~wheelrom.analysis.forced_peak.resonance` checks
    against the model)."""
    band, fam, m = cfg.forced.band_hz, cfg.forced.family, cfg.wheel.modes_per_segment
    if isinstance(band, tuple) and band and all(is_number(v) for v in band):
        if len(band) != 2 or not band[0] < band[1] or not all(math.isfinite(v) for v in band):
            problems.append(f"forced.band_hz: expected [] (automatic) or [lo, hi] with "
                            f"lo < hi [Hz], got {list(band)}")
    free = getattr(cfg.wheel, "basis", "free") == "free"
    if isinstance(fam, int) and isinstance(m, int) and fam >= m and free:
        problems.append(f"forced.family: {fam} is not below wheel.modes_per_segment ({m})")
