"""Every Floquet multiplier of the whole wheel about a travelling wave's orbit, from its
pattern by Bloch waves (docs/theory.md, "The whole wheel's multipliers by Bloch waves").

A travelling wave of ``k`` repeats every ``N'`` blades (its pattern, :func:`~.flow.
pattern_model`), so the orbit of the whole wheel is the pattern's tiled ``L = N / N'`` times
and the wheel's linearised period map ``M`` commutes with the shift by one pattern: it is
block-circulant over the patterns, ``M_{p,r} = C_{p-r}``. Its eigenvectors are Bloch waves
``x_p = e^{i theta p} v`` (``theta = 2 pi j / L``) and its spectrum is the union over ``j``
of the spectra of the pattern-size matrices::

    M_theta = sum_r e^{-i theta r} C_r,          C_r = d x_r(T) / d x_0(0)

the response of pattern ``r`` after one period to a perturbation of pattern 0 alone. One
batch of central differences of the whole wheel's flow (each unknown of pattern 0 moved by
``+-eps`` in its unit) gives every ``C_r`` at once: ``2 n'`` integrations of the wheel for
its complete spectrum, every ND, where a Krylov method over the whole wheel needs about as
many periods and converges only the outermost (:mod:`.monodromy`). ``M_0`` is the pattern's
own period map (the multipliers inside the orbit's symmetry, :mod:`.slider_shooting`).

The integrations are the shot's map ``F = S^{-j} phi_tau`` (``tau = g T / N``: ``1 / N'``
of the period; ``S^{-j}`` the shift back by the ``j`` blades the wave moved), which commutes
with the shift by a pattern too: its Bloch blocks' eigenvalues ``nu`` give the period's
``mu = w^{p j} nu^{N'}`` (``F^{N'} = S^{-j N'} phi_T``, ``S^{N'} = w^p`` on block ``p``), at
``1 / N'`` of the cost (half, for the paper's ND 33).

Under the elastic law the sliders of contacts stuck all period are left out (their rows of
``M`` are unit rows: each a multiplier exactly 1, another orbit of the family), in every
pattern alike.
"""

from __future__ import annotations

import math
import time

import numpy as np

from wheelrom.analysis.periodic.flow import WheelFlow
from wheelrom.analysis.periodic.monodromy import Multipliers, label_vectors
from wheelrom.analysis.periodic.shooting import Orbit
from wheelrom.config import Config
from wheelrom.rom.model import ReducedModel

DIFFERENCE = 1e-6  # central-difference step, in each unknown's unit


def blade_indices(blades: np.ndarray, count: int, m: int, sliders: int) -> np.ndarray:
    """Flat indices of blades ``blades`` (in that order) in a state of ``count`` blades:
    their ``q`` (``(count, m)``), then ``q'``, then, with ``sliders`` contact kinds, their
    sliders (``(K, count, 2)``): a pattern's own flat order (:meth:`~.shooting.Orbit.flat`)
    when ``blades`` are one copy of it."""
    q = (blades[:, None] * m + np.arange(m)).ravel()
    parts = [q, count * m + q]
    if sliders:
        parts.append((2 * count * m + np.arange(sliders)[:, None, None] * 2 * count
                      + 2 * blades[None, :, None] + np.arange(2)).ravel())
    return np.concatenate(parts)


