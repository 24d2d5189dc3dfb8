"""The physical ranges of the configuration's keys that more than one key or module shares
(each key's own range is in its field's metadata), and :func:`with_option`: a command-line
option that sets a key gets that key's range and checks, named as the option."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from wheelrom.config.values import MAX_STIFFNESS, ConfigError, cut

__all__ = ["MAX_BLADES", "MAX_FORCE", "MAX_SIMULATED_TIME", "MAX_SPEED_HZ", "MAX_STIFFNESS",
           "MAX_WINDOWS", "MIN_STEP", "with_option"]

#: the longest ``time.end`` [s]: far beyond any run (seconds), short of what overflows the
#: time grid (1e300 s)
MAX_SIMULATED_TIME = 1e4
#: the shortest ``time.step`` [s]: three decades below the stiffest basis's stable step
#: (3 us); a shorter one only multiplies the steps (1e4 s in 1e-12 s steps never ends)
MIN_STEP = 1e-9
#: the most evaluation windows a run may have (``time.end / time.window``): each is a row
#: of every case's window statistics, in memory and in the file
MAX_WINDOWS = 1_000_000
#: the most blades ``wheel.blades`` may give: beyond any bladed wheel (a few hundred); the
#: transient's dense ``K_R`` grows with its square (:func:`~wheelrom.transient.run.run_memory`)
MAX_BLADES = 1000
#: the fastest ``wheel.speed_hz`` [Hz] (60,000 rpm): beyond any steam turbine (50-250 Hz);
#: the built-in wheel's centrifugal strain leaves small-strain elasticity far below it (the
#: build refuses that: :data:`wheelrom.rom.build.MAX_PRESTRESS_STRAIN`)
MAX_SPEED_HZ = 1000.0
#: the largest force a key may give [N] (the nozzle's, per excitation node): far above any
#: wheel's (hundreds of N), short of what overflows the responses
MAX_FORCE = 1e6


def with_option(cfg, option: str, changes: Mapping[str, Any]):
    """``cfg`` with the keys that a command-line option sets in their place (``option``: the
    option as the user gave it, e.g. ``"--harmonics 1000"``; ``changes``: dotted key ->
    value): the keys' ranges and every cross-check apply as they would to the TOML, and a
    problem is one :class:`~wheelrom.runtime.errors.InputError` naming the option, not the
    key the user never wrote (``cfg`` itself is valid, so any problem is the option's)."""
    from wheelrom.runtime.errors import InputError

    try:
        return cfg.replace(**changes)
    except ConfigError as exc:
        keys_of: dict[str, list[str]] = {}  # one reason, the keys the option sets that give it
        for problem in exc.problems:
            problem = problem.removeprefix(f"{cfg.source}: ")
            key, _, why = problem.partition(": ")
            if key in changes or key.split("[")[0] in changes:
                keys_of.setdefault(why, []).append(key)
            else:
                keys_of.setdefault(problem, [])
        lines = [f"{why} (the range of {' and '.join(keys)}, which it sets)" if keys else why
                 for why, keys in keys_of.items()]
        raise InputError(f"{cut(option, 200)}: " + "; ".join(lines)) from None
