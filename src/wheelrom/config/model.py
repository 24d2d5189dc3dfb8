"""Configuration: one TOML file mapped onto frozen dataclasses, defaults = the paper's Table 1.

Every key is declared once, in the dataclasses below, with its unit and its admissible range.
`load()` reads a file (or nothing: the built-in default case), applies ``--set`` overrides,
checks every key and raises :class:`ConfigError` listing *all* problems at once, each naming
the file and the dotted key.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from wheelrom.config.aero import FlutterConfig, aero_table_problems
from wheelrom.config.contacts import (
    CONTACT_KINDS,
    MAX_STIFFNESS,
    ContactConfig,
    ContactsConfig,
    FrictionConfig,
    law_problems,
)
from wheelrom.config.forced import (
    ForcedConfig,
    MistuningConfig,
    forced_problems,
    mistuning_problems,
)
from wheelrom.config.limit_cycle import LimitCycleConfig, limit_cycle_problems
from wheelrom.config.limits import (
    MAX_BLADES,
    MAX_FORCE,
    MAX_SIMULATED_TIME,
    MAX_SPEED_HZ,
    MAX_WINDOWS,
    MIN_STEP,
)
from wheelrom.config.settle import SettleConfig, settle_problems
from wheelrom.config.values import ConfigError, convert_field, cut, is_number, shown, suggest
from wheelrom.config.values import field_key as _key
from wheelrom.config.values import to_toml as to_toml  # re-exported: config.to_toml


@dataclass(frozen=True)
class WheelConfig:
    blades: int = field(default=66, metadata=_key("-", "number of rotor blades N", min=3,
                                                  max=MAX_BLADES))
    stator_vanes: int = field(
        default=64, metadata=_key("-", "number of stator vanes n_s (nozzle order)", min=1,
                                  max=MAX_BLADES)
    )
    speed_hz: float = field(default=50.0, metadata=_key("Hz", "rotor speed f_rev", min=0.0,
                                                        max=MAX_SPEED_HZ))
    coupling_stiffness: float = field(
        default=2e8, metadata=_key("N/m", "cut-face coupling springs c1", min=0.0,
                                   max=MAX_STIFFNESS)
    )
    modes_per_segment: int = field(
        default=10, metadata=_key("-", "segment modes m kept per blade", min=1, max=200)
    )
    damping_beta: float = field(
        default=5e-8, metadata=_key("s", "stiffness-proportional damping beta_D", min=0.0,
                                    max=1e-4)  # 1e-4 s: 2.5 % of critical at 80 Hz already
    )
    basis: str = field(
        default="attachment",
        metadata=_key(
            "-",
            "segment basis: 'free' (paper: m free-interface modes), 'enriched' (plus the "
            "2 lowest exact cyclic sector modes of ND 0, N/8, N/4, N/2: m + 12 vectors), "
            "'attachment' (plus static responses to unit forces at the contact nodes: "
            "m + 6 per contact kind) or 'enriched+attachment'",
            choices=("free", "enriched", "attachment", "enriched+attachment"),
        ),
    )


@dataclass(frozen=True)
class SegmentConfig:
    source: str = field(
        default="builtin", metadata=_key("-", "'builtin' or a volume mesh file readable by meshio")
    )
    preset: str = field(
        default="default",
        metadata=_key("-", "built-in mesh density", choices=("coarse", "default", "paper")),
    )
    young: float = field(default=2.1e11, metadata=_key("Pa", "Young's modulus E", min=1e9,
                                                       max=1.2e12))  # polymers to diamond
    poisson: float = field(
        default=0.3, metadata=_key("-", "Poisson's ratio nu", min=0.0, max=0.4999)
    )
    density: float = field(default=7850.0, metadata=_key("kg/m^3", "density rho", min=100.0,
                                                         max=25000.0))  # foams to osmium
    prestress: bool = field(
        default=True,
        metadata=_key(
            "-",
            "segment modes at wheel.speed_hz with centrifugal stress stiffening and spin "
            "softening (false: standstill modes)",
        ),
    )
    node_set_tolerance: float = field(
        default=1e-3,
        metadata=_key("m", "largest distance of a node picked by coordinates", gt=0.0,
                      max=0.1),
    )
    node_sets: Mapping[str, Any] = field(
        default_factory=dict,
        metadata=_key(
            "m",
            "node sets given as coordinates for a user mesh: name = [[x, y, z], ...]",
        ),
    )


@dataclass(frozen=True)
class ExcitationConfig:
    force: float = field(
        default=100.0,
        metadata=_key("N", "nozzle force amplitude F_b per excitation node (0: off)", min=0.0,
                      max=MAX_FORCE),
    )


@dataclass(frozen=True)
class TimeConfig:
    step: float = field(
        default=1e-5,
        metadata=_key("s", "fixed step: the exponential scheme's is set by the explicit contact "
                      "coupling (10 us gives RK 3bs's growth rates on the default wheel, 12.5 us "
                      "no longer; lowered off a resonance of a stiff segment mode, and to the "
                      "scheme's stability for the stuck contacts: the elastic law's 8.1 us); "
                      "RK 3bs is "
                      "stable up to 2 pi f_max step = 1.73 (the default attachment basis reaches "
                      "69 kHz: 3e-6)", min=MIN_STEP, max=MAX_SIMULATED_TIME),
    )
    scheme: str = field(
        default="exponential",
        metadata=_key("-", "'rk' (PETSc TS RK, 3bs: the paper's ode3) or 'exponential' "
                      "(ETDRK4 with the segment block A0 exact: docs/theory.md)",
                      choices=("rk", "exponential")),
    )
    end: float = field(
        default=1.5, metadata=_key("s", "simulated time", gt=0.0, max=MAX_SIMULATED_TIME)
    )
    window: float = field(default=0.0375, metadata=_key("s", "evaluation window", gt=0.0,
                                                        max=MAX_SIMULATED_TIME))
    start: str = field(
        default="rest",
        metadata=_key(
            "-", "'rest' or 'preload' (static equilibrium, SNES)", choices=("rest", "preload")
        ),
    )
    divergence_amplitude: float = field(
        default=1.0,
        metadata=_key("m", "tip amplitude beyond which a case is stopped as diverged", gt=0.0,
                      max=10.0),
    )
    perturbation: float = field(
        default=0.0,
        metadata=_key(
            "m", "largest tip displacement of the start perturbation: the lowest mode of every ND "
            "(contacts open) with random phases", min=0.0, max=0.1
        ),
    )
    seed: int = field(
        default=0,
        metadata=_key("-", "seed of the start perturbation (same for every case and rank)", min=0),
    )
    perturbation_waves: tuple[int, ...] = field(
        default=(),
        metadata=_key("-", "travelling waves k (blade s+1 leads by 2 pi k / N; 0..N-1) the start "
                      "perturbation seeds; [] = every one", min=0, integers=True,
                      allow_empty=True),
    )


@dataclass(frozen=True)
class OutputConfig:
    sample_rate_hz: float = field(
        default=20000.0,
        metadata=_key("Hz", "sample rate of the window statistics (tip amplitude, contact "
                      "forces, ND spectrum) and the divergence check", gt=0.0, max=1e7),
    )
    history_rate_hz: float = field(
        default=2000.0,
        metadata=_key("Hz", "rate of the stored tip history: every k-th statistics sample, "
                      "k = sample_rate_hz / history_rate_hz a whole number (at or above the "
                      "sample rate: every sample); 0: no tip history", min=0.0, max=1e7),
    )
    state_rate_hz: float = field(
        default=0.0,
        metadata=_key("Hz", "rate of the stored modal state history (q, q' of every blade, "
                      "for 'wheelrom animate' and 'contacts'), same rule; 0: none",
                      min=0.0, max=1e7),
    )


def sample_every(rate: float, sample_rate: float) -> int:
    """Every how many statistics samples (at ``sample_rate`` [Hz]) a history at ``rate`` [Hz]
    keeps one: ``round(sample_rate / rate)``, 1 at or above the sample rate, 0 for ``rate``
    0 (no history)."""
    if rate <= 0:
        return 0
    return max(1, int(round(sample_rate / rate)))


def _history_problems(out: OutputConfig, problems: list[str]) -> None:
    """``history_rate_hz`` / ``state_rate_hz``: 0, at least the sample rate, or the sample
    rate divided by a whole number (a history keeps every k-th statistics sample)."""
    rate = out.sample_rate_hz
    for name in ("history_rate_hz", "state_rate_hz"):
        value = getattr(out, name)
        if not (is_number(value) and is_number(rate)) or value <= 0 or value >= rate:
            continue
        k = rate / value
        if abs(k - round(k)) > 1e-6 * k:
            lo, hi = rate / math.ceil(k), rate / math.floor(k)
            problems.append(f"output.{name}: {value:g} Hz is not output.sample_rate_hz "
                            f"({rate:g} Hz) divided by a whole number (the history keeps every "
                            f"k-th statistics sample); use {lo:g} or {hi:g} Hz")


def _paper_shroud_angles() -> list[float]:
    return [5.0 * k for k in range(19)]


@dataclass(frozen=True)
class SweepConfig:
    tieboss_angles_deg: tuple[float, ...] = field(
        default=(45.0,), metadata=_key("deg", "tie-boss angles of the sweep", min=0.0, max=90.0)
    )
    shroud_angles_deg: tuple[float, ...] = field(
        default=tuple(_paper_shroud_angles()),
        metadata=_key("deg", "shroud angles of the sweep", min=0.0, max=90.0),
    )


@dataclass(frozen=True)
class StudyConfig:  # wheelrom study (docs/usage.md "Design studies"); none: the [sweep] grid
    grid: Mapping[str, Any] = field(default_factory=dict, metadata=_key(  # every combination
        "-", "axes: dotted.key = [values] or 'start:stop:step' (stop included)", study_table=True))
    zip: Mapping[str, Any] = field(default_factory=dict, metadata=_key(
        "-", "one axis: dotted.key = [values], the lists of equal length", study_table=True))
    cases: str = field(default="", metadata=_key(
        "-", "CSV file of cases, one axis (header: dotted keys; relative to the TOML); '' = none"))


@dataclass(frozen=True)
class Config:
    wheel: WheelConfig = field(default_factory=WheelConfig)
    segment: SegmentConfig = field(default_factory=SegmentConfig)
    excitation: ExcitationConfig = field(default_factory=ExcitationConfig)
    flutter: FlutterConfig = field(default_factory=FlutterConfig)
    contacts: ContactsConfig = field(default_factory=ContactsConfig)
    friction: FrictionConfig = field(default_factory=FrictionConfig)
    time: TimeConfig = field(default_factory=TimeConfig)
    output: OutputConfig = field(default_factory=OutputConfig)
    sweep: SweepConfig = field(default_factory=SweepConfig)
    mistuning: MistuningConfig = field(default_factory=MistuningConfig)
    forced: ForcedConfig = field(default_factory=ForcedConfig)
    study: StudyConfig = field(default_factory=StudyConfig)
    limit_cycle: LimitCycleConfig = field(default_factory=LimitCycleConfig)
    settle: SettleConfig = field(default_factory=SettleConfig)
    source: str = field(default="<built-in default>", compare=False)

    def replace(self, **changes: Any) -> Config:
        """Return a copy with dotted keys replaced: ``cfg.replace(**{"time.end": 0.1})``."""
        return from_dict(_set_nested(to_dict(self), changes), source=self.source)

    def contact(self, kind: str) -> ContactConfig:
        return getattr(self.contacts, kind)


# --------------------------------------------------------------------------------------
# dict <-> dataclass
# --------------------------------------------------------------------------------------


def to_dict(cfg: Any) -> dict[str, Any]:
    """Nested plain dict of a config (tuples as lists); omits ``source``."""
    out: dict[str, Any] = {}
    for f in fields(cfg):
        if isinstance(cfg, Config) and f.name == "source":
            continue
        value = getattr(cfg, f.name)
        if dataclasses.is_dataclass(value):
            out[f.name] = to_dict(value)
        elif isinstance(value, tuple):
            out[f.name] = list(value)
        elif isinstance(value, Mapping):
            out[f.name] = {k: v for k, v in value.items()}
        else:
            out[f.name] = value
    return out


def _set_nested(data: dict[str, Any], changes: Mapping[str, Any],
                merge: bool = False) -> dict[str, Any]:
    """``data`` with the dotted keys of ``changes`` set. ``merge`` (``--set``): a table value
    (``--set 'time={end=1.0}'``) is merged into the section it names, key by key, so the
    TOML's other keys of that section stay (replacing the section would have silently put
    them back to their defaults)."""
    for dotted, value in changes.items():
        node = data
        parts = dotted.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError([f"--set {cut(dotted)}: '{cut(part)}' is a key, not a "
                                   "section"])
        if merge and isinstance(value, Mapping) and isinstance(node.get(parts[-1]), dict):
            _merge(node[parts[-1]], value)
        else:
            node[parts[-1]] = value
    return data


def _merge(section: dict[str, Any], table: Mapping[str, Any]) -> None:
    """``table``'s keys into ``section``, nested tables into nested sections."""
    for key, value in table.items():
        if isinstance(value, Mapping) and isinstance(section.get(key), dict):
            _merge(section[key], value)
        else:
            section[key] = value


