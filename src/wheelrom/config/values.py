"""TOML values of the configuration in and out: the converters of the keys that are not plain
numbers or strings (contact stiffness tables, node-set coordinates) and the TOML writer of
``wheelrom config show``. Generic over the dataclasses of :mod:`wheelrom.config`."""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import re
import stat
from collections.abc import Mapping, Sequence
from dataclasses import fields
from typing import Any


def field_key(unit: str, help: str, **check: Any) -> dict[str, Any]:
    """Field metadata: unit, one-line help and validation bounds (min, max, gt, choices)."""
    return {"unit": unit, "help": help, **check}


#: characters of a user's value an error message quotes: a 50 MB string pasted into a key
#: must not come back as a 50 MB message (and into a log)
SHOWN = 60


def shown(value: Any) -> str:
    """``value`` as an error message quotes it (``repr``), cut after :data:`SHOWN` characters
    with its size: ``'aaaa...... (50000000 characters)'``."""
    text = repr(value)
    if len(text) <= SHOWN:
        return text
    if isinstance(value, list | tuple | Mapping):
        size = f"{len(value)} items"
    else:
        size = f"{len(value) if isinstance(value, str | bytes) else len(text)} characters"
    return f"{text[:SHOWN]}... ({size})"


def cut(text: str, limit: int = SHOWN) -> str:
    """A user's text (a key, a ``--set`` argument) as an error message shows it: at most
    ``limit`` characters, then its length."""
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


#: characters of one problem line at most: each names a key and quotes at most a cut of its
#: value (:func:`~wheelrom.config.values.shown`); this bounds a line that quotes user text
#: some other way (a key's name, a path)
MAX_PROBLEM = 1000


class ConfigError(ValueError):
    """Invalid configuration; ``problems`` lists one message per offending key."""

    def __init__(self, problems: Sequence[str]):
        self.problems = [cut(p, MAX_PROBLEM) for p in problems]
        super().__init__("invalid configuration:\n  " + "\n  ".join(self.problems))


#: the stiffest spring a key may give [N/m] (10 kN/um): no contact, arm or cut-face coupling
#: is stiffer than the steel around it; beyond it a stuck contact only adds a spurious stiff
#: mode (k_t = 1e14 N/m put one at 81 kHz on the small wheel, 1e30 a false instability at
#: 3.7 MHz)
MAX_STIFFNESS = 1e10


def is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def bound_text(bound: float) -> str:
    """A range's bound as a message gives it: ``90.0``, ``0.0``, but ``1e+10`` (not eleven
    digits)."""
    return str(bound) if bound == 0 or 1e-4 <= abs(bound) < 1e5 else f"{bound:g}"


def range_text(meta: Mapping[str, Any]) -> str:
    """A key's range as ``config show`` gives it after the unit: ``", 0.0..90.0"``,
    ``", > 0.0"``, ``", >= 3"``, ``", > 0.0, <= 1e+10"``; "" without one."""
    low = (f"> {bound_text(meta['gt'])}" if "gt" in meta else
           f">= {bound_text(meta['min'])}" if "min" in meta else "")
    high = f"<= {bound_text(meta['max'])}" if "max" in meta else ""
    if "min" in meta and high:
        return f", {bound_text(meta['min'])}..{bound_text(meta['max'])}"
    return "".join(f", {part}" for part in (low, high) if part)


def check_number(where: str, value: Any, meta: Mapping[str, Any], problems: list[str]) -> bool:
    if not is_number(value):
        problems.append(f"{where}: expected a number, got {shown(value)}")
        return False
    if not math.isfinite(value):
        problems.append(f"{where}: must be finite, got {shown(value)}")
        return False
    unit = meta.get("unit", "")
    unit = "" if unit == "-" else f" {unit}"
    if "gt" in meta and not value > meta["gt"]:
        problems.append(f"{where}: must be > {bound_text(meta['gt'])}{unit}, got {shown(value)}")
        return False
    if "min" in meta and value < meta["min"]:
        problems.append(f"{where}: must be >= {bound_text(meta['min'])}{unit}, got "
                        f"{shown(value)}")
        return False
    if "max" in meta and value > meta["max"]:
        problems.append(f"{where}: must be <= {bound_text(meta['max'])}{unit}, got "
                        f"{shown(value)}")
        return False
    return True


