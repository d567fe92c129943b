"""The compiled engine of :mod:`truthbench.simulate.nonlinear` (imported only with numba).

The loop's source lives in :mod:`truthbench.simulate._nonlinear_kernel`, plain Python that
also runs interpreted. Here every function of it is copied with a private globals
dictionary in which the helper names point at their compiled versions, and wrapped in
``numba.njit(cache=True)``: one source, two engines, the same arithmetic up to the
reassociation of sums (``fastmath`` reassoc/contract/nsz only). The compiled code is
cached on disk next to the kernel source: compiling it takes one to two minutes of CPU
on a cold cache (once per machine and source version); a later process loads it in
about half a second.
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

#: helpers inlined at numba's level (into their callers' IR): a call passing many arrays
#: costs more than the work. The per-sample helpers (measured: x1.7 on the whole loop)
#: and the event path with its passes over the modes (-15 % per event). Inlining needs
#: calls with at most 30 arguments (CPython packs longer ones into a tuple, which
#: numba's inliner does not take): hence the tuples of arrays.
_INLINE = ("fill_input", "record", "event_step", "rows_at", "row_derivs", "row_value",
           "add_jump", "gate", "grid_point", "modal_input", "rows_active", "fric_forcing",
           "lean_gate", "row_rate", "gate_rows", "quintic_argmin",
           "dip_suspect", "tabulated_state")

#: the only function that allocates (the outputs and every work array). All the others,
#: the simulation loop included, are compiled without numba's reference counting
#: (``_nrt=False``): they never allocate, and the atomic increments and decrements on
#: every array and view passed around the event path cost more than its arithmetic
#: (measured: half the time of a run with many friction events).
_ALLOCATING = ("run",)

_globals = dict(vars(_src))
for _name in _FUNCTIONS:
    _f = getattr(_src, _name)
    _copy = types.FunctionType(_f.__code__, _globals, _f.__name__, _f.__defaults__,
                               _f.__closure__)
    _copy.__module__ = _src.__name__
    _copy.__qualname__ = _f.__qualname__
    _copy.__doc__ = _f.__doc__
    _options = dict(cache=True, fastmath=_FASTMATH,
                    inline="always" if _name in _INLINE else "never")
    if _name not in _ALLOCATING:
        _options["_nrt"] = False
    _globals[_name] = numba.njit(**_options)(_copy)

run = _globals["run"]