def _build(cls: type, data: Mapping[str, Any], prefix: str, problems: list[str]) -> Any:
    names = [f.name for f in fields(cls) if not (cls is Config and f.name == "source")]
    kwargs = {}
    for key, value in data.items():
        where = f"{prefix}{key}"
        if key not in names:
            kind = "section" if isinstance(value, Mapping) else "key"
            problems.append(f"{cut(where)}: unknown {kind}{suggest(key, names)}")
            continue
        f = next(f for f in fields(cls) if f.name == key)
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if dataclasses.is_dataclass(default):
            if not isinstance(value, Mapping):
                problems.append(f"{where}: expected a section [{where}]")
                continue
            # nested sections: start from the field's own default (shroud differs from tieboss)
            kwargs[key] = _build_from(default, value, f"{where}.", problems)
        else:
            kwargs[key] = convert_field(where, f, value, problems)
    return cls(**kwargs)


def _build_from(default: Any, data: Mapping[str, Any], prefix: str, problems: list[str]) -> Any:
    """Like `_build`, but unspecified keys keep the values of the given default instance."""
    built = _build(type(default), data, prefix, problems)
    given = set(data)
    changes = {f.name: getattr(built, f.name) for f in fields(default) if f.name in given}
    return dataclasses.replace(default, **changes)


