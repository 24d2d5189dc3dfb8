"""Stage 1, configuration: one TOML file mapped onto frozen dataclasses, defaults = the paper's
Table 1 (:mod:`.model`: the schema, ``load``, the cross-checks), the field converter and file
resolver (:mod:`.values`), the shared ranges and the options that set keys (:mod:`.limits`), the
``[contacts]`` and ``[friction]`` sections with the contact law (:mod:`.contacts`), the
``[forced]`` and ``[mistuning]`` sections (:mod:`.forced`), the ``[flutter]`` section and its
aerodynamic damping table (:mod:`.aero`), the ``[limit_cycle]`` (:mod:`.limit_cycle`) and
``[settle]`` (:mod:`.settle`) sections, and the cases of a
``[study]`` (:mod:`.study`).

May import: :mod:`wheelrom.runtime`. This face re-exports the schema, so
``from wheelrom import config; config.load(...)`` and ``from wheelrom.config import Config``
keep working.
"""

from wheelrom.config.limits import with_option
from wheelrom.config.model import (
    CONTACT_KINDS,
    Config,
    ConfigError,
    ContactConfig,
    ContactsConfig,
    ExcitationConfig,
    FlutterConfig,
    ForcedConfig,
    FrictionConfig,
    MistuningConfig,
    OutputConfig,
    SegmentConfig,
    StudyConfig,
    SweepConfig,
    TimeConfig,
    WheelConfig,
    from_dict,
    load,
    parse_override,
    sample_every,
    to_dict,
    to_toml,
)

__all__ = [
    "CONTACT_KINDS", "Config", "ConfigError", "ContactConfig", "ContactsConfig",
    "ExcitationConfig", "FlutterConfig", "ForcedConfig", "FrictionConfig", "MistuningConfig",
    "OutputConfig", "SegmentConfig", "StudyConfig", "SweepConfig", "TimeConfig", "WheelConfig",
    "from_dict", "load", "parse_override", "sample_every", "to_dict", "to_toml", "with_option",
]
