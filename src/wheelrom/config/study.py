"""The cases of a design study (``[study]`` of the configuration): which keys vary, over
which values, and the validated :class:`~wheelrom.config.Config` of every case.

A study is a product of axes, the first one slowest: every ``study.grid`` key is an axis of
its own (a list of values or ``start:stop:step``, stop included), the ``study.zip`` keys form
one axis together (lists of equal length), and the rows of the ``study.cases`` CSV file form
one axis. A configuration without any of them is the ``[sweep]`` grid: tie-boss angle x shroud
angle. Varied keys are numbers, ``true``/``false`` or named choices (``segment.preset``);
lists, tables, free text and the keys every case of one file must share (``wheel.blades``,
``time.end``, ``time.window``, ``output.*``, ``sweep.*``, ``study.*``) are refused. Every value
is checked like the key itself, then every case as a whole configuration; all problems are
listed at once, each naming the key (and the CSV row) it comes from.

:func:`model_key`, :func:`batch_key` and :func:`tuned_key` say which cases share a reduced
model, which may share one TS and which one tuned forced-response reference.
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import itertools
import json
import math
from dataclasses import dataclass

from wheelrom.config import CONTACT_KINDS, Config, ConfigError, from_dict, to_dict
from wheelrom.config.values import (
    beside_toml,
    convert_field,
    input_file_problem,
    is_number,
    quoted,
    shown,
)

#: the two keys of a study made from ``[sweep]``
ANGLE_KEYS = ("contacts.tieboss.angle_deg", "contacts.shroud.angle_deg")
#: keys the cases of one results file share (its layout: blade count and time grid)
SHARED_KEYS = ("wheel.blades", "time.end", "time.window")
SHARED_SECTIONS = ("output", "sweep", "study")
MAX_CASES = 100_000
#: keys that do not change the reduced model (forces and time only; the mistuning is put on
#: the group's tuned model per case: Monte Carlo realisations share one model)
FORCE_SECTIONS = ("excitation", "flutter", "friction", "time", "output", "sweep", "study",
                  "mistuning", "forced", "limit_cycle", "settle")
FORCE_WHEEL_KEYS = ("stator_vanes", "damping_beta")


@dataclass(frozen=True)
class Study:
    """The cases of a study: ``names`` (P,) dotted keys, ``axis`` (P,) the axis of each key,
    ``shape`` the length of every axis (product = C cases, first axis slowest), ``values``
    C tuples of the P values, ``configs`` the C validated configurations, ``legacy``: made
    from ``[sweep]``."""

    names: tuple[str, ...]
    axis: tuple[int, ...]
    shape: tuple[int, ...]
    values: tuple[tuple, ...]
    configs: tuple[Config, ...]
    legacy: bool = False

    @property
    def size(self) -> int:
        return len(self.configs)

    def label(self, i: int) -> str:
        """``key=value, ...`` of case ``i`` (short keys: the last two parts)."""
        return ", ".join(f"{short_name(k)}={_text(v)}"
                         for k, v in zip(self.names, self.values[i], strict=True))


def short_name(key: str) -> str:
    """``contacts.shroud.angle_deg`` -> ``shroud.angle_deg``."""
    return ".".join(key.split(".")[-2:])


def _text(v) -> str:
    return f"{v:g}" if is_number(v) else str(v).lower() if isinstance(v, bool) else str(v)


def expand(cfg: Config) -> Study:
    """The cases of ``cfg``'s study; raises :class:`ConfigError` listing every problem."""
    st = cfg.study
    if not (st.grid or st.zip or st.cases):
        return _legacy(cfg)
    problems: list[str] = []
    axes: list[list[tuple[str, list]]] = []  # per axis: (key, values) of its keys
    for key, spec in st.grid.items():
        values = _axis_values(f"study.grid.{key}", key, spec, problems)
        axes.append([(key, values)])
    if st.zip:
        zipped = [(k, _axis_values(f"study.zip.{k}", k, v, problems)) for k, v in st.zip.items()]
        lengths = {len(v) for _, v in zipped}
        if len(lengths) > 1:
            listing = ", ".join(f"{k}: {len(v)}" for k, v in zipped)
            problems.append(f"study.zip: lists of unequal length ({listing})")
        axes.append(zipped)
    if st.cases:
        axes.append(_csv_axis(cfg, problems))
    names = [k for ax in axes for k, _ in ax]
    twice = sorted({k for k in names if names.count(k) > 1})
    if twice:
        problems.append(f"study: {', '.join(twice)} varied twice (grid, zip and cases each "
                        "name a key once)")
    _raise(cfg, problems)
    shape = tuple(len(ax[0][1]) for ax in axes)
    if math.prod(shape) > MAX_CASES:
        _raise(cfg, [f"study: {math.prod(shape)} cases (more than {MAX_CASES})"])
    values = []
    for index in itertools.product(*(range(n) for n in shape)):
        values.append(tuple(v[index[a]] for a, ax in enumerate(axes) for _, v in ax))
    axis = tuple(a for a, ax in enumerate(axes) for _ in ax)
    configs = case_configs(cfg, names, values)
    return Study(tuple(names), axis, shape, tuple(values), configs)