def convert_stiffness(where: str, value: Any, problems: list[str]) -> Any:
    if isinstance(value, str):
        if value != "fe":
            problems.append(f"{where}: expected a number, a table or 'fe', got {shown(value)}")
        return value
    if is_number(value):
        check_number(where, value, {"gt": 0.0, "max": MAX_STIFFNESS, "unit": "N/m"}, problems)
        return float(value)
    if isinstance(value, list | tuple) and len(value) >= 2:
        rows = []
        for i, row in enumerate(value):
            if not (isinstance(row, list | tuple) and len(row) == 2):
                problems.append(f"{where}[{i}]: expected [angle_deg, stiffness], got {shown(row)}")
                return value
            a_ok = check_number(f"{where}[{i}][0]", row[0], {"min": 0.0, "max": 90.0}, problems)
            k_ok = check_number(f"{where}[{i}][1]", row[1],
                                {"gt": 0.0, "max": MAX_STIFFNESS, "unit": "N/m"}, problems)
            if not (a_ok and k_ok):
                return value
            rows.append((float(row[0]), float(row[1])))
        angles = [r[0] for r in rows]
        if any(b <= a for a, b in zip(angles, angles[1:], strict=False)):
            problems.append(f"{where}: table angles must increase strictly")
        return tuple(rows)
    problems.append(f"{where}: expected a number, a table [[angle, N/m], ...] or 'fe'")
    return value


def convert_tangential_stiffness(where: str, value: Any, problems: list[str]) -> Any:
    """``k_t`` of the elastic law: a number > 0 [N/m] or ``"mindlin"``."""
    if isinstance(value, str):
        if value != "mindlin":
            problems.append(f"{where}: expected a number [N/m] or 'mindlin', got {value!r}")
        return value
    if check_number(where, value, {"gt": 0.0, "max": MAX_STIFFNESS, "unit": "N/m"}, problems):
        return float(value)
    return value


def convert_node_sets(where: str, value: Any, problems: list[str]) -> Any:
    if not isinstance(value, Mapping):
        problems.append(f"{where}: expected a table name = [[x, y, z], ...]")
        return {}
    out = {}
    for name, pts in value.items():
        ok = (
            isinstance(pts, list)
            and pts
            and all(
                isinstance(p, list) and len(p) == 3 and all(is_number(c) for c in p) for p in pts
            )
        )
        if not ok:
            problems.append(f"{where}.{name}: expected a list of [x, y, z] points in m")
            continue
        out[name] = tuple(tuple(float(c) for c in p) for p in pts)
    return out


def convert_study_table(where: str, value: Any, problems: list[str]) -> Any:
    """``study.grid`` / ``study.zip``: dotted key -> list of values or a ``start:stop:step``
    text; nested tables (TOML's unquoted dotted keys) are flattened to dotted keys. Only the
    shape is checked here; the keys and values are checked against the configuration by
    :mod:`wheelrom.config.study`."""
    if not isinstance(value, Mapping):
        problems.append(f"{where}: expected a table dotted.key = [values]")
        return {}
    out: dict[str, Any] = {}

    def walk(table: Mapping[str, Any], prefix: str) -> None:
        for key, item in table.items():
            if isinstance(item, Mapping):
                walk(item, f"{prefix}{key}.")
            elif isinstance(item, list | tuple) and item and all(
                is_number(v) or isinstance(v, str | bool) for v in item
            ):
                out[prefix + key] = tuple(item)
            elif isinstance(item, str) and where.endswith("grid"):
                out[prefix + key] = item
            else:
                text = "a non-empty list of values" + (
                    " or 'start:stop:step'" if where.endswith("grid") else "")
                problems.append(f"{where}.{prefix}{key}: expected {text}, got {shown(item)}")

    walk(value, "")
    return out