def _shortest_window(end: float, window: float) -> float:
    """The shortest evaluation window [s] of the time grid (``transient.ts.time_grid``: the
    last window ends at ``end``, a ``window`` longer than ``end`` is shortened to it)."""
    windows = max(1, int(round(end / window)))
    last = end - (windows - 1) * window
    return last if windows == 1 else min(window, last)


def _cross_checks(cfg: Config, problems: list[str]) -> None:
    fr, t = cfg.friction, cfg.time
    for key in ("tieboss_angles_deg", "shroud_angles_deg"):  # a case computed twice
        angles = getattr(cfg.sweep, key)
        twice = sorted({a for a in angles if is_number(a) and list(angles).count(a) > 1})
        if twice:
            problems.append(f"sweep.{key}: {twice} listed more than once (each would be "
                            "computed twice)")
    if is_number(fr.dynamic) and is_number(fr.static) and fr.dynamic > fr.static:
        problems.append(
            f"friction.dynamic: must not exceed friction.static ({fr.dynamic} > {fr.static})"
        )
    # out-of-range times are reported by their own keys (time.end = 0 divided by zero here)
    times = (t.step, t.window, t.end)
    if all(is_number(v) and 0 < v <= MAX_SIMULATED_TIME for v in times):
        if t.step > t.window:
            problems.append(f"time.step: larger than time.window ({t.step} > {t.window} s)")
        elif t.end / t.window > MAX_WINDOWS:
            problems.append(f"time.window: {t.window:g} s cuts time.end ({t.end:g} s) into "
                            f"{t.end / t.window:.3g} windows; at most {MAX_WINDOWS} (each is "
                            "a row of every case's window statistics)")
        rate = cfg.output.sample_rate_hz
        if is_number(rate) and rate * t.step > 1.0:
            problems.append(f"output.sample_rate_hz: {rate} Hz exceeds 1/time.step")
        elif (is_number(rate) and _shortest_window(t.end, t.window) > 0
              and rate * _shortest_window(t.end, t.window) < 1.0 - 1e-9):
            shortest = _shortest_window(t.end, t.window)
            problems.append(
                f"output.sample_rate_hz: {rate} Hz leaves a window of {shortest:.6g} s without "
                f"a sample (its statistics would all be NaN); use at least {1 / shortest:.6g} Hz"
            )
    _history_problems(cfg.output, problems)
    w = cfg.wheel
    waves = t.perturbation_waves
    if isinstance(w.blades, int) and isinstance(waves, tuple) and all(
            isinstance(k, int) for k in waves):
        beyond = [k for k in waves if k >= w.blades]
        if beyond:
            problems.append(f"time.perturbation_waves: {beyond} not below wheel.blades = "
                            f"{w.blades} (travelling waves are 0..{w.blades - 1})")
        twice = sorted({k for k in waves if waves.count(k) > 1})
        if twice:
            problems.append(f"time.perturbation_waves: {twice} listed more than once (each "
                            "would be seeded twice)")
    if isinstance(cfg.flutter.mode, int) and isinstance(w.modes_per_segment, int):
        if cfg.flutter.mode >= w.modes_per_segment:
            problems.append(
                f"flutter.mode: {cfg.flutter.mode} is not below wheel.modes_per_segment "
                f"({w.modes_per_segment})"
            )
    law_problems(cfg, problems)
    for kind in CONTACT_KINDS:
        c = cfg.contact(kind)
        if is_number(c.profile_thickness) and is_number(c.arm_length):
            if c.profile_thickness >= c.arm_length:
                problems.append(
                    f"contacts.{kind}.profile_thickness: must be shorter than arm_length"
                )