def _legacy(cfg: Config) -> Study:
    tb, sh = cfg.sweep.tieboss_angles_deg, cfg.sweep.shroud_angles_deg
    values = tuple(itertools.product(tb, sh))
    configs = case_configs(cfg, list(ANGLE_KEYS), values)
    return Study(ANGLE_KEYS, (0, 1), (len(tb), len(sh)), values, configs, legacy=True)


def case_configs(cfg: Config, names: list[str], values) -> tuple[Config, ...]:
    """The configuration of every case (``cfg`` with ``names`` set to the case's values),
    each validated as a whole; raises :class:`ConfigError` with every case that fails."""
    base = to_dict(cfg)
    out, problems = [], []
    for i, row in enumerate(values):
        data = copy.deepcopy(base)
        for key, value in zip(names, row, strict=True):
            node = data
            *path, last = key.split(".")
            for part in path:
                node = node[part]
            node[last] = value
        try:
            out.append(from_dict(data, source=cfg.source))
        except ConfigError as exc:
            label = ", ".join(f"{k}={_text(v)}" for k, v in zip(names, row, strict=True))
            problems += [f"study case {i} ({label}): {p.removeprefix(cfg.source + ': ')}"
                         for p in exc.problems]
    _raise(cfg, problems)
    return tuple(out)


def _raise(cfg: Config, problems: list[str], most: int = 12) -> None:
    if problems:
        listed = problems[:most]
        if len(problems) > most:
            listed.append(f"... and {len(problems) - most} more")
        raise ConfigError([f"{cfg.source}: {p}" for p in listed])


def study_field(key: str) -> tuple[dataclasses.Field | None, str | None]:
    """``(field, None)`` of a dotted key that a study may vary, or ``(None, why not)``."""
    node: object = Config()
    parts = key.split(".")
    for depth, part in enumerate(parts):
        names = [f.name for f in dataclasses.fields(node)
                 if not (isinstance(node, Config) and f.name == "source")]
        if part not in names:
            where = ".".join(parts[:depth]) or "the configuration"
            return None, f"unknown key ({quoted(part)} is not in {where})"
        f = next(f for f in dataclasses.fields(node) if f.name == part)
        value = getattr(node, part)
        if dataclasses.is_dataclass(value):
            if depth == len(parts) - 1:
                return None, "is a section, not a key"
            node = value
            continue
        if depth != len(parts) - 1:
            return None, f"unknown key ({quoted(part)} is a key, not a section)"
        return _variable(key, f, value)
    return None, "unknown key"  # pragma: no cover


def _variable(key: str, f: dataclasses.Field, default) -> tuple:
    if key.split(".")[0] in SHARED_SECTIONS or key in SHARED_KEYS:
        return None, ("cannot vary: the cases of one study share the blade count and the time "
                      "grid (wheel.blades, time.end, time.window, output.*); run one study each")
    # a number or a named default ('auto', 'mindlin'): varied over numbers and that name
    either = key == "flutter.mode" or key.endswith(".tangential_stiffness")
    numeric = is_number(default) or isinstance(default, bool) or either
    if not (numeric or (isinstance(default, str) and "choices" in f.metadata)):
        return None, ("is not numeric: a study varies numbers, true/false and named choices, "
                      "not lists, tables or free text")
    return f, None


def _axis_values(where: str, key: str, spec, problems: list[str]) -> list:
    """The values of one varied key, each checked like the key itself."""
    f, why = study_field(key)
    if f is None:
        problems.append(f"{where}: {why}")
        return []
    if isinstance(spec, str):
        values = parse_range(where, spec, problems)
    else:
        values = list(spec)
    for i, value in enumerate(values):
        convert_field(f"{where}[{i}]", f, value, problems)
    return values


def parse_range(where: str, text: str, problems: list[str]) -> list:
    """``"start:stop:step"`` -> the values ``start, start + step, ...`` up to ``stop``
    (included when it is reached within 1e-9 steps); integers when all three are."""
    parts = [p.strip() for p in text.split(":")]
    if len(parts) != 3:
        problems.append(f"{where}: {shown(text)} is not start:stop:step")
        return []
    try:
        numbers = [int(p) if p.lstrip("+-").isdigit() else float(p) for p in parts]
    except ValueError:
        problems.append(f"{where}: {shown(text)} is not start:stop:step (numbers)")
        return []
    start, stop, step = numbers
    if not all(math.isfinite(v) for v in numbers):
        problems.append(f"{where}: {shown(text)} start, stop and step must be finite")
        return []
    if step <= 0:
        problems.append(f"{where}: {shown(text)} step must be positive")
        return []
    if stop < start:
        problems.append(f"{where}: {shown(text)} stop is below start")
        return []
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_CASES:
        problems.append(f"{where}: {shown(text)} gives {count} values (more than {MAX_CASES})")
        return []
    if all(isinstance(v, int) for v in numbers):
        return [start + k * step for k in range(count)]
    return [round(start + k * step, 12) for k in range(count)]