def _toml_key(key: str) -> str:
    return key if key.replace("_", "").replace("-", "").isalnum() else _toml_value(key)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


#: keys that name a file, resolved beside the TOML, with the value that names none
FILE_KEYS = {"segment.source": "builtin", "mistuning.file": "", "study.cases": "",
             "flutter.table": ""}


#: the longest path and file name the operating system opens (Linux's PATH_MAX, NAME_MAX)
MAX_PATH, MAX_NAME = 4096, 255


def path_problem(name: str) -> str | None:
    """Why the value ``name`` of a file key (:data:`FILE_KEYS`) cannot name a file (None: it
    may): longer than a path or one of its names can be. Checked with the configuration,
    so that no reader quotes a 50 MB "path" back into a message (the value is cut:
    :func:`shown`)."""
    if len(name) > MAX_PATH:
        return f"{shown(name)} is no file name (a path has at most {MAX_PATH} characters)"
    longest = max(name.replace("\\", "/").split("/"), key=len)
    if len(longest) > MAX_NAME:
        return (f"{shown(name)} is no file name (one of its names has {len(longest)} "
                f"characters, at most {MAX_NAME})")
    return None


def to_toml(cfg: Any, comments: bool = True) -> str:
    """The effective configuration (a :class:`wheelrom.config.Config`) as TOML, with units and
    help as comments. File keys (:data:`FILE_KEYS`) are written as absolute paths: the text
    means the same wherever it is saved (``config show sub/x.toml > y.toml``) or read back
    (the ``config`` attribute of a results file, read by ``animate`` from any directory)."""
    lines: list[str] = []
    source = getattr(cfg, "source", "")

    def value_of(obj: Any, name: str, key: str) -> Any:
        value = getattr(obj, key)
        if f"{name}.{key}" in FILE_KEYS and value != FILE_KEYS[f"{name}.{key}"]:
            return os.path.abspath(beside_toml(value, source))
        return value

    def section(obj: Any, name: str) -> None:
        plain = [f for f in fields(obj) if not dataclasses.is_dataclass(getattr(obj, f.name))]
        skip = ("node_sets",) if name else ("source", "node_sets")
        plain = [f for f in plain if f.name not in skip and not f.metadata.get("study_table")]
        if plain:
            lines.append(f"[{name}]")
            for f in plain:
                text = f"{f.name} = {_toml_value(value_of(obj, name, f.name))}"
                if comments and f.metadata:
                    text = (f"{text:<40} # [{f.metadata['unit']}{range_text(f.metadata)}] "
                            f"{f.metadata['help']}")
                lines.append(text)
            lines.append("")
        if name == "segment" and obj.node_sets:
            lines.append("[segment.node_sets]")
            for k, pts in obj.node_sets.items():
                lines.append(f"{k} = {_toml_value([list(p) for p in pts])}")
            lines.append("")
        for f in fields(obj):
            value = getattr(obj, f.name)
            if f.metadata.get("study_table") and value:
                lines.append(f"[{name}.{f.name}]")
                lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
                lines.append("")
            if dataclasses.is_dataclass(value):
                section(value, f"{name}.{f.name}" if name else f.name)

    section(cfg, "")
    return "\n".join(lines).rstrip() + "\n"


def suggest(name: str, valid: Sequence[str]) -> str:
    """" (did you mean 'x'?)" for a close match of an unknown key, else the valid ones."""
    # a name far longer than any key is no misspelling (and difflib indexes every character)
    longest = max(map(len, valid), default=0)
    close = difflib.get_close_matches(name, valid, n=1, cutoff=0.6) \
        if len(name) <= 2 * longest + 10 else []
    return f" (did you mean '{close[0]}'?)" if close else f" (valid: {', '.join(valid)})"


