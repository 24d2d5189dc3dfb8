"""The ``[contacts]`` and ``[friction]`` sections: the contact kinds (tie-boss, shroud) with
their geometry, preload and stiffnesses, and the contact law (the paper's regularised Coulomb
law of the slip velocity or the elastic Coulomb contact; docs/theory.md, "Contact laws")."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from wheelrom.config.values import MAX_STIFFNESS, is_number
from wheelrom.config.values import field_key as _key

CONTACT_KINDS = ("tieboss", "shroud")
#: the largest ``contacts.*.normal_preload`` [N]: far above any wheel's (hundreds of N), short
#: of what overflows the contact laws (1e308 N)
MAX_NORMAL_PRELOAD = 1e7
#: the largest arm or height [m]: beyond any wheel (the paper's radius is 2.2 m)
MAX_LENGTH = 10.0
__all__ = ["CONTACT_KINDS", "CONTACT_LAWS", "MAX_LENGTH", "MAX_NORMAL_PRELOAD", "MAX_STIFFNESS",
           "ContactConfig",
           "ContactsConfig", "FrictionConfig", "law_problems"]


@dataclass(frozen=True)
class ContactConfig:
    enabled: bool = field(default=True, metadata=_key("-", "contact kind present"))
    height: float = field(default=1.6, metadata=_key("m", "radius H of the arm", gt=0.0,
                                                     max=MAX_LENGTH))
    arm_length: float = field(default=0.15, metadata=_key("m", "rigid arm length L", gt=0.0,
                                                          max=MAX_LENGTH))
    profile_thickness: float = field(
        default=3.1e-2, metadata=_key("m", "distance l between profile points A and B", gt=0.0,
                                      max=MAX_LENGTH)
    )
    angle_deg: float = field(
        default=45.0, metadata=_key("deg", "contact surface angle beta", min=0.0, max=90.0)
    )
    normal_preload: float = field(
        default=400.0,
        metadata=_key("N", "initial normal force F_N0", min=0.0, max=MAX_NORMAL_PRELOAD),
    )
    stiffness: Any = field(
        default=7.6e7,
        metadata=_key(
            "N/m",
            "normal contact stiffness k_c: a number, a table [[angle_deg, N/m], ...] or 'fe'",
            gt=0.0, max=MAX_STIFFNESS,  # shown by config show; convert_stiffness applies it
        ),
    )
    arm_axial_stiffness: float = field(
        default=5e8,
        metadata=_key("N/m", "axial stiffness of the arm, in series for stiffness = 'fe'", gt=0.0,
                      max=MAX_STIFFNESS),
    )
    tangential_stiffness: Any = field(
        default="mindlin",
        metadata=_key(
            "N/m",
            "contacts.law = 'elastic' only: tangential stiffness k_t of the stuck contact, a "
            "number or 'mindlin' (Mindlin's ratio 2 (1 - nu) / (2 - nu) of the normal "
            "stiffness k_c at each blade's angle, nu = segment.poisson: 0.82 k_c)",
            gt=0.0, max=MAX_STIFFNESS,  # shown by config show; the converter applies it
        ),
    )


def _shroud_default() -> ContactConfig:
    return ContactConfig(
        height=2.18, arm_length=0.2, profile_thickness=3.46e-2, angle_deg=50.0, stiffness=7.6e7
    )


#: the contact laws (docs/theory.md, "Contact laws"): the paper's regularised Coulomb law of
#: the slip velocity (Fig. 4) or the elastic Coulomb contact (a Jenkins slider per contact)
CONTACT_LAWS = ("paper", "elastic")


@dataclass(frozen=True)
class ContactsConfig:
    law: str = field(
        default="paper",
        metadata=_key("-", "'paper' (friction of the slip velocity, Fig. 4: f_s, f_d, decay, "
                      "v_k) or 'elastic' (Coulomb with a tangential stiffness k_t while the "
                      "contact sticks, mu = friction.coulomb when it slips)",
                      choices=CONTACT_LAWS),
    )
    tieboss: ContactConfig = field(default_factory=ContactConfig)
    shroud: ContactConfig = field(default_factory=_shroud_default)

    @property
    def elastic(self) -> bool:
        """Whether the contacts follow the elastic Coulomb law (else the paper's): the one
        test of the law (the force parameters' :attr:`~wheelrom.forces.contact_law.
        ContactLaw.elastic` is this, carried into the compiled record)."""
        return self.law == "elastic"

    def enabled_kinds(self) -> list[str]:
        return [k for k in CONTACT_KINDS if getattr(self, k).enabled]


@dataclass(frozen=True)
class FrictionConfig:
    static: float = field(
        default=0.6, metadata=_key("-", "static friction coefficient f_s", min=0.0, max=10.0)
    )
    dynamic: float = field(
        default=0.4, metadata=_key("-", "dynamic friction coefficient f_d", min=0.0, max=10.0)
    )
    decay: float = field(
        default=2.0, metadata=_key("s/m", "decay d of the static-to-dynamic transition", min=0.0,
                                   max=1e4)
    )
    microslip_velocity: float = field(
        default=0.6, metadata=_key("m/s", "micro-slip velocity v_k", gt=0.0, max=100.0)
    )
    coulomb: float = field(
        default=0.4,
        metadata=_key("-", "contacts.law = 'elastic' only: Coulomb coefficient mu of the "
                      "slipping contact (Table 1's f_d, the coefficient of sustained sliding)",
                      min=0.0, max=10.0),
    )


def law_problems(cfg, problems: list[str]) -> None:
    """Keys of the elastic law set under the paper law: they would be silently unused."""
    if cfg.contacts.elastic:
        return
    # a value that is wrong by itself is reported by its own key already
    unused = [f"contacts.{kind}.tangential_stiffness" for kind in CONTACT_KINDS
              if is_number(k_t := cfg.contact(kind).tangential_stiffness) and k_t > 0]
    coulomb = cfg.friction.coulomb
    if is_number(coulomb) and coulomb >= 0 and coulomb != FrictionConfig.coulomb:
        unused.append("friction.coulomb")
    for key in unused:
        problems.append(f"{key}: applies to contacts.law = 'elastic' only (the law is "
                        "'paper': set contacts.law = 'elastic' or remove the key)")
