"""Reduced models kept on disk between commands: the same wheel is not built twice.

``./run/paper`` runs eight commands on the same wheel; building it in each (segment FE,
prestress, SLEPc modes, attachment vectors: 6.8 s on the default wheel) would cost 55 s of the
job. A model is stored once built and read back by the next command whose model is the same.

**What "the same" means**, the cache key (SHA-256) over: the configuration's keys the model
depends on (:func:`wheelrom.config.study.model_key`: not the forces, the contact angles,
preloads or the mistuning, which each case puts on the tuned model), the path and contents of
a mesh file (``segment.source``, beside the TOML), the source code of the segment and rom
stages, the PETSc options of the model's solvers (:data:`PREFIXES`) and the versions of numpy,
scipy, meshio, PETSc, SLEPc and scikit-fem. Anything else that changed builds a new model
(a mesh format's side files, e.g. an XDMF's HDF5, are not hashed: ``off`` after editing them).

**Where**: ``$WHEELROM_MODEL_CACHE`` (a directory; ``off``: no cache), else
``$XDG_CACHE_HOME/wheelrom/models`` (``~/.cache/...``). Files are ``.npz`` read with
``allow_pickle=False`` (data only) and written whole under a temporary name then renamed, so a
concurrent command reads a complete file or none; an unreadable file is built again and
replaced. The :data:`KEEP` most recently used are kept.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import time
import uuid
from pathlib import Path

import numpy as np

from wheelrom.rom.model import ReducedModel

KEEP = 64  # models kept (a few kB each)
ENVIRONMENT = "WHEELROM_MODEL_CACHE"
ARRAYS = ("segment_hz", "K_seg", "A0", "A1", "rotation", "tip", "aero", "excitation")
PER_KIND = ("contact_A", "contact_B", "contact_points", "contact_stiffness")
STAGES = ("segment", "rom")  # the code a model is built by
#: options prefixes of the PETSc/SLEPc objects that build a model (the segment's modes, the
#: prestress solve, the attachment and enrichment vectors, the FE contact stiffness): a
#: tighter -segment_eps_tol is another model
PREFIXES = ("segment_", "prestress_", "attachment_", "cyclic_", "stiffness_")


def directory() -> Path | None:
    """The cache directory, or None when ``$WHEELROM_MODEL_CACHE`` is ``off``."""
    where = os.environ.get(ENVIRONMENT, "")
    if where.lower() == "off":
        return None
    if where:
        return Path(where)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "wheelrom" / "models"


def _code_digest() -> str:
    package = Path(__file__).resolve().parent.parent
    h = hashlib.sha256()
    for stage in STAGES:
        for path in sorted((package / stage).glob("*.py")):
            h.update(path.name.encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def _versions() -> dict:
    import meshio
    import petsc4py
    import scipy
    import skfem
    import slepc4py

    return {"numpy": np.__version__, "scipy": scipy.__version__, "meshio": meshio.__version__,
            "petsc4py": petsc4py.__version__, "slepc4py": slepc4py.__version__,
            "skfem": skfem.__version__}


def _solver_options() -> dict:
    """The PETSc options database's entries that reach the model's solvers."""
    from wheelrom.runtime.environment import petsc

    every = petsc().Options().getAll()
    return {k: str(v) for k, v in every.items() if k.startswith(PREFIXES)}


def cache_key(cfg) -> str:
    """The SHA-256 of what the reduced model of ``cfg`` depends on (module docstring)."""
    from wheelrom.config.study import model_key

    h = hashlib.sha256()
    h.update(model_key(cfg).encode())
    if cfg.segment.source != "builtin":  # the file the reader reads: beside the TOML
        from wheelrom.segment.reader import source_path

        path = Path(source_path(cfg))
        h.update(str(path.resolve()).encode())
        h.update(path.read_bytes())
    h.update(_code_digest().encode())
    h.update(json.dumps([_versions(), _solver_options()], sort_keys=True).encode())
    return h.hexdigest()


def load(path: Path) -> ReducedModel | None:
    """The model stored at ``path``; None when it is missing or unreadable."""
    try:
        # opened here: np.load leaves its own handle open when a damaged file raises
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as data:
            info = json.loads(str(data["info"]))
            kinds = json.loads(str(data["kinds"]))
            per_kind = {name: {k: data[f"{name}/{k}"].copy() for k in kinds[name]}
                        for name in PER_KIND}
            model = ReducedModel(int(data["blades"]), int(data["modes"]),
                                 *(data[name].copy() for name in ARRAYS), **per_kind,
                                 info=info)
            if "speed_stiffness" in data.files:
                model.speed_stiffness = data["speed_stiffness"].copy()
    except Exception:  # noqa: BLE001 (missing, truncated: BadZipFile, EOFError; damaged)
        return None
    try:
        os.utime(path)  # most recently used
    except OSError:  # a read-only cache, or pruned meanwhile by another command
        pass
    return model


def store(path: Path, model: ReducedModel) -> None:
    """Write ``model`` (without its mistuning) to ``path`` whole; a failure to write (a full
    or read-only disk) only costs the next command a build."""
    arrays = {name: np.asarray(getattr(model, name)) for name in ARRAYS}
    if model.speed_stiffness is not None:
        arrays["speed_stiffness"] = np.asarray(model.speed_stiffness)
    kinds = {}
    for name in PER_KIND:
        table = getattr(model, name)
        kinds[name] = sorted(table)
        arrays.update({f"{name}/{k}": np.asarray(v) for k, v in table.items()})
    tmp = path.with_name(f".{path.name}.{socket.gethostname()}.{os.getpid()}."
                         f"{uuid.uuid4().hex}.tmp")  # unique on a shared file system
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(tmp, "wb") as f:
            # the model file's rule for its info (results/layout.py): numpy scalars as floats
            np.savez(f, blades=model.blades, modes=model.modes,
                     info=json.dumps(model.info, default=float),
                     kinds=json.dumps(kinds), **arrays)
        os.replace(tmp, path)
        _prune(path.parent)
    except OSError:
        tmp.unlink(missing_ok=True)


def _prune(folder: Path) -> None:
    files = sorted(folder.glob("*.npz"), key=lambda p: p.stat().st_mtime, reverse=True)
    for old in files[KEEP:]:
        old.unlink(missing_ok=True)


def cached(cfg, build, log) -> ReducedModel:
    """The reduced model of ``cfg`` from the cache, else ``build()`` stored there; its
    mistuning is the caller's (each case's)."""
    folder = directory()
    if folder is None:
        return build()
    t0 = time.perf_counter()
    try:
        path = folder / f"{cache_key(cfg)}.npz"
    except OSError:  # a mesh file that cannot be read: the build says why
        return build()
    model = load(path)
    if model is not None:
        model.info["build_s"] = time.perf_counter() - t0  # this command's cost of it
        model.info["model_cache"] = str(path)
        log(f"model read from the cache in {time.perf_counter() - t0:.2f} s "
            f"({path}; {ENVIRONMENT}=off builds it)")
        return model
    model = build()
    store(path, model)
    return model