def bloch_multipliers(model: ReducedModel, cfg: Config, orbit: Orbit, scale: np.ndarray,
                      keep: np.ndarray, angles_deg: dict | None = None, lam: float = 1.0,
                      coarse: bool = False) -> Multipliers:
    """Every multiplier of the whole wheel of ``model`` about ``orbit`` (a pattern's, tiled)
    in the orbit's steps (``coarse``: at ``cfg``'s ``time.step`` when that is coarser, the
    flow's step check included): ``values`` largest modulus first, ``nd`` and
    ``wave`` of their whole-wheel eigenvectors, ``trivial`` the phase shift's (the ``theta =
    0`` eigenvector most aligned with the flow). ``scale`` ``(n',)``: the pattern's unknowns'
    units; ``keep``: the pattern unknowns that take part (the elastic law's locked sliders
    left out: each a multiplier exactly 1). ``matvecs``: the whole wheel's shots over
    ``tau`` integrated."""
    t0 = time.perf_counter()
    N, m, pattern = model.blades, model.modes, orbit.pattern
    copies = N // pattern
    kinds = 0 if orbit.sliders is None else orbit.sliders.shape[0]
    where = [blade_indices(p * pattern + np.arange(pattern), N, m, kinds)[keep]
             for p in range(copies)]
    state = orbit.wheel_state(N).ravel()
    if kinds:
        state = np.concatenate([state, orbit.wheel_sliders(N).ravel()])
    unit = scale[keep]
    n = keep.size
    probes = np.repeat(state[None], 2 * n, axis=0)
    rows = np.arange(n)
    probes[2 * rows, where[0]] += DIFFERENCE * unit
    probes[2 * rows + 1, where[0]] -= DIFFERENCE * unit
    # the short map F = S^{-j} phi_tau of the shot (tau = g T / N, N' of them a period)
    shots = round(1 / orbit.fraction)
    tau = orbit.fraction * orbit.period
    short = orbit.steps_per_period // shots  # the orbit's own steps a shot
    flow = WheelFlow(model, cfg, angles_deg, lam)
    try:
        if coarse:
            short = min(short, flow.steps_for(tau)[0])
        h = tau / short
        # on the orbit's switches, the pattern's branches on every copy (docs/theory.md
        # "Events in the step"), when they were located
        schedule = None if orbit.switches is None else orbit.switches.schedule(h, N)
        ends = flow.shift(flow.advance(probes, tau, short, schedule=schedule), -orbit.shift)
        along = (flow.advance(state[None], h, 1)[0] - state)[where[0]] / unit
    finally:
        flow.destroy()
    response = (ends[0::2] - ends[1::2]) / (2 * DIFFERENCE)  # row i: d end / d (x_i / unit_i)
    # C_r[a, i]: pattern r's unknown a (in its unit) per unit of pattern 0's unknown i
    C = [(response[:, where[r]] / unit).T for r in range(copies)]
    units = np.zeros(state.size)
    units[np.concatenate(where)] = np.tile(unit, copies)
    values, nd, wave, first = block_circulant_spectrum(C, where, units, N, m, shots,
                                                       orbit.shift)
    alignment = np.abs(first.conj().T @ along) / np.maximum(
        np.linalg.norm(first, axis=0) * np.linalg.norm(along), 1e-300)
    alignment = np.concatenate([alignment, np.zeros(values.size - alignment.size)])
    order = np.argsort(-np.abs(values), kind="stable")
    values, nd, wave, alignment = values[order], nd[order], wave[order], alignment[order]
    return Multipliers(values, nd, wave, int(np.argmax(alignment)), orbit.period, 2 * n,
                       time.perf_counter() - t0, values.size, by="Bloch waves",
                       alignment=alignment, step=h)


def block_circulant_spectrum(C: list, blocks: list, units: np.ndarray, blades: int,
                             modes: int, power: int = 1, shift: int = 0):
    """The eigenvalues of a map block-circulant over ``g = len(C)`` blocks of the whole
    wheel's state, from ``C[r]`` ``(n', n')``: block ``r``'s response to block 0 (each in
    its units ``units[blocks[r]]``; ``blocks[r]`` its flat indices in the state of size
    ``units.size``). Per Bloch block ``B_p = sum_r C_{-r} w^{r p}`` (``w = e^{2 pi i / g}``:
    the perturbations that change by ``w^p`` from one block to the next) its eigenvalues
    ``nu``, reported as ``w^{p shift} nu^power`` (a map over ``tau`` that shifts the blades
    by ``shift`` and ``power`` of which make a period; 1, 0: the period map itself). Returns
    ``(values, nd, wave, first)``: per Bloch block in order, the NDs and wave indices of the
    whole-wheel eigenvectors, and ``p = 0``'s eigenvectors ``(n', n')`` in the block's units
    (the pattern's own: the phase shift's is among them)."""
    g = len(C)
    values, nd, wave = [], [], []
    first = None
    for p in range(g):
        w = np.exp(2j * math.pi * p / g)
        nu, vectors = np.linalg.eig(sum(C[(-r) % g] * w**r for r in range(g)))
        whole = np.zeros((nu.size, units.size), complex)  # the Bloch waves in state units
        for r in range(g):
            whole[:, blocks[r]] = (w**r * vectors * units[blocks[r], None]).T
        labels = label_vectors(whole, blades, modes)
        values.append(w**shift * nu**power)  # w = e^{2 pi i p / g}: w^shift is the w^{p j} above
        nd.append(labels[0])
        wave.append(labels[1])
        first = vectors if p == 0 else first
    return np.concatenate(values), np.concatenate(nd), np.concatenate(wave), first
