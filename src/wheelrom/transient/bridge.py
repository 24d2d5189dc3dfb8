"""PETSc TS calls the compiled kernel without Python: ``rhs_core`` and ``sample_core`` wrapped
as C functions (numba ``cfunc``) that get and restore the Vec arrays through PETSc's C API
(ctypes), registered with ``TSSetRHSFunction`` / ``TSMonitorSet``.

Why: a petsc4py Python callback costs several microseconds per call (wrapping the Vecs, numpy
views, the numba dispatch of ~30 arguments); the paper case needs ~900,000 evaluations.
"""

from __future__ import annotations

import ctypes
import functools

import numba
import numpy as np
from numba import types

from wheelrom._environment import petsc
from wheelrom.transient.fastmath import double_ptr, long_ptr
from wheelrom.transient.kernel import rhs_core, sample_core
from wheelrom.transient.layout import (
    H_LEN,
    H_NSTATE,
    H_OFFSETS,
    H_RHS_CALLS,
    H_SLOT_F,
    H_SLOT_U,
    H_USER_REASON,
    Context,
)  # fmt: skip


@numba.njit
def _context_at(ctx_addr):
    """The context array at ``ctx_addr`` and its header viewed as int64 (pointer slots)."""
    header = numba.carray(double_ptr(ctx_addr), H_OFFSETS)
    ctx = numba.carray(double_ptr(ctx_addr), int(header[H_LEN]))
    return ctx, numba.carray(long_ptr(ctx_addr), H_OFFSETS)


@numba.njit
def _state_at(address, ctx):
    """A PETSc state Vec's array (``B (2 N m + 4)`` doubles) at ``address``."""
    return numba.carray(double_ptr(address), int(ctx[H_NSTATE]))


def _petsc_function(lib, name, *argtypes):
    fn = getattr(lib, name)
    fn.argtypes = argtypes
    fn.restype = ctypes.c_int
    return fn


@functools.cache
def _library():
    """PETSc's C library, reached through petsc4py's extension module (dlsym also searches
    its libpetsc dependency)."""
    return ctypes.CDLL(petsc().__file__)


def _adapt_of(ts) -> ctypes.c_void_p:
    adapt = ctypes.c_void_p()
    get_adapt = _petsc_function(_library(), "TSGetAdapt", ctypes.c_void_p, ctypes.c_void_p)
    if get_adapt(ts.handle, ctypes.byref(adapt)):
        raise RuntimeError("PETSc error in TSGetAdapt")
    return adapt


def set_adapt_type(ts, kind: str) -> None:
    """``TSAdaptSetType`` (petsc4py 3.18 has no TSAdapt object): a default set in code, which
    ``-<prefix>ts_adapt_type`` overrides in ``setFromOptions``."""
    setter = _petsc_function(_library(), "TSAdaptSetType", ctypes.c_void_p, ctypes.c_char_p)
    if setter(_adapt_of(ts), kind.encode()):
        raise RuntimeError(f"PETSc error in TSAdaptSetType({kind!r})")


def adapt_type(ts) -> str:
    """The TS's step adaptor type (``"none"``: fixed steps)."""
    name = ctypes.c_char_p()
    getter = _petsc_function(_library(), "TSAdaptGetType", ctypes.c_void_p, ctypes.c_void_p)
    if getter(_adapt_of(ts), ctypes.byref(name)):
        raise RuntimeError("PETSc error in TSAdaptGetType")
    return name.value.decode()


