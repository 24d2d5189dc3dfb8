"""The HDF5 results file, owned here: its layout (docs/output.md), creating it, writing the
model and the cases, reading it back. Used by ``sweep``, ``run --out``, ``modes --out`` and
``plot``; works on a serial ``h5py.File`` and on one opened with the ``mpio`` driver (every
rank creates the layout identically; each case is written by the rank that ran it).
"""

from __future__ import annotations

import itertools
import json
import tomllib

import numpy as np

from wheelrom import config as config_mod
from wheelrom.config import CONTACT_KINDS, Config
from wheelrom.results.checksums import create_checksums, write_checksum
from wheelrom.results.file_checksums import write_file_checksums
from wheelrom.results.histories import create_histories, write_histories
from wheelrom.rom.model import ReducedModel
from wheelrom.runtime.errors import InputError
from wheelrom.transient.problem import N_WORK, WORK_NAMES, CaseResult
from wheelrom.transient.ts import time_grid

STATUS_LEN = 256
FORMAT = "wheelrom-sweep-1"
STABILITY_FORMAT = "wheelrom-stability-1"
FORCED_FORMAT = "wheelrom-forced-1"  # wheelrom forced-response --out (cli_forced)


def case_angles(cfg: Config) -> np.ndarray:
    """``(C, 2)`` (tie-boss, shroud) angle of every case of the sweep [deg], tie-boss major."""
    pairs = itertools.product(cfg.sweep.tieboss_angles_deg, cfg.sweep.shroud_angles_deg)
    return np.array(list(pairs), dtype=float).reshape(-1, 2)


def angles_of(row: np.ndarray) -> dict:
    """The contact angles of one case, kind -> [deg]."""
    return {"tieboss": float(row[0]), "shroud": float(row[1])}


def single_case(cfg: Config) -> Config:
    """``cfg`` with a sweep of one case at its configured contact angles (``run --out``)."""
    return cfg.replace(**{"sweep.tieboss_angles_deg": [cfg.contacts.tieboss.angle_deg],
                          "sweep.shroud_angles_deg": [cfg.contacts.shroud.angle_deg]})


def write_model(group, model: ReducedModel) -> None:
    """Reduced-model data (``/model``): small arrays, written by one rank or serially."""
    from scipy.sparse import csr_matrix

    K = csr_matrix(model.dense_stiffness())
    red = group.create_group("reduced")
    red["K/data"], red["K/indices"], red["K/indptr"] = K.data, K.indices, K.indptr
    red["K/shape"] = np.array(K.shape)
    group["segment_hz"] = model.segment_hz
    group["A0"], group["A1"] = model.A0, model.A1
    group["excitation"], group["aero"], group["tip"] = model.excitation, model.aero, model.tip
    group["frequencies_by_nd"] = model.frequencies_by_nodal_diameter()
    for kind, XA in model.contact_A.items():
        group[f"contacts/{kind}/A_shape"] = XA
        group[f"contacts/{kind}/B_shape"] = model.contact_B[kind]
        group[f"contacts/{kind}/points"] = model.contact_points[kind]
    for kind, table in model.contact_stiffness.items():
        group[f"contacts/{kind}/stiffness"] = table
    if not model.tuned:
        group["mistuning"] = model.mistuning
    group.attrs["blades"] = model.blades
    group.attrs["modes"] = model.modes
    group.attrs["info"] = json.dumps(model.info, default=float)


def write_aero_table(f, cfg: Config, model: ReducedModel) -> None:
    """``/aero`` (``flutter.model = "table"`` only; docs/output.md): the table as used, per
    ND ``k = 0..N-1`` in the lead convention -- the complex coefficient ``kappa_k``, the
    reference frequency and the influence coefficients -- so the file says what the flow
    did even where the CSV is gone."""
    if cfg.flutter.model != "table":
        return
    from wheelrom.forces.parameters import selected_aero, table_operator

    op = table_operator(model, cfg, selected_aero(model, cfg))
    g = f.create_group("aero")
    g.attrs["table"] = cfg.flutter.table
    g.attrs["family_mode"] = op.family
    g.attrs["scale"] = cfg.flutter.table_scale
    g["nodal_diameter"] = np.arange(model.blades)
    g["coefficient"] = np.column_stack([op.kappa.real, op.kappa.imag])
    g["frequency_hz"] = op.omega / (2 * np.pi)
    g["influence_displacement"] = op.a
    g["influence_velocity"] = op.b


def write_model_file(f, cfg: Config, model: ReducedModel, extra: dict | None = None) -> None:
    """A model file (``modes --out``): the configuration, ``/model`` and ``extra`` datasets
    (path under ``/model`` -> array)."""
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    write_model(f.create_group("model"), model)
    for name, value in (extra or {}).items():
        f[f"model/{name}"] = value
    write_file_checksums(f)


