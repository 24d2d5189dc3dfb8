"""TOML values of the configuration in and out: the converters of the keys that are not plain
numbers or strings (contact stiffness tables, node-set coordinates) and the TOML writer of
``wheelrom config show``. Generic over the dataclasses of :mod:`wheelrom.config`."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import fields
from typing import Any


def is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def check_number(where: str, value: Any, meta: Mapping[str, Any], problems: list[str]) -> bool:
    if not is_number(value):
        problems.append(f"{where}: expected a number, got {value!r}")
        return False
    if not math.isfinite(value):
        problems.append(f"{where}: must be finite, got {value!r}")
        return False
    unit = meta.get("unit", "")
    unit = "" if unit == "-" else f" {unit}"
    if "gt" in meta and not value > meta["gt"]:
        problems.append(f"{where}: must be > {meta['gt']}{unit}, got {value!r}")
        return False
    if "min" in meta and value < meta["min"]:
        problems.append(f"{where}: must be >= {meta['min']}{unit}, got {value!r}")
        return False
    if "max" in meta and value > meta["max"]:
        problems.append(f"{where}: must be <= {meta['max']}{unit}, got {value!r}")
        return False
    return True


def convert_stiffness(where: str, value: Any, problems: list[str]) -> Any:
    if isinstance(value, str):
        if value != "fe":
            problems.append(f"{where}: expected a number, a table or 'fe', got {value!r}")
        return value
    if is_number(value):
        check_number(where, value, {"gt": 0.0, "unit": "N/m"}, problems)
        return float(value)
    if isinstance(value, list | tuple) and len(value) >= 2:
        rows = []
        for i, row in enumerate(value):
            if not (isinstance(row, list | tuple) and len(row) == 2):
                problems.append(f"{where}[{i}]: expected [angle_deg, stiffness], got {row!r}")
                return value
            a_ok = check_number(f"{where}[{i}][0]", row[0], {"min": 0.0, "max": 90.0}, problems)
            k_ok = check_number(f"{where}[{i}][1]", row[1], {"gt": 0.0}, problems)
            if not (a_ok and k_ok):
                return value
            rows.append((float(row[0]), float(row[1])))
        angles = [r[0] for r in rows]
        if any(b <= a for a, b in zip(angles, angles[1:], strict=False)):
            problems.append(f"{where}: table angles must increase strictly")
        return tuple(rows)
    problems.append(f"{where}: expected a number, a table [[angle, N/m], ...] or 'fe'")
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


def to_toml(cfg: Any, comments: bool = True) -> str:
    """The effective configuration (a :class:`wheelrom.config.Config`) as TOML, with units and
    help as comments."""
    lines: list[str] = []

    def section(obj: Any, name: str) -> None:
        plain = [f for f in fields(obj) if not dataclasses.is_dataclass(getattr(obj, f.name))]
        skip = ("node_sets",) if name else ("source", "node_sets")
        plain = [f for f in plain if f.name not in skip]
        if plain:
            lines.append(f"[{name}]")
            for f in plain:
                text = f"{f.name} = {_toml_value(getattr(obj, f.name))}"
                if comments and f.metadata:
                    text = f"{text:<40} # [{f.metadata['unit']}] {f.metadata['help']}"
                lines.append(text)
            lines.append("")
        if name == "segment" and obj.node_sets:
            lines.append("[segment.node_sets]")
            for k, pts in obj.node_sets.items():
                lines.append(f"{k} = {_toml_value([list(p) for p in pts])}")
            lines.append("")
        for f in fields(obj):
            value = getattr(obj, f.name)
            if dataclasses.is_dataclass(value):
                section(value, f"{name}.{f.name}" if name else f.name)

    section(cfg, "")
    return "\n".join(lines).rstrip() + "\n"