@functools.cache
def callbacks():
    """``(rhs, monitor, TSSetRHSFunction, TSMonitorSet)``: C callbacks compiled once per
    process (~1 s) and the PETSc setters. Pointers travel as int64 (same ABI on x86-64)."""
    lib = _library()
    i64, i32 = ctypes.c_int64, ctypes.c_int32
    get_read = _petsc_function(lib, "VecGetArrayRead", i64, i64)
    restore_read = _petsc_function(lib, "VecRestoreArrayRead", i64, i64)
    get_write = _petsc_function(lib, "VecGetArray", i64, i64)
    restore_write = _petsc_function(lib, "VecRestoreArray", i64, i64)
    set_reason = _petsc_function(lib, "TSSetConvergedReason", i64, i32)

    @numba.cfunc(types.int32(types.int64, types.float64, types.int64, types.int64, types.int64))
    def rhs(ts, t, U, F, ctx_addr):
        ctx, slots = _context_at(ctx_addr)
        slot_u = ctx_addr + 8 * H_SLOT_U
        slot_f = ctx_addr + 8 * H_SLOT_F
        err = get_read(U, slot_u)
        if err:
            return err
        err = get_write(F, slot_f)
        if err:
            return err
        u = _state_at(slots[H_SLOT_U], ctx)
        f = _state_at(slots[H_SLOT_F], ctx)
        rhs_core(t, u, f, ctx)
        ctx[H_RHS_CALLS] += 1.0
        err = restore_read(U, slot_u)
        if err:
            return err
        return restore_write(F, slot_f)

    @numba.cfunc(types.int32(types.int64, types.int32, types.float64, types.int64, types.int64))
    def monitor(ts, step, t, U, ctx_addr):
        ctx, slots = _context_at(ctx_addr)
        slot_u = ctx_addr + 8 * H_SLOT_U
        err = get_read(U, slot_u)
        if err:
            return err
        u = _state_at(slots[H_SLOT_U], ctx)
        stop = sample_core(t, u, ctx)
        err = restore_read(U, slot_u)
        if err:
            return err
        if stop:
            return set_reason(ts, int(ctx[H_USER_REASON]))
        return 0

    set_rhs = _petsc_function(lib, "TSSetRHSFunction", i64, i64, i64, i64)
    set_monitor = _petsc_function(lib, "TSMonitorSet", i64, i64, i64, i64)
    return rhs, monitor, set_rhs, set_monitor


@functools.cache
def _null_rhs():
    @numba.cfunc(types.int32(types.int64, types.float64, types.int64, types.int64, types.int64))
    def nothing(ts, t, U, F, ctx_addr):
        return 0

    return nothing


def attach_null(ts, f) -> None:
    """Register a compiled right-hand side that does nothing (``F`` keeps its values) and no
    monitor: what the integrator costs by itself (``wheelrom bench``'s floor figures)."""
    set_rhs = callbacks()[2]
    ts.cancelMonitor()
    if set_rhs(ts.handle, f.handle, _null_rhs().address, 0):
        raise RuntimeError("PETSc error while registering the no-op right-hand side")

def attach(ts, f, context: Context) -> None:
    """Register the compiled RHS (residual Vec ``f``) and sampling monitor on ``ts``.

    ``context`` must outlive ``ts``: PETSc keeps its address.
    """
    rhs, monitor, set_rhs, set_monitor = callbacks()
    err = set_rhs(ts.handle, f.handle, rhs.address, context.address)
    err = err or set_monitor(ts.handle, monitor.address, context.address, 0)
    if err:
        raise RuntimeError(f"PETSc error {err} while registering the compiled callbacks")


def evaluate(context: Context, t: float, states: np.ndarray) -> np.ndarray:
    """The compiled RHS from Python (tests, benchmarks) for blade-major case states
    ``(B, 2 N m + 4)`` (or one state when ``B = 1``); returns the same shape."""
    states = np.asarray(states, dtype=float)
    u = context.pack(states)
    f = np.empty_like(u)
    rhs_core(t, u, f, context.array)
    return context.unpack(f).reshape(states.shape)


def sample(t: float, u: np.ndarray, context: Context) -> bool:
    """The sampling monitor from Python for a kernel-layout state ``u``; True when no case
    of the batch is left running."""
    return bool(sample_core(t, u, context.array))