def convert_field(where: str, f: dataclasses.Field, value: Any, problems: list[str]) -> Any:
    """``value`` of the dataclass field ``f`` checked against its default's type and its
    metadata (``min``, ``gt``, ``choices``, ...); problems are appended, named by ``where``."""
    meta = f.metadata
    default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
    if f.name == "stiffness":
        return convert_stiffness(where, value, problems)
    if f.name == "tangential_stiffness":
        return convert_tangential_stiffness(where, value, problems)
    if f.name == "node_sets":
        return convert_node_sets(where, value, problems)
    if meta.get("study_table"):
        return convert_study_table(where, value, problems)
    if where.split("[")[0].endswith("flutter.mode"):  # "auto" or a mode number (-1: all)
        if isinstance(value, str) and value == "auto":
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            check_number(where, value, meta, problems)
            return value
        problems.append(f"{where}: expected 'auto' or an integer (-1: all modes), got "
                        f"{shown(value)}")
        return value
    if isinstance(default, bool):
        if not isinstance(value, bool):
            problems.append(f"{where}: expected true or false, got {shown(value)}")
        return value
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            problems.append(f"{where}: expected an integer, got {shown(value)}")
            return value
        check_number(where, value, meta, problems)
        return value
    if isinstance(default, float):
        if check_number(where, value, meta, problems):
            return float(value)
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            problems.append(f"{where}: expected a string, got {shown(value)}")
        elif any(where.split("[")[0].endswith(key) for key in FILE_KEYS) and path_problem(value):
            problems.append(f"{where}: {path_problem(value)}")
        elif "choices" in meta and value not in meta["choices"]:
            problems.append(
                f"{where}: {shown(value)} is not one of {', '.join(map(repr, meta['choices']))}"
            )
        return value
    if isinstance(default, tuple):
        if not isinstance(value, list | tuple) or not (value or meta.get("allow_empty")):
            problems.append(f"{where}: expected a non-empty list of numbers, got {shown(value)}")
            return value
        if meta.get("integers"):
            bad = [v for v in value if not isinstance(v, int) or isinstance(v, bool)]
            if bad:
                problems.append(f"{where}: expected a list of integers, got {shown(value)}")
                return value
        ok = all(check_number(f"{where}[{i}]", v, meta, problems) for i, v in enumerate(value))
        if not ok:
            return value
        return tuple(int(v) for v in value) if meta.get("integers") else tuple(map(float, value))
    raise AssertionError(f"no converter for {where}")  # pragma: no cover


def file_stamp(path: str):
    """``(size, mtime_ns)`` of ``path``, or None when it cannot be read: the cache key under
    which a file key's contents are read once per process while the file is unchanged."""
    try:
        stat = os.stat(path)
    except OSError:
        return None  # not there: the reader names the problem
    return stat.st_size, stat.st_mtime_ns


#: the largest input file a key names (``mistuning.file``, ``flutter.table``,
#: ``study.cases``) that is read: each holds at most a few numbers per blade or case
MAX_INPUT_BYTES = 64 << 20


def input_file_problem(path: str) -> str | None:
    """Why the input file ``path`` must not be read (None: it may, or it is missing and the
    reader says so): not a regular file (``/dev/zero``, a FIFO, a directory: read forever
    or never), or larger than :data:`MAX_INPUT_BYTES`."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file (a device, a FIFO or a directory); name a file"
    if info.st_size > MAX_INPUT_BYTES:
        return (f"is {info.st_size / 1e6:.1f} MB, more than the {MAX_INPUT_BYTES >> 20} MiB "
                "an input file of numbers may be")
    return None


def quoted(text: str) -> str:
    """A word read from a user's file, for an error message: quoted when it looks like a
    token (a number, a column or key name), else only its length. A key that points at the
    wrong file (``/etc/passwd``) must not print that file's lines into a log."""
    text = text.strip()
    if re.fullmatch(r"[A-Za-z0-9_.+\-]{1,40}", text):
        return repr(text)
    return f"a {len(text)}-character text (not shown)"


def beside_toml(name: str, source: str) -> str:
    """A file key's value (``mistuning.file``, ``study.cases``) as a path: relative to the
    TOML file of the configuration's ``source`` when it is one."""
    path = os.path.expanduser(name)
    toml = source.split(" + --set ")[0]
    if not os.path.isabs(path) and os.path.isfile(toml):
        path = os.path.join(os.path.dirname(os.path.abspath(toml)), path)
    return path
