"""The compiled engine of :mod:`truthbench.simulate.nonlinear` (imported only with numba).

The loop's source lives in :mod:`truthbench.simulate._nonlinear_kernel`, plain Python that
also runs interpreted. Here every function of it is copied with a private globals
dictionary in which the helper names point at their compiled versions, and wrapped in
``numba.njit(cache=True)``: one source, two engines, the same arithmetic (no fastmath).
The compiled code is cached on disk next to the kernel source.
"""

from __future__ import annotations

import types

import numba

from . import _nonlinear_kernel as _src

#: every function of the kernel module, compiled (they call one another)
_FUNCTIONS = tuple(
    name
    for name, obj in vars(_src).items()
    if isinstance(obj, types.FunctionType) and obj.__module__ == _src.__name__
)

#: reassociation lets LLVM vectorise the sums over modes (as in _kernels_numba)
_FASTMATH = {"reassoc", "contract", "nsz"}

#: small helpers of the per-sample path, inlined at numba's level: a call passing many
#: arrays costs more than the work (measured: x1.7 on the whole loop)
_INLINE = ("fill_input", "record")

_globals = dict(vars(_src))
for _name in _FUNCTIONS:
    _f = getattr(_src, _name)
    _copy = types.FunctionType(_f.__code__, _globals, _f.__name__, _f.__defaults__,
                               _f.__closure__)
    _copy.__module__ = _src.__name__
    _copy.__qualname__ = _f.__qualname__
    _copy.__doc__ = _f.__doc__
    _globals[_name] = numba.njit(
        cache=True, fastmath=_FASTMATH, inline="always" if _name in _INLINE else "never"
    )(_copy)

run = _globals["run"]
