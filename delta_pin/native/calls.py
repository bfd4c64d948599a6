"""Calls into the native library from numba-compiled code, through function addresses.

The addresses (``TreeDynamics.address_dynamics``, ``address_gap``) and the tree handle are plain
integers passed at run time, so the compiled callers stay cacheable (numba would bake a ctypes
function's address into the machine code instead). Arrays must be contiguous float64.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["call_closure_gap", "call_tree_dynamics"]

_DOUBLE = ir.DoubleType()
_DOUBLE_P = _DOUBLE.as_pointer()
_VOID_P = ir.IntType(8).as_pointer()


def _data(context, builder, array_type, value):
    return context.make_array(array_type)(context, builder, value).data


@intrinsic
def call_tree_dynamics(typingctx, address, handle, q, v, tau, mass, rotational, ddq):
    """``dpn_dynamics(handle, q, v, tau, mass, rotational, ddq)`` at ``address``; returns its
    status (0: ok)."""
    signature = types.int32(address, handle, q, v, tau, mass, rotational, ddq)

    def codegen(context, builder, sig, args):
        function_type = ir.FunctionType(
            ir.IntType(32), [_VOID_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE_P, _DOUBLE, _DOUBLE_P, _DOUBLE_P]
        )
        function = builder.inttoptr(args[0], function_type.as_pointer())
        arguments = [builder.inttoptr(args[1], _VOID_P)]
        for index in (2, 3, 4):
            arguments.append(_data(context, builder, sig.args[index], args[index]))
        arguments.append(args[5])
        for index in (6, 7):
            arguments.append(_data(context, builder, sig.args[index], args[index]))
        return builder.call(function, arguments)

    return signature, codegen


@intrinsic
def call_closure_gap(typingctx, address, handle, q):
    """``dpn_closure_gap(handle, q)`` at ``address``: the largest closure gap [m]."""
    signature = types.float64(address, handle, q)

    def codegen(context, builder, sig, args):
        function_type = ir.FunctionType(_DOUBLE, [_VOID_P, _DOUBLE_P])
        function = builder.inttoptr(args[0], function_type.as_pointer())
        handle = builder.inttoptr(args[1], _VOID_P)
        return builder.call(function, [handle, _data(context, builder, sig.args[2], args[2])])

    return signature, codegen
