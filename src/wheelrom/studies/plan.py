"""How a study's cases are run: which share a model and a TS, which the screen confirms by a
transient, and which rank runs what. Plain data in, plain data out (no MPI, no files), so
the decisions are the same on every rank and testable alone.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def group_by(keys: Sequence[str]) -> tuple[list[int], list[list[int]]]:
    """``(group of every item, items of every group)``: equal keys share a group, numbered
    in order of first appearance."""
    first: dict[str, int] = {}
    of = [first.setdefault(k, len(first)) for k in keys]
    members: list[list[int]] = [[] for _ in first]
    for i, g in enumerate(of):
        members[g].append(i)
    return of, members


def boundary(verdicts: Sequence, shape: Sequence[int]) -> np.ndarray:
    """``(C,)`` whether each case of a grid (``shape``, first axis slowest, ``C = prod``) has
    a neighbour along some axis (index +-1, the other indices equal) of another verdict
    (``stable``, ``unstable``, or a failed analysis): the cases on either side of a
    stability boundary."""
    grid = np.asarray([str(v) for v in verdicts]).reshape(tuple(shape))
    out = np.zeros(grid.shape, dtype=bool)
    for axis in range(grid.ndim):
        if grid.shape[axis] < 2:
            continue
        lo = [slice(None)] * grid.ndim
        hi = [slice(None)] * grid.ndim
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        differ = grid[tuple(lo)] != grid[tuple(hi)]
        out[tuple(lo)] |= differ
        out[tuple(hi)] |= differ
    return out.reshape(-1)


def selection(verdicts: Sequence, shape: Sequence[int], confirm: Sequence[int],
              mode: str) -> list[str]:
    """Why each case gets a transient: ``all`` (mode ``full``), ``boundary``, ``user``,
    ``boundary+user`` (mode ``screen``), ``none`` (not run; every case of mode
    ``stability``)."""
    C = len(verdicts)
    if mode != "screen":
        return ["all" if mode == "full" else "none"] * C
    edge = boundary(verdicts, shape)
    asked = np.zeros(C, dtype=bool)
    asked[list(confirm)] = True
    words = {(True, True): "boundary+user", (True, False): "boundary",
             (False, True): "user", (False, False): "none"}
    return [words[(bool(e), bool(a))] for e, a in zip(edge, asked, strict=True)]


def balance(costs: Sequence[float], ranks: int) -> list[list[int]]:
    """Items per rank, longest first to the least loaded rank (ties: lower index, lower rank):
    a deterministic greedy schedule whose makespan is within 4/3 of the best. Each rank's
    items come back in increasing index order."""
    load = [0.0] * ranks
    out: list[list[int]] = [[] for _ in range(ranks)]
    for i in sorted(range(len(costs)), key=lambda i: (-costs[i], i)):
        r = min(range(ranks), key=lambda r: (load[r], r))
        out[r].append(i)
        load[r] += costs[i]
    return [sorted(items) for items in out]


def batches(items: Sequence[int], keys: Sequence[str], width: int) -> list[list[int]]:
    """Cases (a rank's, or every case: ``settle``) in TS batches: cases with the same batch
    key together, at most ``width`` per batch (0: no limit), in order of their first case."""
    _, members = group_by([keys[i] for i in items])
    out = []
    for group in members:
        cases = [items[j] for j in group]
        step = width or len(cases)
        out += [cases[k : k + step] for k in range(0, len(cases), step)]
    return sorted(out, key=lambda b: b[0])


def shared_models(configs: Sequence, comm, say) -> tuple[list[int], list]:
    """``(model_of, models)``: one reduced model per group of ``configs`` that share one,
    built on rank 0 of the mpi4py ``comm`` (None: serial) and broadcast, so that results do
    not depend on the number of ranks; a model that cannot be built stops every rank with one
    :class:`~wheelrom.runtime.errors.InputError` (none is left waiting in the broadcast)."""
    from wheelrom.config.study import model_key
    from wheelrom.rom.build import build_model
    from wheelrom.runtime.environment import petsc, slepc
    from wheelrom.runtime.errors import InputError

    petsc()  # PetscInitialize is collective: every rank, before rank 0 builds alone
    slepc()
    model_of, members = group_by([model_key(c) for c in configs])
    models: list | str | None = None
    if comm is None or comm.rank == 0:
        try:
            models = [build_model(configs[m[0]], petsc().COMM_SELF, log=say) for m in members]
        except Exception as exc:  # every rank stops with it, none waits in bcast
            models = f"the model could not be built: {type(exc).__name__}: {exc}"
    if comm is not None:
        models = comm.bcast(models)
    if isinstance(models, str):
        raise InputError(models)
    return model_of, models
