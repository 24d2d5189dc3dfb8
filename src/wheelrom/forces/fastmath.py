"""Compiler helpers of the kernel: LLVM bit casts, a vectorisable ``exp``, numba's ``noalias``
flag, and integer addresses cast to typed pointers (for C callbacks reading PETSc memory)."""

from __future__ import annotations

import numba
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


@intrinsic
def _float_bits(typingctx, x):
    """The IEEE bits of a float64 as int64 (LLVM ``bitcast``: vectorises)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _bits_float(typingctx, x):
    """The float64 with the IEEE bits of an int64 (inverse of :func:`_float_bits`)."""

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


def _noalias_option() -> dict:
    """``{"noalias": True}`` for ``numba.njit`` where numba has the flag (it marks every
    array argument ``noalias`` in LLVM); numba 0.68 has the compiler flag but no decorator
    option for it, so the option is added here. Without it the contact loop is still correct,
    only slower (LLVM then needs runtime overlap checks across ~20 arrays and gives up)."""
    from numba.core import compiler, cpu
    from numba.core.options import TargetOptions

    if not hasattr(compiler.Flags, "noalias"):
        return {}
    if not hasattr(cpu.CPUTargetOptions, "noalias"):
        cpu.CPUTargetOptions.noalias = TargetOptions.Mapping("noalias")
    return {"noalias": True}


NOALIAS = _noalias_option()

_SHIFTER = 6755399441055744.0  # 1.5 * 2**52: adding it rounds to an integer in the low bits
_SHIFTER_BITS = 0x4338000000000000


@numba.njit(inline="always", fastmath={"contract"}, error_model="numpy")
def fexp(x):
    """``exp(x)`` within 2 ulp for ``x`` in [-708, 709] (clamped outside), branch-free (tested).

    Why: ``math.exp`` is a libm call, which keeps LLVM from vectorising the contact loop
    (there is no vector math library in numba's LLVM here). Cody-Waite reduction
    ``x = k ln 2 + r``, ``|r| <= ln 2 / 2``, Taylor polynomial of degree 13 (truncation
    < 1e-17 relative), ``2^k`` built in the exponent bits.
    """
    x = min(max(x, -708.0), 709.0)
    shifted = x * 1.4426950408889634 + _SHIFTER
    k = _float_bits(shifted) - _SHIFTER_BITS
    kd = shifted - _SHIFTER
    r = x - kd * 6.93147180369123816490e-01  # ln 2, high part (exact product)
    r = r - kd * 1.90821492927058770002e-10  # ln 2, low part
    # Estrin's scheme: the same polynomial as Horner's but a dependency chain of ~5
    # operations instead of 14 (the chain, not the operation count, bounds the long
    # vectorised contact loop: measured 25 % of it with Horner)
    r2 = r * r
    r4 = r2 * r2
    r8 = r4 * r4
    p01 = 1.0 + r
    p23 = 0.5 + r * (1.0 / 6.0)
    p45 = 1.0 / 24.0 + r * (1.0 / 120.0)
    p67 = 1.0 / 720.0 + r * (1.0 / 5040.0)
    p89 = 1.0 / 40320.0 + r * (1.0 / 362880.0)
    p1011 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0)
    p1213 = 1.0 / 479001600.0 + r * (1.0 / 6227020800.0)
    p03 = p01 + r2 * p23
    p47 = p45 + r2 * p67
    p811 = p89 + r2 * p1011
    p07 = p03 + r4 * p47
    p813 = p811 + r4 * p1213
    p = p07 + r8 * p813
    return p * _bits_float((k + 1023) << 52)



def _address_cast(element):
    """A numba intrinsic turning an int64 address into ``element *`` (for ``numba.carray``
    over PETSc and context memory)."""

    @intrinsic
    def cast(typingctx, address):
        sig = types.CPointer(element)(types.int64)

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], context.get_value_type(signature.return_type))

        return sig, codegen

    return cast


double_ptr = _address_cast(types.float64)
long_ptr = _address_cast(types.int64)
