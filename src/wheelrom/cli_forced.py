"""``wheelrom forced-response``: the linear steady response to the nozzle over a frequency
range (:mod:`wheelrom.transient.forced`), of the configured wheel (mistuned when
``[mistuning]`` says so) and of the tuned wheel, with the amplification factor."""

from __future__ import annotations

import argparse
import math

import numpy as np

from wheelrom.cli_args import comm_self, force, json_out, load_config
from wheelrom.cli_output import log, print_json
from wheelrom.config import CONTACT_KINDS
from wheelrom.errors import InputError
from wheelrom.outputs import check_output, replacing
from wheelrom.results import FORCED_FORMAT as FORMAT


def args_forced(p: argparse.ArgumentParser) -> None:
    p.add_argument("--frequencies", required=True, metavar="A:B:N",
                   help="excitation frequencies [Hz]: N values from A to B inclusive")  # fmt: skip
    p.add_argument("--contacts", action=argparse.BooleanOptionalAction, default=True,
                   help="linearise the contacts at the preloaded equilibrium (default) or "
                   "leave them out (K_R and beta_D K_R only)")  # fmt: skip
    p.add_argument("--angle", nargs=2, action="append", default=[], metavar=("KIND", "DEG"),
                   help="contact angle [deg] of a kind (tieboss, shroud) instead of "
                   "contacts.<kind>.angle_deg (repeatable)")  # fmt: skip
    json_out(p)
    p.add_argument("--out", help="write the response to this HDF5 file")
    force(p)


def parse_frequencies(text: str) -> np.ndarray:
    """``--frequencies A:B:N`` [Hz] -> ``(N,)`` values from A to B inclusive."""
    try:
        start, stop, count = text.split(":")
        a, b, n = float(start), float(stop), int(count)
    except ValueError:
        raise InputError(f"--frequencies {text}: expected A:B:N (Hz, N an integer), "
                         "e.g. 300:400:201") from None  # fmt: skip
    if not (math.isfinite(a) and math.isfinite(b) and 0 <= a <= b):
        raise InputError(f"--frequencies {text}: expected 0 <= A <= B (Hz)")
    if n < 1 or (n > 1 and a == b):
        raise InputError(f"--frequencies {text}: N must be >= 1 (and 1 when A = B)")
    return np.linspace(a, b, n)


def parse_angles(pairs: list[list[str]]) -> dict:
    """``--angle KIND DEG`` pairs -> kind -> angle [deg]."""
    out = {}
    for kind, value in pairs:
        if kind not in CONTACT_KINDS:
            raise InputError(f"--angle {kind}: contact kinds are {', '.join(CONTACT_KINDS)}")
        try:
            out[kind] = float(value)
        except ValueError:
            raise InputError(f"--angle {kind} {value}: the angle is a number [deg]") from None
    return out


def cmd_forced(args: argparse.Namespace) -> int:
    """Linear forced response to the nozzle at engine order wheel.stator_vanes: per
    frequency the largest blade tip amplitude of the configured wheel and of the tuned wheel,
    and the amplification factor (peak over peak). PETSc prefixes forced_ (KSP) and
    forced_preload_ (SNES)."""
    from wheelrom.rom.build import build_model, quiet
    from wheelrom.transient.forced import amplification_factor, forced_response, tuned_copy

    cfg = load_config(args)
    hz = parse_frequencies(args.frequencies)
    angles = parse_angles(args.angle) or None
    if args.out:
        check_output(args.out, args.force)
    say = quiet if args.json else log
    model = build_model(cfg, comm_self(), log=say)
    w = 2 * math.pi * hz
    response = forced_response(model, cfg, w, args.contacts, angles, comm_self())
    tuned = response
    if not model.tuned:
        say("the tuned reference (mistuning removed)")
        tuned = forced_response(tuned_copy(model), cfg, w, args.contacts, angles, comm_self())
    out = {
        "stator_vanes": response.stator_vanes,
        "nodal_diameter": response.nodal_diameter,
        "contacts": args.contacts,
        "mistuned": not model.tuned,
        "frequency_hz": hz.tolist(),
        "max_amplitude_m": response.max_amplitude.tolist(),
        "tuned_max_amplitude_m": tuned.max_amplitude.tolist(),
        "peak_amplitude_m": response.peak,
        "tuned_peak_amplitude_m": tuned.peak,
        "amplification_factor": amplification_factor(response, tuned),
        "solve_s_per_frequency": response.solve_s / hz.size,
    }
    if args.out:
        _write(args.out, cfg, model, response, tuned, out, angles)
    if args.json:
        print_json(out)
    else:
        _print(out)
    return 0