def from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Config:
    """Validate a nested dict (as read from TOML) and return the frozen :class:`Config`."""
    problems: list[str] = []
    cfg = _build_from(Config(), data, "", problems)
    _cross_checks(cfg, problems)
    mistuning_problems(cfg, source, problems)
    forced_problems(cfg, problems)
    aero_table_problems(cfg, source, problems)
    limit_cycle_problems(cfg, problems)
    settle_problems(cfg, problems)
    if problems:
        raise ConfigError([f"{source}: {p}" for p in problems])
    return dataclasses.replace(cfg, source=source)


def parse_override(text: str) -> tuple[str, Any]:
    """Parse one ``--set section.key=value``; the value is TOML, else a bare string."""
    if "=" not in text:
        raise ConfigError([f"--set {cut(text)}: expected section.key=value"])
    key, raw = (s.strip() for s in text.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def load(path: str | Path | None = None, overrides: Sequence[str] = ()) -> Config:
    """Read a TOML file (``None``: built-in default case), apply ``--set`` overrides, validate."""
    data: dict[str, Any] = {}
    source = "<built-in default>"
    if path is not None:
        source = str(path)
        try:
            with open(path, "rb") as fh:  # a BOM (some Windows editors) is not TOML
                data = tomllib.loads(fh.read().decode("utf-8-sig"))
        except FileNotFoundError:
            raise ConfigError([f"{source}: file not found"]) from None
        except IsADirectoryError:
            raise ConfigError([f"{source}: is a directory, not a TOML file"]) from None
        except PermissionError:
            raise ConfigError([f"{source}: not readable (permission denied)"]) from None
        except UnicodeDecodeError as exc:
            raise ConfigError(
                [f"{source}: not UTF-8 text (byte {exc.start}); TOML files are UTF-8"]
            ) from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError([f"{source}: not valid TOML: {exc}"]) from None
    changes = dict(parse_override(o) for o in overrides)
    if changes:
        source += " + --set " + " ".join(f"{cut(k)}={shown(v)}" for k, v in changes.items())
    return from_dict(_set_nested(data, changes, merge=True), source=source)