def create_layout(f, cfg: Config, model: ReducedModel, angles: np.ndarray | None = None,
                  modes: int | None = None) -> None:
    """Create every dataset of a sweep of ``cfg`` (collective: all ranks call this
    identically); every case ``pending``. ``angles``: ``(C, 2)`` tie-boss, shroud angle of
    every case [deg] (default: ``cfg``'s sweep grid; a study passes its cases'); ``modes``:
    the modal state history's width (default ``model.modes``; a study whose groups differ in
    their mode count passes the largest, and a case fills its own first columns)."""
    angles = case_angles(cfg) if angles is None else angles
    C = angles.shape[0]
    grid = time_grid(cfg)
    W, N = grid.windows, model.blades
    f.attrs["format"] = FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    write_aero_table(f, cfg, model)
    cases = f.create_group("cases")
    cases.create_dataset("angles_deg", data=angles)
    cases.attrs["angle_columns"] = "tieboss, shroud"
    st = cases.create_dataset("status", (C,), dtype=f"S{STATUS_LEN}")
    cases.create_dataset("wall_s", (C,), dtype="f8", fillvalue=np.nan)
    cases.create_dataset("compile_s", (C,), dtype="f8", fillvalue=np.nan)
    for name in ("steps", "batch", "windows_done", "samples_done"):
        cases.create_dataset(name, (C,), dtype="i8")
    cases.create_dataset("options", (C,), dtype=f"S{STATUS_LEN}")
    cases.create_dataset("window_end", data=np.array(grid.window_end))
    nan = dict(dtype="f8", fillvalue=np.nan)
    cases.create_dataset("max_tip_amplitude", (C, W), **nan)
    cases.create_dataset("nd_spectrum", (C, W, N // 2 + 1), **nan)
    cases.create_dataset("energy", (C, W), **nan)
    cases.create_dataset("energy0", (C,), **nan)
    cases.create_dataset("work", (C, W, N_WORK), **nan)
    cases["work"].attrs["columns"] = ", ".join(WORK_NAMES)
    create_histories(cases, C, grid, N, modes or model.modes)
    cases.create_dataset("growth_rate", (C,), **nan)
    cases.create_dataset("nd_growth_rate", (C, N // 2 + 1), **nan)
    for name in ("linear_growth_rate", "linear_nodal_diameter", "linear_frequency_hz"):
        cases.create_dataset(name, (C,), **nan)
    cases.create_dataset("classification", (C,), dtype=f"S{STATUS_LEN}")
    for kind in CONTACT_KINDS:
        cases.create_dataset(f"min_normal_force/{kind}", (C, W), **nan)
        cases.create_dataset(f"open_fraction/{kind}", (C, W), **nan)
        cases.create_dataset(f"slip_fraction/{kind}", (C, W), **nan)
    create_checksums(cases, C)
    # every rank writes the same small model arrays; identical values, so this is safe and
    # keeps creation collective
    write_model(f.create_group("model"), model)
    st[...] = np.array([b"pending"] * C, dtype=f"S{STATUS_LEN}")


def layout_bytes(create) -> int:
    """The bytes of the file ``create(f)`` lays out, once every dataset is written: the layout
    built in memory (HDF5 core driver, nothing on disk; chunked datasets take no memory until
    written), every dataset's size summed. What a command checks against the free disk space
    before it computes (:func:`wheelrom.runtime.outputs.check_space`)."""
    import uuid

    import h5py

    total = [0]

    def count(_, obj):
        if isinstance(obj, h5py.Dataset):
            total[0] += int(obj.size) * obj.dtype.itemsize

    with h5py.File(f"layout-{uuid.uuid4().hex}.h5", "w", driver="core",
                   backing_store=False) as f:
        create(f)
        f.visititems(count)
    return total[0]


def write_case(f, i: int, res: CaseResult) -> None:
    """Case ``i``'s result into a file made by :func:`create_layout`; its status last, so a
    write that fails half-way (a full disk) leaves the case ``pending``."""
    cases = f["cases"]
    w = res.window_end.size
    s = res.sample_time.size
    cases["wall_s"][i] = res.wall_s
    cases["compile_s"][i] = res.compile_s
    cases["steps"][i] = res.steps
    cases["batch"][i] = res.batch
    cases["windows_done"][i] = w
    cases["samples_done"][i] = s
    cases["options"][i] = json.dumps(res.options).encode()[:STATUS_LEN]
    cases["energy0"][i] = res.energy0
    if w:
        cases["max_tip_amplitude"][i, :w] = res.max_tip_amplitude
        cases["nd_spectrum"][i, :w] = res.nd_spectrum
        cases["energy"][i, :w] = res.energy
        cases["work"][i, :w] = res.work
        for kind, values in res.min_normal_force.items():
            cases[f"min_normal_force/{kind}"][i, :w] = values
            cases[f"open_fraction/{kind}"][i, :w] = res.open_fraction[kind]
            cases[f"slip_fraction/{kind}"][i, :w] = res.slip_fraction[kind]
    write_histories(cases, i, res)
    if w >= 2:
        cases["growth_rate"][i], cases["nd_growth_rate"][i] = res.growth_rates()
    if res.linear:
        for key, value in res.linear.items():
            cases[f"linear_{key}"][i] = value
    cases["classification"][i] = res.classification.encode()[:STATUS_LEN]
    write_checksum(cases, i)  # of the rows as stored, before the status that completes them
    cases["status"][i] = res.status.encode()[:STATUS_LEN]


def statuses(f) -> list[str]:
    """The status of every case (``pending``, ``done``, ``failed: ...``)."""
    return [s.decode() for s in f["cases/status"][:]]


def config_changes(stored, cfg: Config, select=None) -> str | None:
    """How the configuration ``stored`` in a file (its TOML text) differs from ``cfg``, as
    ``key: file value -> now``; None: the same values. Values are compared, not text: a
    comment or a help text that changed between wheelrom versions is no difference.
    ``select``: compare only the keys it keeps of either nested dict (e.g.
    :func:`wheelrom.config.study.model_data`: the same wheel). A key missing from the file
    (an older wheelrom) counts only when its value now is not its default."""
    def flat(node, prefix=""):
        out = {}
        for key, value in node.items():
            if isinstance(value, dict):
                out.update(flat(value, f"{prefix}{key}."))
            else:
                out[f"{prefix}{key}"] = value
        return out

    select = select or (lambda data: data)
    try:
        old = flat(select(tomllib.loads(stored.decode() if isinstance(stored, bytes)
                                        else stored)))
    except (AttributeError, tomllib.TOMLDecodeError):
        return "its configuration attribute is missing or not TOML"
    new = flat(select(tomllib.loads(config_mod.to_toml(cfg))))
    # a key the file's wheelrom version did not have, now at its default, is no difference: a
    # new key's default keeps the behaviour it had (an upgrade must not refuse a --resume)
    default = flat(select(tomllib.loads(config_mod.to_toml(config_mod.from_dict({})))))
    keys = sorted(k for k in old.keys() | new.keys() if old.get(k) != new.get(k)
                  and not (k not in old and k in default and new[k] == default[k]))
    if not keys:
        return None
    shown = ", ".join(f"{k}: {old.get(k, '(none)')!r} -> {new.get(k, '(none)')!r}"
                      for k in keys[:3])
    return shown + (f" and {len(keys) - 3} more" if len(keys) > 3 else "")


def resume_problem(path: str, cfg: Config) -> str | None:
    """Why the file at ``path`` cannot be completed for ``cfg`` (None: it can)."""
    import h5py

    try:
        with h5py.File(path, "r") as f:
            if f.attrs.get("format") != FORMAT:
                return f"{path} is not a wheelrom sweep file"
            changed = config_changes(f.attrs.get("config"), cfg)
            if changed:
                return (f"{path} was written for a different configuration ({changed}); use "
                        "--force to start again")
    except OSError as exc:
        return f"{path} cannot be opened for --resume ({exc}); use --force to start again"
    return None


def options_problem(path: str, settings: dict) -> str | None:
    """Why the cases still to run in ``path`` must not use the TS ``settings``
    (:func:`wheelrom.transient.ts.ts_settings`): the finished cases ran with other ones, and one
    file must not mix integrators. None: they agree (or no case ran yet)."""
    import h5py

    recorded = []
    with h5py.File(path, "r") as f:
        for i, (raw, status) in enumerate(zip(f["cases/options"][:], statuses(f), strict=True)):
            if status == "pending" or not raw:
                continue
            try:
                used = json.loads(raw.decode())
            except ValueError:
                return (f"{path}: case {i}'s recorded TS options are not readable JSON; "
                        "use --force to start again")
            if used:  # {}: a batch that failed before its TS existed records nothing to match
                recorded.append((i, used))
    wanted = json.loads(json.dumps(settings))  # the same number formats as the file
    for i, used in recorded:
        differ = sorted(k for k in set(used) | set(wanted) if used.get(k) != wanted.get(k))
        if differ:
            then = ", ".join(f"{k}={used.get(k, '-')}" for k in differ)
            now = ", ".join(f"{k}={wanted.get(k, '-')}" for k in differ)
            return (
                f"{path}: case {i} ran with {then}; this run would use {now}. Resume with "
                "the same PETSc options (see 'wheelrom info'), or use --force to start again"
            )
    return None


def write_stability(f, cfg: Config, model: ReducedModel, cases: list) -> None:
    """``/stability`` of a stability file (``wheelrom stability --out``; docs/output.md) from
    :class:`~wheelrom.analysis.stability.StabilityResult` per case of ``cfg``'s grid, with
    the configuration and ``/model``."""
    f.attrs["format"] = STABILITY_FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    write_model(f.create_group("model"), model)
    write_aero_table(f, cfg, model)
    g = f.create_group("stability")
    g.attrs["kinds"] = ", ".join(cases[0].kinds)
    g["angles_deg"] = case_angles(cfg)
    g["angles_deg"].attrs["columns"] = "tieboss, shroud"
    E = min(len(r.eigenvalue) for r in cases)  # the same for tuned wheels: 2 m (N/2 + 1)
    order = [np.argsort(-r.growth_rate, kind="stable")[:E] for r in cases]  # fastest first
    per_mode = ("nodal_diameter", "growth_rate", "frequency_hz", "damping_ratio",
                "tip_amplitude", "contact_normal", "contact_tangential", "modal_share")
    for name in per_mode:
        g[name] = np.array([getattr(r, name)[o] for r, o in zip(cases, order, strict=True)])
    g["max_growth_rate"] = np.array([r.growth_rate.max() for r in cases])
    g["verdict"] = np.array([r.verdict().encode() for r in cases])
    g["normal_force"] = np.array([r.normal_force for r in cases])
    g["margin"] = np.array([r.margin for r in cases])
    g["equilibrium"] = np.array([r.equilibrium for r in cases])
    g["residual"] = np.array([r.residual for r in cases])
    g["cyclic"] = np.array([r.cyclic for r in cases])
    g["wall_s"] = np.array([r.wall_s for r in cases])
    if all(r.flutter_margin is not None for r in cases):
        m = [r.flutter_margin for r in cases]
        g["critical_mu"] = np.array([x.critical_mu for x in m])
        g["margin_ratio"] = np.array([x.ratio for x in m])
        g["margin_nodal_diameter"] = np.array([x.nodal_diameter for x in m])
        g["margin_frequency_hz"] = np.array([x.frequency_hz for x in m])
        g["growth_rate_without_self_excitation"] = np.array([x.growth_at_zero for x in m])
    write_file_checksums(f, {"stability": len(cases)})


def check_readable(path: str) -> None:
    """One line when ``path`` cannot be a wheelrom file to read: missing, a directory (HDF5's
    own refusal is a two-line dump of its read call), or no regular file (a FIFO blocks the
    read, a device never ends it)."""
    import os

    if os.path.isdir(path):
        raise InputError(f"{path} is a directory, not a wheelrom results file")
    if not os.path.exists(path):
        raise InputError(f"{path}: no such file")
    if not os.path.isfile(path):
        raise InputError(f"{path} is not a regular file (a device, a FIFO or a socket), not a "
                         "wheelrom results file")
    if not os.access(path, os.R_OK):
        raise InputError(PERMISSION.format(path=path))


#: the refusal of a file this user may not read (another user's mode-0600 file): said as
#: such, not as "not an HDF5 file" (its content was never seen)
PERMISSION = "{path}: not readable by this user (permission denied)"


def not_readable(exc: OSError) -> bool:
    """Whether opening a file failed for want of permission (h5py reports errno 13 in its
    message, not always as ``errno``)."""
    import errno

    return exc.errno == errno.EACCES or "Permission denied" in str(exc)


def read_error(path: str, exc: OSError, what: str) -> InputError:
    """The one line of an HDF5 file that did not open: permission denied said as such,
    anything else as ``what`` (``"not an HDF5 file"``) with HDF5's reason."""
    if not_readable(exc):
        return InputError(PERMISSION.format(path=path))
    return InputError(f"{path}: {what} ({exc})")


def open_file(path: str):
    """The HDF5 file at ``path`` opened for reading without the file lock (a sweep still
    writing it holds it open; what it flushed is readable), or one line naming it."""
    import h5py

    check_readable(path)
    try:
        return h5py.File(path, "r", locking=False)
    except OSError as exc:
        raise read_error(path, exc, "not an HDF5 file") from None


def read_config(f, path: str) -> Config:
    """The configuration a results file was written with (file keys such as
    ``flutter.table`` resolved beside the TOML it came from while that is there, else beside
    the results file)."""
    import os

    if "config" not in f.attrs:
        raise InputError(f"{path}: attribute 'config' is missing (not a wheelrom file)")
    toml = str(f.attrs.get("config_source", "")).split(" + --set ")[0]
    source = toml if os.path.isfile(toml) else path
    return config_mod.from_dict(tomllib.loads(f.attrs["config"]), source=source)
