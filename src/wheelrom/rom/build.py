"""The one pipeline from a configuration to the reduced wheel, used by every command:

    segment mesh -> matrices (-> centrifugal prestress) -> segment modes (SLEPc) -> basis
    (free or enriched) -> reduced wheel (cyclic synthesis) -> contact stiffness tables

:func:`build_segment` stops after the matrices (what the contact-stiffness, accuracy and
full-wheel references need: the *same* matrices the model is built from); :func:`build`
goes on to the reduced model and keeps what it was built from; :func:`build_model` returns
the model alone (a few kilobytes, what the transient and the sweep broadcast).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from wheelrom.config import Config
from wheelrom.rom.bases import (
    ENRICH_FAMILIES,
    attachment_vectors,
    enrichment_phases,
    enrichment_vectors,
    ritz_basis,
)
from wheelrom.rom.model import ReducedModel, blade_mistuning, reduce
from wheelrom.runtime.errors import InputError
from wheelrom.segment.assembly import SegmentMatrices, assemble
from wheelrom.segment.contact_stiffness import stiffness_tables
from wheelrom.segment.load import load_segment
from wheelrom.segment.mesh import SegmentMesh
from wheelrom.segment.modes import segment_modes
from wheelrom.segment.prestress import prestress


def quiet(msg: str) -> None:
    """A ``log`` that drops progress lines."""


@dataclass
class SegmentBuild:
    """The segment of a configuration as the reduced model uses it.

    ``matrices``: free-DOF mass and stiffness; with ``segment.prestress`` at
    ``wheel.speed_hz > 0`` the stiffness is ``K + K_sigma - Omega^2 M_s`` (docs/theory.md).
    """

    mesh: SegmentMesh
    matrices: SegmentMatrices
    cfg: Config
    info: dict = field(default_factory=dict)  # e.g. the prestress's peak von Mises stress
    #: ``K_sigma - Omega^2 M_s`` on the free DOFs (scipy CSR) [N/m]: what the prestress added
    #: to the stiffness (None: no prestress)
    speed_stiffening: object = None


@dataclass
class WheelBuild:
    """A reduced model with what it was built from: the segment and the basis ``shapes``
    ``(n_dofs, r)`` on the full DOFs (M-orthonormal), for exports and references."""

    segment: SegmentBuild
    shapes: np.ndarray
    model: ReducedModel


def build_segment(cfg: Config, comm, log=quiet) -> SegmentBuild:
    """Mesh and matrices of the segment of ``cfg`` (``comm``: communicator of the prestress
    solve; every rank of it gets the same result)."""
    seg = load_segment(cfg)
    s = cfg.segment
    mats = assemble(seg, s.young, s.poisson, s.density)
    log(f"segment: {seg.n_dofs} DOFs (hex20), assembled in {mats.assembly_s:.2f} s")
    if s.prestress and cfg.wheel.speed_hz > 0:
        omega = 2 * np.pi * cfg.wheel.speed_hz
        ps = prestress(seg, mats, s.young, s.poisson, s.density, omega,
                       cfg.wheel.coupling_stiffness, comm)
        _check_prestress_strain(seg, ps, cfg.wheel.speed_hz)
        standstill = mats.K
        mats = replace(mats, K=ps.stiffness(mats))
        stiffening = (mats.K - standstill).tocsr()
        stress = _stress_report(ps, seg.info.get("rim_radius"))
        log(
            f"prestress at {cfg.wheel.speed_hz:g} Hz: static residual {ps.residual:.1e}, "
            f"largest displacement {np.abs(ps.displacement).max() * 1e3:.3f} mm, "
            + stress_line(stress) + f" ({ps.solve_s:.1f} s)"
        )
    else:
        stress, stiffening = {}, None
    return SegmentBuild(seg, mats, cfg, stress, stiffening)


#: the largest centrifugal displacement over the wheel's outer radius the linear prestress
#: is taken for: its hoop strain. Steels yield at 0.2-0.7 %; at 1 % the wheel has long left
#: small-strain elasticity (the built-in wheel reaches it near 105 Hz, 3.4 % at 200 Hz; at
#: 1e9 Hz it "moved" 1.2e15 mm and spin softening took every frequency to 0)
MAX_PRESTRESS_STRAIN = 0.01


class BeyondPrestress(InputError):
    """A rotor speed ``speed_hz`` [Hz] whose linear prestress is meaningless (``why``); the
    message names ``wheel.speed_hz``, a command that set the speed otherwise (``campbell
    --speeds``) names its option with ``why``."""

    def __init__(self, speed_hz: float, why: str):
        self.speed_hz, self.why = speed_hz, why
        super().__init__(f"wheel.speed_hz {speed_hz:g} Hz: {why}: a lower speed, or "
                         "segment.prestress = false")


def _check_prestress_strain(seg, ps, speed_hz: float) -> None:
    """Refuse a ``wheel.speed_hz`` whose centrifugal displacement exceeds
    :data:`MAX_PRESTRESS_STRAIN` of the wheel's outer radius: the linear prestress and every
    frequency built on it would be meaningless, however finite."""
    radius = float(np.hypot(seg.nodes[:, 0], seg.nodes[:, 1]).max())
    moved = float(np.abs(ps.displacement).max())
    if moved > MAX_PRESTRESS_STRAIN * radius:
        raise BeyondPrestress(
            speed_hz, f"the centrifugal displacement {moved * 1e3:.3g} mm is "
            f"{100 * moved / radius:.2g} % of the wheel's {radius:.3g} m radius, beyond "
            f"small-strain elasticity (at most {100 * MAX_PRESTRESS_STRAIN:g} %; peak von Mises "
            f"stress {ps.peak_von_mises / 1e6:.3g} MPa)")


ROOT_CORNER_SPAN = 0.1  # [m] band about the rim where the blade root's corner is singular


def _stress_report(ps, rim_radius: float | None) -> dict:
    """Peak von Mises stresses [Pa] of the prestress and where (radius [m]); for the built-in
    segment (its rim radius known) also split: disc (more than ``ROOT_CORNER_SPAN`` below the
    rim), blade (as far above it) and the root corner band between them, where the blade
    meets the rim at a sharp re-entrant edge: there the linear elastic stress is singular and
    its peak grows with mesh refinement (a detail design puts a fillet there)."""
    out = {"prestress_peak_von_mises_pa": ps.peak_von_mises,
           "prestress_peak_radius_m": ps.peak_radius}
    if rim_radius is not None:
        r = ps.element_radius
        for name, mask in (("disc", r < rim_radius - ROOT_CORNER_SPAN),
                           ("blade", r > rim_radius + ROOT_CORNER_SPAN),
                           ("root_corner", abs(r - rim_radius) <= ROOT_CORNER_SPAN)):
            if mask.any():
                out[f"prestress_{name}_peak_pa"], out[f"prestress_{name}_radius_m"] = (
                    ps.peak_where(mask))
    return out


def stress_line(info: dict) -> str:
    """The stress report of ``_stress_report`` in one line [MPa]."""
    parts = [f"peak von Mises stress {info['prestress_peak_von_mises_pa'] / 1e6:.0f} MPa at "
             f"r = {info['prestress_peak_radius_m']:.2f} m"]
    for name, label in (("disc", "disc"), ("blade", "blade"),
                        ("root_corner", "root corner (singular)")):
        if f"prestress_{name}_peak_pa" in info:
            parts.append(f"{label} {info[f'prestress_{name}_peak_pa'] / 1e6:.0f} MPa "
                         f"(r = {info[f'prestress_{name}_radius_m']:.2f} m)")
    return "; ".join(parts)


def contact_stiffness_tables(segment: SegmentBuild, kinds, comm) -> dict:
    """``{kind: (angles_deg, k_c [N/m], ContactFlexibility)}`` from the segment's matrices
    (the table ``stiffness = "fe"`` uses; :mod:`wheelrom.segment.contact_stiffness`)."""
    return stiffness_tables(segment.cfg, segment.mesh, segment.matrices, kinds, comm)


def build(cfg: Config, comm, log=quiet, segment: SegmentBuild | None = None) -> WheelBuild:
    """Segment -> modes -> basis -> reduced wheel for ``cfg`` (``segment``: reuse a segment
    already built for the same configuration).

    ``comm``: communicator of the segment solves (SLEPc, MUMPS); the result is the same on
    every rank of it. ``log`` receives progress lines.
    """
    t0 = time.perf_counter()
    segment = segment or build_segment(cfg, comm, log)
    seg, mats = segment.mesh, segment.matrices
    eig = segment_modes(mats, cfg.wheel.modes_per_segment, comm)
    log(
        f"segment modes: {eig.frequencies_hz.size} in {eig.solve_s:.2f} s, "
        f"max residual {eig.residuals.max():.1e}"
    )
    parts = set(cfg.wheel.basis.split("+")) - {"free"}
    if parts:
        t1 = time.perf_counter()
        vectors, said = [eig.vectors[mats.free]], []
        if "enriched" in parts:
            phases = enrichment_phases(seg.sectors)
            vectors.append(enrichment_vectors(seg, mats, cfg.wheel.coupling_stiffness,
                                              ENRICH_FAMILIES, comm, phases))
            said.append(f"{ENRICH_FAMILIES} sector modes of ND {', '.join(map(str, phases))}")
        if "attachment" in parts:
            kinds = [k for k in cfg.contacts.enabled_kinds() if f"{k}_A" in seg.node_sets]
            vectors.append(attachment_vectors(seg, mats, kinds, comm))
            said.append(f"attachment vectors of {', '.join(kinds) or 'no'} contacts")
        X, lam = ritz_basis(mats, vectors)
        log(f"{cfg.wheel.basis} basis: {X.shape[1]} vectors (free modes + "
            f"{' + '.join(said)}) in {time.perf_counter() - t1:.2f} s")
        hz = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
        shapes = mats.expand(X)
        model = reduce(seg, shapes, np.diag(lam), cfg, hz)
    else:
        shapes = eig.vectors
        model = reduce(seg, shapes, np.diag(eig.eigenvalues), cfg, eig.frequencies_hz)
    if segment.speed_stiffening is not None:  # the speed's share, for model.at_speed
        basis = shapes[mats.free]
        stiffening = basis.T @ (segment.speed_stiffening @ basis)
        model.speed_stiffness = 0.5 * (stiffening + stiffening.T)
    model.info["speed_hz"] = float(cfg.wheel.speed_hz)
    fe_kinds = [k for k in cfg.contacts.enabled_kinds() if cfg.contact(k).stiffness == "fe"]
    for kind, (angles, values, flex) in contact_stiffness_tables(segment, fe_kinds, comm).items():
        model.contact_stiffness[kind] = np.stack([angles, values], axis=1)
        log(
            f"contact stiffness '{kind}' from FE ({flex.solve_s:.1f} s): "
            f"{values.min():.3g}..{values.max():.3g} N/m over 0..90 deg"
        )
    model.mistuning = blade_mistuning(cfg)
    if model.mistuning is not None:
        log(f"mistuning: delta_s from {model.mistuning.min():+.4f} to {model.mistuning.max():+.4f} "
            "(blade modal stiffness x (1 + delta_s))")
    model.info.update(segment.info)
    model.info.update(
        segment_dofs=seg.n_dofs,
        assembly_s=mats.assembly_s,
        eigen_solve_s=eig.solve_s,
        eigen_residual_max=float(eig.residuals.max()),
        build_s=time.perf_counter() - t0,
    )
    return WheelBuild(segment, shapes, model)


def build_model(cfg: Config, comm, log=quiet) -> ReducedModel:
    """The reduced model of ``cfg`` alone (see :func:`build`), read from the model cache when
    an earlier command built the same (:mod:`wheelrom.rom.cache`)."""
    from wheelrom.rom import cache

    def fresh() -> ReducedModel:
        return build(cfg, comm, log).model

    # a model built by several ranks together is not read from the cache: a rank that found
    # it would leave the others alone in the collective build
    model = cache.cached(cfg, fresh, log) if comm.getSize() == 1 else fresh()
    model.mistuning = blade_mistuning(cfg)  # each case's: the cache holds the tuned wheel
    return model
