"""Calls into the native library from numba-compiled code, through function addresses.

The addresses (``TreeDynamics.addresses``) and the tree handle are plain integers passed at run
time, so the compiled callers stay cacheable (numba would bake a ctypes function's address into
the machine code instead). Array arguments go as pointers to their first element: they must be
contiguous float64.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["call_active_dynamics"]

_DOUBLE = ir.DoubleType()
_VOID_P = ir.IntType(8).as_pointer()
_RETURNS = {"i": (types.int32, ir.IntType(32)), "d": (types.float64, _DOUBLE)}


def _codegen(returns: str, arguments: str):
    """Code generation for ``call(address, handle, *args)``: the C function at ``address`` called
    as ``f(void *handle, *args)``; ``arguments`` spells each argument: ``p`` an array passed as a
    pointer to its data, ``d`` a double. ``returns``: ``i`` (int) or ``d`` (double)."""
    llvm_return = _RETURNS[returns][1]
    llvm_arguments = [_VOID_P] + [_DOUBLE if kind == "d" else _DOUBLE.as_pointer() for kind in arguments]

    def codegen(context, builder, sig, values):
        function = builder.inttoptr(values[0], ir.FunctionType(llvm_return, llvm_arguments).as_pointer())
        passed = [builder.inttoptr(values[1], _VOID_P)]
        for kind, array_type, value in zip(arguments, sig.args[2:], values[2:]):
            passed.append(
                value if kind == "d" else context.make_array(array_type)(context, builder, value).data
            )
        return builder.call(function, passed)

    return codegen


@intrinsic
def call_active_dynamics(
    typingctx, address, handle, alpha, alpha_dot, torque, mass, rotational, out, xyz, gap
):
    """``dpn_active_dynamics(handle, alpha, alpha_dot, torque, mass, rotational, alpha_ddot, xyz,
    gap)``: 0 where it succeeds, 2 where the loops do not close."""
    signature = types.int32(address, handle, alpha, alpha_dot, torque, mass, rotational, out, xyz, gap)
    return signature, _codegen("i", "pppdpppp")
