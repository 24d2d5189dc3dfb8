"""The commands that look at one case of a results file in motion: ``animate`` (the whole
wheel as XDMF for ParaView, a GIF of the tip ring, a rendering of the surface) and
``contacts`` (normal forces over time, friction hysteresis), both from the case's modal state
history (``output.state_rate_hz > 0``); ``animate`` falls back to the tip history."""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from wheelrom.cli.args import comm_self, positive_number
from wheelrom.cli.output import log
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import check_output, replacing


def parse_window(text: str | None) -> tuple[float, float] | None:
    """``--window a:b`` [s] -> ``(a, b)``; None when not given."""
    if text is None:
        return None
    try:
        a, b = (float(x) for x in text.split(":"))
    except ValueError:
        raise InputError(f"--window {text}: expected a:b in seconds, e.g. 1.4625:1.5") from None
    if not (math.isfinite(a) and math.isfinite(b) and b > a):
        raise InputError(f"--window {text}: expected a < b (seconds)")
    return a, b


def _last_window(cases, case: int) -> tuple[float, float]:
    """The last window the case completed [s]."""
    done = int(cases["windows_done"][case])
    if done == 0:
        raise InputError(f"--case {case}: no window completed (the case failed at the start)")
    ends = cases["window_end"][()]
    return (float(ends[done - 2]) if done > 1 else 0.0), float(ends[done - 1])


def _frames(count: int, frames: int) -> np.ndarray:
    """``frames`` sample rows spread evenly over ``count`` (all of them when fewer)."""
    if frames < 1:
        raise InputError(f"--frames {frames}: at least 1")
    return np.unique(np.linspace(0, count - 1, min(frames, count)).round().astype(int))


def _prefix(args: argparse.Namespace) -> str:
    return args.out or f"{os.path.splitext(args.file)[0]}_case{args.case}"


def _check_outputs(paths: list[str], force: bool, source: str) -> None:
    """Every output writable (existing ones need ``force``) and none of them the results
    file ``source`` itself (not even with ``force``)."""
    for path in paths:
        if os.path.exists(path) and os.path.samefile(path, source):
            raise InputError(f"--out: {path} would overwrite the results file {source}; "
                             "choose another prefix")
        check_output(path, force, "--out")


def cmd_animate(args: argparse.Namespace) -> int:
    """The whole wheel's motion over a window of one case: PREFIX.xdmf + PREFIX.h5 (surface
    displacement per time step, ParaView), PREFIX.gif (tip ring along the axis, open
    contacts marked) and PREFIX.png (the surface at the largest deformation); without a modal
    state history the GIF alone, from the tip history."""
    from wheelrom.results.reconstruct import check_case, open_results

    t0 = time.perf_counter()
    window = parse_window(args.window)
    prefix = _prefix(args)
    # a study's case may have a model of its own: the rebuild checks against /model only
    with open_results(args.file, studies=False) as f:
        check_case(f, args.case)
        cases = f["cases"]
        window = window or _last_window(cases, args.case)
        if "state_history" in cases:
            paths = [f"{prefix}.xdmf", f"{prefix}.h5", f"{prefix}.gif", f"{prefix}.png"]
            _check_outputs(paths, args.force, args.file)
            _animate_states(f, args, window, prefix)
        else:
            paths = [f"{prefix}.gif"]
            _check_outputs(paths, args.force, args.file)
            log(f"{args.file} has no state history (output.state_rate_hz = 0): the tip ring "
                "from the tip history only")
            _animate_tips(f, args, window, paths[0])
    for path in paths:
        print(path)
    log(f"animate: {time.perf_counter() - t0:.1f} s")
    return 0


def _animate_states(f, args, window, prefix: str) -> None:
    """XDMF, GIF and PNG of a window of the case's modal state history."""
    from wheelrom.plots.motion import auto_scale, surface_png, tip_ring_gif
    from wheelrom.results.histories import state_window
    from wheelrom.results.layout import angles_of, read_config
    from wheelrom.results.reconstruct import contact_histories
    from wheelrom.results.wheel_motion import rebuild, wheel_surface, write_xdmf

    times, states = state_window(f["cases"], args.file, args.case, window)
    rows = _frames(times.size, args.frames)
    times, states = times[rows], states[rows]
    t0 = time.perf_counter()
    wheel = rebuild(f, args.file, comm_self(), log=log)
    seg, model = wheel.segment.mesh, wheel.model
    surface = wheel_surface(seg, wheel.shapes)
    t1 = time.perf_counter()
    log(f"model rebuilt and checked against the file's in {t1 - t0:.1f} s; surface "
        f"{surface.points.shape[0]} points, {surface.quads.shape[0]} faces")
    write_xdmf(prefix, surface, times, states[:, 0])
    log(f"{prefix}.xdmf: {times.size} time steps in {time.perf_counter() - t1:.1f} s")
    cfg = read_config(f, args.file)
    contacts = contact_histories(model, cfg, angles_of(f["cases/angles_deg"][args.case]),
                                 times, states)
    tips = np.einsum("ksm,am->ksa", states[:, 0], model.tip)
    tip_point = seg.nodes[seg.node_sets["tip"]].mean(axis=0)
    amplitude = float(np.linalg.norm(tips, axis=2).max())
    scale = args.scale or auto_scale(amplitude, float(np.hypot(*tip_point[:2])))
    marks = {kind: (float(np.hypot(*model.contact_points[kind][0][:2])), h.state == 0)
             for kind, h in contacts.items()}
    with replacing(f"{prefix}.gif") as partial:
        tip_ring_gif(partial, times, tips, tip_point, scale, marks)
    k = int(np.argmax(np.abs(states[:, 0]).max(axis=(1, 2))))
    u = surface.displacement(states[k, 0])
    with replacing(f"{prefix}.png") as partial:
        surface_png(partial, surface.points, surface.quads, u, scale, float(times[k]))