def _write(path: str, cfg, model, response, tuned, out: dict, angles: dict | None) -> None:
    """The response as HDF5 (docs/output.md, format ``wheelrom-forced-1``): ``frequency_hz``
    ``(F,)``, ``blade_amplitude`` and ``tuned_blade_amplitude`` ``(F, N)`` [m],
    ``mistuning`` ``(N,)``; attributes: the configuration and its source, the wheelrom
    version, the scalars of ``out``, the model size, the contact angles (JSON) and the KSP
    settings (``solver``, JSON: :func:`wheelrom.transient.forced.ksp_settings`)."""
    import json

    import h5py

    from wheelrom import __version__
    from wheelrom import config as config_mod

    with replacing(path) as partial, h5py.File(partial, "w") as f:
        f.attrs["format"] = FORMAT
        f.attrs["config"] = config_mod.to_toml(cfg)
        f.attrs["config_source"] = cfg.source
        f.attrs["wheelrom_version"] = __version__
        for key in ("stator_vanes", "nodal_diameter", "contacts", "mistuned",
                    "amplification_factor", "solve_s_per_frequency"):  # fmt: skip
            f.attrs[key] = out[key]
        f.attrs["blades"], f.attrs["modes"] = model.blades, model.modes
        f.attrs["contact_angles_deg"] = json.dumps(_contact_angles(cfg, angles) if out["contacts"]
                                                   else {})  # fmt: skip
        f.attrs["solver"] = json.dumps(response.solver)
        f["frequency_hz"] = np.asarray(out["frequency_hz"])
        f["blade_amplitude"] = response.blade_amplitude
        f["tuned_blade_amplitude"] = tuned.blade_amplitude
        mistuning = model.mistuning if model.mistuning is not None else np.zeros(model.blades)
        f["mistuning"] = mistuning


def _contact_angles(cfg, angles: dict | None) -> dict:
    """kind -> contact angle [deg] of every enabled kind: ``--angle`` or the configured one."""
    return {k: float((angles or {}).get(k, getattr(cfg.contacts, k).angle_deg))
            for k in cfg.contacts.enabled_kinds()}  # fmt: skip


def _print(out: dict) -> None:
    """A table per frequency, then the peaks and the amplification factor."""
    print(f"engine order {out['stator_vanes']} (ND {out['nodal_diameter']}), contacts "
          f"{'linearised' if out['contacts'] else 'off'}, "
          f"{'mistuned' if out['mistuned'] else 'tuned'} wheel")  # fmt: skip
    print(f"{'f [Hz]':>12s} {'max tip [m]':>12s} {'tuned [m]':>12s} {'ratio':>8s}")
    rows = zip(out["frequency_hz"], out["max_amplitude_m"], out["tuned_max_amplitude_m"],
               strict=True)  # fmt: skip
    for f, a, t in rows:
        print(f"{f:12.4f} {a:12.4e} {t:12.4e} {a / max(t, 1e-300):8.4f}")
    print(f"peak max-blade amplitude {out['peak_amplitude_m']:.4e} m, tuned "
          f"{out['tuned_peak_amplitude_m']:.4e} m: amplification factor "
          f"{out['amplification_factor']:.4f}")  # fmt: skip
    print(f"solve time {1e3 * out['solve_s_per_frequency']:.3g} ms per frequency")
