"""PETSc TS calls the compiled kernel without Python: ``rhs_core`` and ``sample_core`` wrapped
as C functions (numba ``cfunc``) that get and restore the Vec arrays through PETSc's C API
(external symbols resolved to libpetsc's), registered with ``TSSetRHSFunction`` /
``TSMonitorSet`` (ctypes). The callbacks are cached on disk like the kernel
(:mod:`wheelrom.runtime.kernel_cache`): a process loads them instead of compiling them.

Why: a petsc4py Python callback costs several microseconds per call (wrapping the Vecs, numpy
views, the numba dispatch of ~30 arguments); the paper case needs ~900,000 evaluations.
"""

from __future__ import annotations

import ctypes
import functools

import numba
import numpy as np
from llvmlite import binding as llvm
from numba import types

from wheelrom.forces.fastmath import double_ptr, long_ptr
from wheelrom.runtime import kernel_cache as _kernel_cache
from wheelrom.runtime.environment import petsc
from wheelrom.transient.contact_kernel import slide_core
from wheelrom.transient.kernel import rhs_core, sample_core
from wheelrom.transient.layout import (
    H_EXPONENTIAL,
    H_LEN,
    H_NSTATE,
    H_OFFSETS,
    H_RHS_CALLS,
    H_SLIDERS,
    H_SLOT_F,
    H_SLOT_U,
    H_USER_REASON,
    Context,
)


@numba.njit
def _context_at(ctx_addr):
    """The context array at ``ctx_addr`` and its header viewed as int64 (pointer slots)."""
    header = numba.carray(double_ptr(ctx_addr), H_OFFSETS)
    ctx = numba.carray(double_ptr(ctx_addr), int(header[H_LEN]))
    return ctx, numba.carray(long_ptr(ctx_addr), H_OFFSETS)


@numba.njit
def _state_at(address, ctx):
    """A PETSc state Vec's array (``H_NSTATE`` doubles: the kernel layout) at ``address``."""
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


# PETSc's C API as called by the C callbacks: external symbols that the JIT resolves to the
# addresses :func:`_register_petsc_symbols` gives it (cacheable machine code, unlike calls of
# ctypes function objects, whose addresses numba freezes into the code)
_I64, _I32 = types.int64, types.int32
_vec_get_array_read = types.ExternalFunction("VecGetArrayRead", _I32(_I64, _I64))
_vec_restore_array_read = types.ExternalFunction("VecRestoreArrayRead", _I32(_I64, _I64))
_vec_get_array = types.ExternalFunction("VecGetArray", _I32(_I64, _I64))
_vec_restore_array = types.ExternalFunction("VecRestoreArray", _I32(_I64, _I64))
_ts_set_converged_reason = types.ExternalFunction("TSSetConvergedReason", _I32(_I64, _I32))
_ts_restart_step = types.ExternalFunction("TSRestartStep", _I32(_I64))
_PETSC_SYMBOLS = ("VecGetArrayRead", "VecRestoreArrayRead", "VecGetArray", "VecRestoreArray",
                  "TSSetConvergedReason", "TSRestartStep")
_RHS_SIGNATURE = types.int32(types.int64, types.float64, types.int64, types.int64, types.int64)
_MONITOR_SIGNATURE = types.int32(types.int64, types.int32, types.float64, types.int64,
                                 types.int64)


def _rhs_callback(ts, t, U, F, ctx_addr):
    """``TSRHSFunction`` (C): ``F = rhs(t, U)`` through :func:`rhs_core`; ``ctx_addr`` the
    context array's address."""
    ctx, slots = _context_at(ctx_addr)
    slot_u = ctx_addr + 8 * H_SLOT_U
    slot_f = ctx_addr + 8 * H_SLOT_F
    err = _vec_get_array_read(U, slot_u)
    if err:
        return err
    err = _vec_get_array(F, slot_f)
    if err:  # U's array back before the error goes up
        _vec_restore_array_read(U, slot_u)
        return err
    u = _state_at(slots[H_SLOT_U], ctx)
    f = _state_at(slots[H_SLOT_F], ctx)
    rhs_core(t, u, f, ctx)
    ctx[H_RHS_CALLS] += 1.0
    err = _vec_restore_array_read(U, slot_u)
    if err:
        return err
    return _vec_restore_array(F, slot_f)


def _monitor_callback(ts, step, t, U, ctx_addr):
    """``TSMonitor`` (C), after every step: the output samples through :func:`sample_core`
    (a contact counts as slipping when it slipped in the step that ended: sampled before
    its slider's return, after which the trial force sits on the Coulomb limit to rounding),
    then the elastic law's sliders returned onto the Coulomb limit (:func:`slide_core`; when
    one moved, the TS restarts its next step: an FSAL scheme's last stage saw the old ones;
    the exponential step returns them in its own first stage); stops the TS (user reason)
    when no case is left running."""
    ctx, slots = _context_at(ctx_addr)
    slot_u = ctx_addr + 8 * H_SLOT_U
    err = _vec_get_array_read(U, slot_u)
    if err:
        return err
    stop = sample_core(t, _state_at(slots[H_SLOT_U], ctx), ctx)
    err = _vec_restore_array_read(U, slot_u)
    if err:
        return err
    if ctx[H_SLIDERS] > 0.0 and ctx[H_EXPONENTIAL] == 0.0:
        err = _vec_get_array(U, slot_u)
        if err:
            return err
        moved = slide_core(_state_at(slots[H_SLOT_U], ctx), ctx)
        err = _vec_restore_array(U, slot_u)
        if err:
            return err
        if moved:
            err = _ts_restart_step(ts)
            if err:
                return err
    if stop:
        return _ts_set_converged_reason(ts, np.int32(ctx[H_USER_REASON]))
    return 0


def _null_callback(ts, t, U, F, ctx_addr):
    """``TSRHSFunction`` (C) that leaves ``F`` as it is."""
    return 0


@functools.cache
def _register_petsc_symbols() -> None:
    """Tell the JIT's linker where PETSc's functions of the callbacks are in this process."""
    lib = _library()
    for name in _PETSC_SYMBOLS:
        llvm.add_symbol(name, ctypes.cast(getattr(lib, name), ctypes.c_void_p).value)


@functools.cache
def callbacks():
    """``(rhs, monitor, TSSetRHSFunction, TSMonitorSet)``: the C callbacks, loaded from the
    kernel cache (:mod:`wheelrom.runtime.kernel_cache`, ~0.05 s) or compiled once per machine
    (~10 s),
    and the PETSc setters. Pointers travel as int64 (same ABI on x86-64)."""
    _register_petsc_symbols()
    rhs = _kernel_cache.cfunc(_RHS_SIGNATURE, _rhs_callback)
    monitor = _kernel_cache.cfunc(_MONITOR_SIGNATURE, _monitor_callback)
    i64 = ctypes.c_int64
    set_rhs = _petsc_function(_library(), "TSSetRHSFunction", i64, i64, i64, i64)
    set_monitor = _petsc_function(_library(), "TSMonitorSet", i64, i64, i64, i64)
    return rhs, monitor, set_rhs, set_monitor


@functools.cache
def _null_rhs():
    return _kernel_cache.cfunc(_RHS_SIGNATURE, _null_callback)


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