def _animate_tips(f, args, window, gif: str) -> None:
    """The tip-ring GIF from the tip history (ring radius: the outermost contact point)."""
    from wheelrom.plots.motion import auto_scale, tip_ring_gif
    from wheelrom.results.histories import tip_window

    times, tips = tip_window(f["cases"], args.file, args.case, window)
    rows = _frames(times.size, args.frames)
    times, tips = times[rows], tips[rows]
    points = [g["points"][()] for g in f["model/contacts"].values()] if "model/contacts" in f \
        else []
    radius = max((float(np.hypot(*p[:, :2].T).max()) for p in points), default=1.0)
    amplitude = float(np.linalg.norm(tips, axis=2).max())
    scale = args.scale or auto_scale(amplitude, radius)
    with replacing(gif) as partial:
        tip_ring_gif(partial, times, tips, np.array([radius, 0.0, 0.0]), scale)


def cmd_contacts(args: argparse.Namespace) -> int:
    """Contact forces of one case from its modal state history: normal force over time of
    the contacts after the chosen blades (PREFIX_normal_force.png) and the friction
    hysteresis loop of each (PREFIX_hysteresis_<kind>_blade<B>.png)."""
    from wheelrom.plots.motion import hysteresis_png, normal_force_png
    from wheelrom.results.reconstruct import case_contacts, check_case, open_results

    window = parse_window(args.window)
    prefix = _prefix(args)
    with open_results(args.file) as f:
        check_case(f, args.case)
        N = int(f["model"].attrs["blades"])
        window = window or _last_window(f["cases"], args.case)
    for blade in args.blade:
        if not 0 <= blade < N:
            raise InputError(f"--blade {blade}: the wheel has blades 0..{N - 1}")
    histories = case_contacts(args.file, args.case, window)
    if args.kind != "all":
        if args.kind not in histories:
            raise InputError(f"--kind {args.kind}: the case has contacts "
                             f"{', '.join(histories) or 'none'}")
        histories = {args.kind: histories[args.kind]}
    if not histories:
        raise InputError(f"{args.file}: the case has no contacts")
    paths = [f"{prefix}_normal_force.png"] + [
        f"{prefix}_hysteresis_{kind}_blade{b}.png" for kind in histories for b in args.blade]
    _check_outputs(paths, args.force, args.file)
    with replacing(paths[0]) as partial:
        normal_force_png(partial, histories, args.blade)
    rest = iter(paths[1:])
    for h in histories.values():
        for blade in args.blade:
            with replacing(next(rest)) as partial:
                hysteresis_png(partial, h, blade)
    print("\n".join(paths))
    return 0


def args_animate(p: argparse.ArgumentParser) -> None:
    _file_case(p)
    p.add_argument("--scale", type=positive_number, default=None,
                   help="displacement scale of the pictures (default: the largest tip "
                   "displacement drawn as 4 %% of the tip radius); the XDMF holds true "
                   "displacements [m]")
    p.add_argument("--frames", type=int, default=40,
                   help="time steps written, spread evenly over the window (default 40)")


def args_contacts(p: argparse.ArgumentParser) -> None:
    _file_case(p)
    p.add_argument("--blade", type=int, nargs="+", default=[0],
                   help="contacts between blade B and B+1 (default 0)")
    p.add_argument("--kind", default="all", help="tieboss, shroud or all (default)")


def _file_case(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="HDF5 file from sweep, study or run --out with a state "
                   "history (output.state_rate_hz > 0)")
    p.add_argument("--case", type=int, default=0, help="case index as 'wheelrom info' lists it")
    p.add_argument("--window", default=None, metavar="A:B",
                   help="time window [s] (default: the case's last window)")
    p.add_argument("--out", default=None, metavar="PREFIX",
                   help="output prefix (default: FILE without .h5 + _case<K>)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