def _cell(text: str):
    """A CSV cell as TOML would read it: an integer, a float, true/false, else the text."""
    t = text.strip()
    if t.lower() in ("true", "false"):
        return t.lower() == "true"
    for kind in (int, float):
        try:
            return kind(t)
        except ValueError:
            pass
    return t


def _csv_axis(cfg: Config, problems: list[str]) -> list[tuple[str, list]]:
    """The ``study.cases`` file: one axis, a column per key, a case per non-empty row."""
    path = beside_toml(cfg.study.cases, cfg.source)
    name = cfg.study.cases
    why = input_file_problem(path)
    if why:
        problems.append(f"study.cases: {name}: {why}")
        return []
    try:
        # utf-8-sig: a byte-order mark (Excel's "CSV UTF-8") is not part of the first key
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [(n, r) for n, r in enumerate(csv.reader(fh), start=1)
                    if any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError) as exc:
        problems.append(f"study.cases: {name}: cannot be read ({exc})")
        return []
    if len(rows) < 2:
        problems.append(f"study.cases: {name}: needs a header of dotted keys and a row per case")
        return []
    header = [h.strip() for h in rows[0][1]]
    fields = []
    for column, key in enumerate(header, start=1):
        f, why = study_field(key)
        if f is None:
            problems.append(f"{name} column {column} ({quoted(key)}): {why}")
        fields.append(f)
    columns: list[list] = [[] for _ in header]
    for line, row in rows[1:]:
        if len(row) != len(header):
            problems.append(f"{name} row {line}: {len(row)} values for {len(header)} columns")
            continue
        for c, (key, f, text) in enumerate(zip(header, fields, row, strict=True)):
            value = _cell(text)
            if f is not None:
                numeric = is_number(f.default) if f.default is not dataclasses.MISSING else True
                if numeric and not is_number(value):
                    problems.append(f"{name} row {line} column {key}: {quoted(text)} is not "
                                    "a number")
                else:
                    convert_field(f"{name} row {line} column {key}", f, value, problems)
            columns[c].append(value)
    return list(zip(header, columns, strict=True))


def _drop(data: dict, dotted: str) -> None:
    *path, last = dotted.split(".")
    for part in path:
        data = data.get(part, {})
    data.pop(last, None)


def model_key(cfg: Config) -> str:
    """What the reduced model of ``cfg`` depends on, as text: cases with the same key share
    one model (:func:`model_data`)."""
    return json.dumps(model_data(to_dict(cfg)), sort_keys=True, default=str)


def model_data(data: dict) -> dict:
    """The keys of a configuration's nested dict (``to_dict``, or TOML read back) the reduced
    model depends on (a copy): everything but the force and time keys and
    ``[mistuning]``, which each case puts on the shared tuned model; a contact's stiffness,
    arm length and arm axial stiffness only through ``stiffness = "fe"``."""
    data = copy.deepcopy(data)
    for section in FORCE_SECTIONS:
        data.pop(section, None)
    for key in FORCE_WHEEL_KEYS:
        _drop(data, f"wheel.{key}")
    _drop(data, "contacts.law")
    for kind in CONTACT_KINDS:
        _drop(data, f"contacts.{kind}.angle_deg")
        _drop(data, f"contacts.{kind}.normal_preload")
        _drop(data, f"contacts.{kind}.tangential_stiffness")
        if data.get("contacts", {}).get(kind, {}).get("stiffness") != "fe":
            for key in ("stiffness", "arm_length", "arm_axial_stiffness"):
                _drop(data, f"contacts.{kind}.{key}")
    return data


def batch_key(cfg: Config) -> str:
    """Cases with the same key may be integrated in one TS: everything but the contact
    angles agrees (:func:`wheelrom.transient.layout.check_batchable`; the transient splits
    them further where their steps or, under the elastic law with an angle-dependent
    ``k_c``, their propagated springs differ: ``wheelrom.transient.run._step_groups``)."""
    data = to_dict(cfg)
    for kind in CONTACT_KINDS:
        _drop(data, f"contacts.{kind}.angle_deg")
    return json.dumps(data, sort_keys=True, default=str)


def tuned_key(cfg: Config) -> str:
    """Cases with the same key differ only in their mistuning: they share one tuned forced
    response reference (:mod:`wheelrom.studies.mistuning`)."""
    data = to_dict(cfg)
    data.pop("mistuning", None)
    return json.dumps(data, sort_keys=True, default=str)
