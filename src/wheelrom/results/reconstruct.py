"""What a results file's modal state history gives back after the run: the reduced model as
stored (``/model``, no segment rebuild) and, per sample, the contact forces of every blade
pair evaluated by the solver's own reference force model
(:class:`~wheelrom.forces.reference.ReferenceForces`, the model the compiled kernel is held
equal to): normal force, friction force and the relative displacement of the contact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from wheelrom.config import Config, parse_override
from wheelrom.forces.parameters import force_parameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.results.histories import state_window
from wheelrom.results.info import not_case_file
from wheelrom.results.layout import FORMAT, angles_of, open_file, read_config
from wheelrom.results.study_layout import FORMAT as STUDY_FORMAT
from wheelrom.results.study_layout import read_parameters
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.errors import InputError
from wheelrom.segment.mesh import rotation_z


def open_results(path: str, studies: bool = True):
    """A results file (sweep, ``run --out`` or, with ``studies``, a study with transients)
    opened for reading, or one line naming it."""
    f = open_file(path)
    formats = (FORMAT, STUDY_FORMAT) if studies else (FORMAT,)
    if f.attrs.get("format") not in formats or "cases" not in f or "model" not in f:
        problem = not_case_file(path, f, "animate" if not studies else "contacts", formats)
        f.close()
        raise problem
    return f


def check_case(f, case: int) -> None:
    """``--case`` names a case of the file that has run (done, or failed after some time)."""
    cases = f["cases"]
    total = cases["status"].shape[0]
    if not 0 <= case < total:
        raise InputError(f"--case {case}: the file has {total} case{'s' * (total != 1)} "
                         f"(0..{total - 1})")
    status = cases["status"][case].decode()
    if status == "pending":
        raise InputError(f"--case {case} is pending: nothing computed yet")
    if status == "skipped" or "max_tip_amplitude" not in cases:
        raise InputError(f"--case {case} has no transient (the study ran none for it)")


def case_setup(f, path: str, case: int) -> tuple[ReducedModel, Config, dict]:
    """The reduced model, configuration and contact angles [deg] case ``case`` ran with.

    A sweep file has one model and one configuration; a study file (format 2) holds the
    model of every case's group (``/models/<g>``, ``/cases/model``), the case's mistuning
    (``/cases/mistuning``) and its parameters as written (``/cases/parameters/text``), which
    are put back on the stored configuration as ``--set`` would."""
    cfg = read_config(f, path)
    angles = angles_of(f["cases/angles_deg"][case])
    if f.attrs.get("format") != STUDY_FORMAT:
        return read_model(f["model"]), cfg, angles
    params = read_parameters(f)
    cfg = cfg.replace(**dict(parse_override(f"{name}={text}") for name, text
                             in zip(params["names"], params["text"][case], strict=True)))
    model = read_model(f[f"models/{int(f['cases/model'][case])}"])
    if "mistuning" in f["cases"] and np.any(f["cases/mistuning"][case]):
        model.mistuning = f["cases/mistuning"][case]
    return model, cfg, angles


def read_model(group) -> ReducedModel:
    """The :class:`ReducedModel` of a ``/model`` group, as the run used it (what the forces
    need; ``K_seg`` from the segment frequencies, ``R`` from the blade count)."""
    N, m = int(group.attrs["blades"]), int(group.attrs["modes"])
    hz = group["segment_hz"][()]
    model = ReducedModel(
        blades=N, modes=m, segment_hz=hz, K_seg=np.diag((2 * math.pi * hz) ** 2),
        A0=group["A0"][()], A1=group["A1"][()], rotation=rotation_z(2.0 * math.pi / N),
        tip=group["tip"][()], aero=group["aero"][()], excitation=group["excitation"][()],
    )
    for kind, g in group.get("contacts", {}).items():
        model.contact_A[kind] = g["A_shape"][()]
        model.contact_B[kind] = g["B_shape"][()]
        model.contact_points[kind] = g["points"][()]
        if "stiffness" in g:
            model.contact_stiffness[kind] = g["stiffness"][()]
    if "mistuning" in group:
        model.mistuning = group["mistuning"][()]
    return model


@dataclass
class ContactHistory:
    """One contact kind over the samples of a state history (``S`` samples, ``N`` blade
    pairs ``(s, s+1)``; local frame xi radial, eta normal, zeta of the contact surface).

    ``time`` ``(S,)`` [s]; ``normal_force`` ``(S, N)`` [N] (0: open); ``friction_force``
    ``(S, N, 2)`` (xi, zeta) [N] on blade ``s+1``; ``relative_displacement`` ``(S, N, 3)``
    (xi, eta, zeta) [m] of the contact (change from the undeformed gap); ``slip_velocity``
    ``(S, N)`` [m/s]; ``state`` ``(S, N)``: 0 open, 1 stick (micro-slip), 2 slip.
    """

    kind: str
    time: np.ndarray
    normal_force: np.ndarray
    friction_force: np.ndarray
    relative_displacement: np.ndarray
    slip_velocity: np.ndarray
    state: np.ndarray


def contact_histories(model: ReducedModel, cfg: Config, angles_deg: dict, times: np.ndarray,
                      states: np.ndarray) -> dict[str, ContactHistory]:
    """Kind -> :class:`ContactHistory` at the modal states ``states`` ``(S, 2, N, m)``
    (``q``, ``q'``) at ``times`` ``(S,)`` of the case with contact angles ``angles_deg``.

    Under the elastic law the sliders are replayed along the stored states
    (:meth:`ReferenceForces.replay`: a dense ``output.state_rate_hz``)."""
    forces = ReferenceForces(force_parameters(model, cfg, angles_deg))
    kinds = forces.params.contacts.kinds
    S, K, N = len(times), len(kinds), model.blades
    normal, slip = np.zeros((S, K, N)), np.zeros((S, K, N))
    friction, rel = np.zeros((S, K, N, 2)), np.zeros((S, K, N, 3))
    state = np.zeros((S, K, N), dtype=np.int8)
    for i in forces.replay(times, states):
        normal[i], slip[i], state[i] = forces.normal_force, forces.slip_velocity, \
            forces.contact_state
        friction[i], rel[i] = forces.friction_force, forces.relative_displacement
    return {kind: ContactHistory(kind, np.asarray(times), normal[:, k], friction[:, k],
                                 rel[:, k], slip[:, k], state[:, k])
            for k, kind in enumerate(kinds)}


def case_contacts(path: str, case: int, window: tuple[float, float] | None = None
                  ) -> dict[str, ContactHistory]:
    """The contact histories of case ``case`` of the results file ``path`` over ``window``
    ``(a, b)`` [s] (None: the whole run), from its state history."""
    with open_results(path) as f:
        check_case(f, case)
        model, cfg, angles = case_setup(f, path, case)
        times, states = state_window(f["cases"], path, case, window, model.modes)
    return contact_histories(model, cfg, angles, times, states)
