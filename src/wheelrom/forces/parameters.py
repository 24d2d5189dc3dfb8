"""Force parameters of one case: a frozen record built once from the reduced model and the
configuration, consumed by the reference force model and the compiled kernel alike (nozzle
eq. 13, Van der Pol eqs. 1, 2/14, dry-friction contacts on rigid arms eqs. 16-20;
docs/theory.md).

Units: modal coordinates ``q`` [sqrt(kg) m], velocities ``q'`` [sqrt(kg) m/s], generalised
force [sqrt(kg) m/s^2] (= N / sqrt(kg), since ``M_R = I``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np

from wheelrom.config import Config
from wheelrom.config.aero import read_aero_table
from wheelrom.forces.aero import AeroOperator, aero_operator
from wheelrom.forces.contact_law import OPEN, SLIP, STICK, ContactLaw, contact_law, mindlin_ratio
from wheelrom.rom.model import ReducedModel

VDP_OFF, VDP_ABSOLUTE, VDP_RELATIVE, AERO_TABLE = 0, 1, 2, 3
VDP_MODELS = {"off": VDP_OFF, "absolute": VDP_ABSOLUTE, "relative": VDP_RELATIVE,
              "table": AERO_TABLE}
__all__ = ["OPEN", "SLIP", "STICK", "ContactParameters", "ForceParameters", "force_parameters"]


def contact_frame(angle_deg: float) -> np.ndarray:
    """``T_g2l`` of eq. 18: rows xi = x, eta = (0, cos b, sin b), zeta = (0, -sin b, cos b)."""
    b = math.radians(angle_deg)
    return np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(b), math.sin(b)], [0.0, -math.sin(b), math.cos(b)]]
    )


def stiffness_at(stiffness, angle_deg: float) -> float:
    """Normal contact stiffness ``k_c(beta)`` [N/m] from a number or an (angle, value) table.

    Tables are interpolated linearly in ``log k`` (the curve spans decades, paper Fig. 5).
    """
    if isinstance(stiffness, int | float):
        return float(stiffness)
    if isinstance(stiffness, str):
        raise ValueError("stiffness = 'fe' must be resolved before building the force model")
    angles = np.array([a for a, _ in stiffness])
    values = np.log(np.array([k for _, k in stiffness]))
    return float(np.exp(np.interp(angle_deg, angles, values)))


@dataclass(frozen=True)
class ContactParameters:
    """Per contact kind (``K`` of them), as the force implementations want them.

    ``shape_A``, ``shape_B``: ``(K, 3, m)`` displacement of the profile points A, B per modal
    coordinate; ``point_A``, ``point_B``: ``(K, 3)`` undeformed A, B [m]; ``arm_length``:
    ``(K,)`` rigid arm L [m]; ``frame``: ``(K, N, 3, 3)`` local frame ``T_g2l`` per blade;
    ``stiffness``: ``(K, N)`` normal stiffness k_c [N/m]; ``preload``: ``(K,)`` F_N0 [N];
    ``angles_deg``: kind -> ``(N,)`` contact surface angle per blade; ``tangential``:
    ``(K, N)`` tangential stiffness k_t [N/m] of the elastic law (zeros under the paper law).
    """

    kinds: tuple[str, ...]
    shape_A: np.ndarray
    shape_B: np.ndarray
    point_A: np.ndarray
    point_B: np.ndarray
    arm_length: np.ndarray
    frame: np.ndarray
    stiffness: np.ndarray
    preload: np.ndarray
    angles_deg: dict
    tangential: np.ndarray


@dataclass(frozen=True)
class ForceParameters:
    """Everything the forces of one case need (``N`` blades, ``m`` modes).

    ``omega`` [rad/s] rotor speed; ``stator_vanes`` n_s; ``nozzle_force`` F_b [N];
    ``excitation``: ``(m,)`` generalised force of a unit ``y`` force on the excitation nodes;
    ``nozzle_phase``: ``(N,)`` phi_s [rad]; ``vdp_model``: VDP_OFF/ABSOLUTE/RELATIVE or
    AERO_TABLE; ``vdp_mu`` [N s/m] (the table's factor ``flutter.table_scale`` [-] for
    AERO_TABLE), ``vdp_r`` [m]; ``aero``: ``(m,)`` Van der Pol direction (mean aero ``y`` per
    modal coordinate, restricted to ``flutter.mode`` when set); ``aero_displacement``,
    ``aero_velocity``: ``(N,)`` the table's influence coefficients ``a_j`` [N/m], ``b_j``
    [N s/m] (:mod:`wheelrom.forces.aero`; zeros for the other models); ``law``: the
    tangential contact law (:class:`~wheelrom.forces.contact_law.ContactLaw`, ``friction``
    its packed record); ``rotation``: ``(3, 3)`` R; ``follows_speed``: below.
    """

    blades: int
    modes: int
    omega: float
    stator_vanes: int
    nozzle_force: float
    excitation: np.ndarray
    nozzle_phase: np.ndarray
    vdp_model: int
    vdp_mu: float
    vdp_r: float
    aero: np.ndarray
    aero_displacement: np.ndarray
    aero_velocity: np.ndarray
    law: ContactLaw
    rotation: np.ndarray
    contacts: ContactParameters
    #: the forced response over the rotor speed (``forced.over = "speed"``): the stiffness
    #: follows the speed ``w / n_s`` of the excitation ``w`` (the forces do not read it)
    follows_speed: bool = False

    def __post_init__(self):
        # the compiled kernels index these by mode and blade without bounds checks: a short
        # array would be read past its end (garbage, NaN on some machines), so refuse it here
        m, N, K = self.modes, self.blades, len(self.contacts.kinds)
        expected = {"excitation": (m,), "nozzle_phase": (N,), "aero": (m,),
                    "aero_displacement": (N,),
                    "aero_velocity": (N,), "contacts.shape_A": (K, 3, m),
                    "contacts.shape_B": (K, 3, m)}
        for name, shape in expected.items():
            owner, _, field = name.rpartition(".")
            value = getattr(self.contacts if owner else self, field)
            if np.shape(value) != shape:
                raise ValueError(f"force parameters: {name} has shape {np.shape(value)}, "
                                 f"expected {shape} ({m} modes, {N} blades, {K} contact "
                                 "kinds)")

    @functools.cached_property
    def friction(self) -> np.ndarray:
        """The contact law's packed record (:meth:`ContactLaw.packed`; built once: every
        force evaluation of the reference passes it)."""
        return self.law.packed()

    @property
    def sliders(self) -> int:
        """Slider coordinates of the state per case: ``2 K N`` under the elastic law, 0
        under the paper law (it has none)."""
        return 2 * len(self.contacts.kinds) * self.blades if self.law.elastic else 0

    def first_blades(self, n: int) -> ForceParameters:
        """The parameters of a tuned wheel's pattern of its first ``n`` blades (the per-blade
        arrays cut to them; the nozzle's phases stay the whole wheel's, so the pattern feels
        the whole wheel's travelling force). Not for an aerodynamic table, whose per-blade
        arrays are influence coefficients over blade distances."""
        c = self.contacts
        contacts = dataclasses.replace(
            c, frame=c.frame[:, :n].copy(), stiffness=c.stiffness[:, :n].copy(),
            tangential=c.tangential[:, :n].copy(),
            angles_deg={k: np.asarray(v)[:n].copy() for k, v in c.angles_deg.items()})
        return dataclasses.replace(
            self, blades=n, nozzle_phase=self.nozzle_phase[:n].copy(),
            aero_displacement=self.aero_displacement[:n].copy(),
            aero_velocity=self.aero_velocity[:n].copy(), contacts=contacts)

    def shared(self) -> tuple:
        """Everything but the contact frames and stiffnesses (what the cases of one batch
        must share: the compiled kernel takes it from the batch's first case)."""
        c = self.contacts
        return (self.blades, self.modes, c.kinds, self.vdp_model, self.stator_vanes,
                self.omega, self.nozzle_force, self.vdp_mu, self.vdp_r, self.friction,
                self.excitation, self.aero, self.aero_displacement, self.aero_velocity,
                self.nozzle_phase, self.rotation, c.preload,
                c.arm_length, c.shape_A, c.shape_B, c.point_A, c.point_B)


def flutter_mode(aero: np.ndarray, tip: np.ndarray) -> int:
    """``flutter.mode = "auto"``: the segment mode the Van der Pol force acts on in the paper's
    reading ("one selected mode of each blade"): the lowest mode that moves the aerofoil
    mainly tangentially, i.e. whose aero participation ``|p_j|`` (mean ``y`` motion of the
    aero nodes, ``aero`` ``(m,)``) is at least half its tip displacement ``|tip_j|``
    (``tip`` ``(3, m)``): the first bending mode of a blade. A property of each mode alone,
    so the choice does not change as a basis grows (a rule relative to the largest ``|p|``
    did: high Ritz vectors of an attachment basis move the tip most)."""
    size = np.abs(np.asarray(aero, dtype=float))
    tip = np.linalg.norm(np.asarray(tip, dtype=float).reshape(3, -1), axis=0)
    moving = tip > 1e-6 * tip.max()  # modes of the disc alone leave the tip at rest
    chosen = np.flatnonzero(moving & (size >= 0.5 * tip))
    return int(chosen[0]) if chosen.size else int(np.argmax(size))


def force_parameters(model: ReducedModel, cfg: Config,
                     angles_deg: dict | None = None) -> ForceParameters:
    """The force parameters of ``cfg`` on ``model``; ``angles_deg``: kind -> contact angle
    [deg] (a number or one per blade) instead of ``contacts.<kind>.angle_deg``."""
    N, m = model.blades, model.modes
    w, fl = cfg.wheel, cfg.flutter
    aero = selected_aero(model, cfg)
    a, b = np.zeros(N), np.zeros(N)
    if fl.model == "table":
        operator = table_operator(model, cfg, aero)
        a, b = operator.a, operator.b
    return ForceParameters(
        blades=N,
        modes=m,
        omega=2 * math.pi * w.speed_hz,
        stator_vanes=w.stator_vanes,
        nozzle_force=cfg.excitation.force,
        excitation=np.ascontiguousarray(model.excitation, dtype=float),
        nozzle_phase=2 * math.pi * (1 - w.stator_vanes / N) * np.arange(N),
        vdp_model=VDP_MODELS[fl.model],
        vdp_mu=fl.table_scale if fl.model == "table" else fl.mu,
        vdp_r=fl.r,
        aero=aero,
        aero_displacement=a,
        aero_velocity=b,
        law=contact_law(cfg),
        rotation=np.ascontiguousarray(model.rotation),
        contacts=_contact_parameters(model, cfg, angles_deg or {}),
        follows_speed=cfg.forced.over == "speed",
    )


def selected_aero(model: ReducedModel, cfg: Config) -> np.ndarray:
    """``(m,)`` the Van der Pol / aerodynamic direction ``p``: the model's aero participation,
    restricted to ``flutter.mode`` when one mode is selected."""
    aero = np.array(model.aero, dtype=float)
    mode = flutter_mode(aero, model.tip) if cfg.flutter.mode == "auto" else cfg.flutter.mode
    if mode >= 0:  # one segment mode only
        keep = np.zeros_like(aero)
        keep[mode] = aero[mode]
        aero = keep
    return aero


def table_operator(model: ReducedModel, cfg: Config, aero: np.ndarray) -> AeroOperator:
    """``flutter.table`` on ``model`` (:mod:`wheelrom.forces.aero`) along the direction
    ``aero`` (:func:`selected_aero`): the family is its first moving mode (the selected one;
    with every mode, the lowest with aero motion sets the reference frequencies)."""
    fl = cfg.flutter
    table = read_aero_table(fl.table, cfg.source, model.blades, fl.table_phase,
                            fl.table_directions, fl.table_sign)
    family = int(np.flatnonzero(aero)[0])
    return aero_operator(table, model, family, float(aero[family]))


def _contact_parameters(model: ReducedModel, cfg: Config, angles_deg: dict) -> ContactParameters:
    N, m = model.blades, model.modes
    kinds = [k for k in cfg.contacts.enabled_kinds() if k in model.contact_A]
    K = len(kinds)
    frame = np.zeros((K, N, 3, 3))
    k_c = np.zeros((K, N))
    k_t = np.zeros((K, N))
    elastic = cfg.contacts.elastic
    angles = {}
    for i, kind in enumerate(kinds):
        c = cfg.contact(kind)
        ang = np.broadcast_to(np.asarray(angles_deg.get(kind, c.angle_deg), float), (N,))
        stiffness = c.stiffness
        if stiffness == "fe":
            if kind not in model.contact_stiffness:
                raise ValueError(f"contacts.{kind}.stiffness = 'fe' but the model has no table")
            stiffness = [tuple(row) for row in model.contact_stiffness[kind]]
        angles[kind] = ang.copy()
        for s in range(N):
            frame[i, s] = contact_frame(ang[s])
            k_c[i, s] = stiffness_at(stiffness, ang[s])
        if elastic:
            tangential = c.tangential_stiffness
            k_t[i] = (mindlin_ratio(cfg.segment.poisson) * k_c[i] if tangential == "mindlin"
                      else float(tangential))
    return ContactParameters(
        kinds=tuple(kinds),
        shape_A=np.array([model.contact_A[k] for k in kinds]).reshape(K, 3, m),
        shape_B=np.array([model.contact_B[k] for k in kinds]).reshape(K, 3, m),
        point_A=np.array([model.contact_points[k][0] for k in kinds]).reshape(K, 3),
        point_B=np.array([model.contact_points[k][1] for k in kinds]).reshape(K, 3),
        arm_length=np.array([cfg.contact(k).arm_length for k in kinds], dtype=float),
        frame=frame,
        stiffness=k_c,
        preload=np.array([cfg.contact(k).normal_preload for k in kinds], dtype=float),
        angles_deg=angles,
        tangential=k_t,
    )
