"""Appended dynamics (Table 10.1): actuator and sensor dynamics, time delay.

They change what is recorded, not the structure: the data then contain them and the
structural model does not (the chapter's Section 10.2.2, issue 1;
:ref:`method-estimation-issues`).

Each side has a first-order and a second-order low-pass:

==================  ==============  ============================================
effect              order           parameters
==================  ==============  ============================================
actuator_dynamics   first           ``bandwidth_hz`` (corner)
actuator_resonance  second          ``natural_frequency_hz``, ``damping_ratio``
sensor_lag          first           ``bandwidth_hz`` (corner)
sensor_dynamics     second          ``bandwidth_hz`` (natural frequency),
                                    ``damping_ratio``
==================  ==============  ============================================

Diagnosis fits a first-order low-pass ``1 / (tau s + 1)`` by ``tau_s`` and a second-order
one ``1 / (a s^2 + b s + 1)`` by ``a_s2`` and ``b_s`` (see :func:`second_order_values`):
the FRF is linear in ``a`` and ``b`` to first order about the ideal ``a = b = 0``
(``dH/da = -s^2 H``, ``dH/db = -s H``, both non-zero there), so a first-order score
from the neutral start sees both, and a Gauss-Newton step from it is well-posed. Fitting
the square roots instead (``sqrt(a)``, a time) would give a parameter whose sensitivity
is zero at the start (``dH/d sqrt(a) = -2 sqrt(a) s^2 H``): invisible to the score and
stuck at its bound.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import ClassVar

import numpy as np

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)
from truthbench.effects.hardware import Filter

FIRST_ORDER_LIMIT = 1e-9
"""A second-order low-pass fitted with ``a = 0`` is the first-order ``1 / (b s + 1)``;
its natural frequency and damping ratio are infinite. It is given as the second-order
low-pass whose ``a`` is ``(FIRST_ORDER_LIMIT b)^2``: natural frequency
``1 / (2 pi 1e-9 b)``, damping ratio ``5e8``. The term added to the denominator,
``(1e-9 b s)^2``, is below double round-off relative to ``1 + b s`` wherever
``|b s| < 1e2`` (the first-order low-pass already down 40 dB) and below ``1e-18 |b s|``
beyond."""

SMALLEST_TIME_S = 1e-100
"""A low-pass whose time scale (``sqrt(a)``) is below this is ideal: at any frequency
below 1e80 rad/s it changes the FRF by less than round-off, and its natural frequency
would overflow the filter's coefficients."""


def _bandwidth(fitted) -> dict[str, float]:
    """A low-pass fitted by its time constant ``tau_s`` (0: ideal, infinite bandwidth)."""
    tau = fitted["tau_s"]
    return {"bandwidth_hz": np.inf if tau <= 0 else 1.0 / (2 * np.pi * tau)}


_LOW_PASS = Diagnosable((FitParam("tau_s", "time", 0.5, minimum=0.0),), to_values=_bandwidth)
"""The first-order form: ``tau_s`` starts at 0 (ideal); natural size half of
``1 / (2 pi f_max)`` (a corner at twice the band's top)."""


def second_order_coefficients(frequency_hz: float, damping_ratio: float
                              ) -> tuple[float, float]:
    """``(a, b)`` of the low-pass ``1 / (a s^2 + b s + 1)`` with natural frequency
    ``frequency_hz`` and damping ratio ``damping_ratio``: ``a = 1 / w^2``,
    ``b = 2 zeta / w``, ``w = 2 pi frequency_hz`` (``(0, 0)``: ideal, for an infinite
    frequency).

    Parameters
    ----------
    frequency_hz : float
        Natural frequency, Hz (> 0, may be inf).
    damping_ratio : float
        Damping ratio (>= 0).

    Returns
    -------
    a : float
        Coefficient of ``s^2``, s^2.
    b : float
        Coefficient of ``s``, s.
    """
    w = 2 * np.pi * float(frequency_hz)
    return 1.0 / (w * w), 2.0 * float(damping_ratio) / w


def second_order_values(a: float, b: float, ideal_damping: float = 1.0
                        ) -> tuple[float, float]:
    """Natural frequency and damping ratio of the low-pass ``1 / (a s^2 + b s + 1)``
    (the inverse of :func:`second_order_coefficients`).

    ``a > 0``: ``f = 1 / (2 pi sqrt(a))``, ``zeta = b / (2 sqrt(a))``. ``a = 0``, ``b > 0``:
    the first-order low-pass ``1 / (b s + 1)`` (corner ``1 / (2 pi b)``), given as the
    second-order one with ``a = (FIRST_ORDER_LIMIT b)^2`` (see
    :data:`FIRST_ORDER_LIMIT`): ``f = 1 / (2 pi 1e-9 b)``, ``zeta = 5e8``. ``a = b = 0``
    (or a time scale below :data:`SMALLEST_TIME_S`): ideal, ``f = inf`` with
    ``zeta = ideal_damping`` (immaterial).

    Parameters
    ----------
    a : float
        Coefficient of ``s^2``, s^2 (>= 0).
    b : float
        Coefficient of ``s``, s (>= 0).
    ideal_damping : float, optional
        Damping ratio reported for the ideal low-pass.

    Returns
    -------
    frequency_hz : float
    damping_ratio : float
    """
    a, b = float(a), float(b)
    if a < 0 or b < 0:
        raise ValueError(f"a second-order low-pass 1 / (a s^2 + b s + 1) needs a >= 0 and "
                         f"b >= 0; got a = {a!r}, b = {b!r}")
    r = max(np.sqrt(a), FIRST_ORDER_LIMIT * b)
    if r < SMALLEST_TIME_S:
        return np.inf, float(ideal_damping)
    return 1.0 / (2 * np.pi * r), b / (2 * r)


def _second_order_form(frequency: str, ideal_damping: float) -> Diagnosable:
    """The diagnosis form of a second-order low-pass whose natural frequency is the
    effect's parameter ``frequency``.

    ``a_s2`` and ``b_s`` start at 0 (ideal) with minimum 0. Natural sizes: ``b``, half of
    ``1 / (2 pi f_max)`` (reference ``time``, as ``tau_s``): a damping ratio of 0.5 at a
    natural frequency of twice the band's top. ``a``: ``0.25 (1 / (2 pi f_max))^2``
    (reference ``time_squared``), that natural frequency.
    """

    def to_values(fitted: Mapping[str, float]) -> dict[str, float]:
        f, zeta = second_order_values(fitted["a_s2"], fitted["b_s"], ideal_damping)
        return {frequency: f, "damping_ratio": zeta}

    return Diagnosable((FitParam("a_s2", "time_squared", 0.25, minimum=0.0),
                        FitParam("b_s", "time", 0.5, minimum=0.0)), to_values=to_values)


def _first_order_low_pass(bandwidth_hz: float) -> Filter:
    """``w / (s + w)``, ``w = 2 pi bandwidth_hz``."""
    w = 2 * np.pi * bandwidth_hz
    return Filter((w,), (1.0, w))


def _second_order_low_pass(frequency_hz: float, damping_ratio: float) -> Filter:
    """``w^2 / (s^2 + 2 zeta w s + w^2)``, ``w = 2 pi frequency_hz``."""
    w = 2 * np.pi * frequency_hz
    return Filter((w * w,), (1.0, 2.0 * damping_ratio * w, w * w))


def _add(filters: list, make: Callable[..., Filter], frequency_hz: float, *args) -> None:
    """Append ``make(frequency_hz, *args)`` unless the frequency is infinite (ideal)."""
    if np.isfinite(frequency_hz):
        filters.append(make(frequency_hz, *args))


@register_effect
class ActuatorDynamics(Effect):
    name: ClassVar[str] = "actuator_dynamics"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("the applied force is the recorded command through a "
                                  "first-order low-pass (a shaker's electrical pole); "
                                  "second order: actuator_resonance")
    params: ClassVar = (EffectParam("bandwidth_hz", 1e3, "corner frequency, Hz", 1e-3),)
    options: ClassVar = {}
    neutral: ClassVar = {"bandwidth_hz": np.inf}
    diagnosis: ClassVar = _LOW_PASS

    def contribute(self, values, options, setup):
        _add(setup.input_filters, _first_order_low_pass, values["bandwidth_hz"])


@register_effect
class ActuatorResonance(Effect):
    name: ClassVar[str] = "actuator_resonance"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("the applied force is the recorded command through a "
                                  "second-order low-pass (a shaker's armature or stinger "
                                  "resonance): a peak near the natural frequency for a "
                                  "damping ratio below 1/sqrt(2); first order: "
                                  "actuator_dynamics")
    params: ClassVar = (EffectParam("natural_frequency_hz", 1e3, "natural frequency, Hz",
                                    1e-3),
                        EffectParam("damping_ratio", 0.3, "damping ratio", 0.0))
    options: ClassVar = {}
    neutral: ClassVar = {"natural_frequency_hz": np.inf}
    diagnosis: ClassVar = _second_order_form("natural_frequency_hz", 0.3)

    def contribute(self, values, options, setup):
        _add(setup.input_filters, _second_order_low_pass, values["natural_frequency_hz"],
             values["damping_ratio"])


@register_effect
class SensorDynamics(Effect):
    name: ClassVar[str] = "sensor_dynamics"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("every recorded output passes a second-order low-pass "
                                  "(an accelerometer's mounted resonance, an anti-alias "
                                  "filter) of natural frequency bandwidth_hz; first order: "
                                  "sensor_lag")
    params: ClassVar = (EffectParam("bandwidth_hz", 2e3, "natural frequency, Hz", 1e-3),
                        EffectParam("damping_ratio", 0.7, "damping ratio", 0.0))
    options: ClassVar = {}
    neutral: ClassVar = {"bandwidth_hz": np.inf}
    diagnosis: ClassVar = _second_order_form("bandwidth_hz", 0.7)

    def contribute(self, values, options, setup):
        _add(setup.output_filters, _second_order_low_pass, values["bandwidth_hz"],
             values["damping_ratio"])


@register_effect
class SensorLag(Effect):
    name: ClassVar[str] = "sensor_lag"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("every recorded output passes a first-order low-pass (a "
                                  "signal conditioner's RC filter, a sensor's time "
                                  "constant); second order: sensor_dynamics")
    params: ClassVar = (EffectParam("bandwidth_hz", 2e3, "corner frequency, Hz", 1e-3),)
    options: ClassVar = {}
    neutral: ClassVar = {"bandwidth_hz": np.inf}
    diagnosis: ClassVar = _LOW_PASS

    def contribute(self, values, options, setup):
        _add(setup.output_filters, _first_order_low_pass, values["bandwidth_hz"])


@register_effect
class TimeDelay(Effect):
    name: ClassVar[str] = "time_delay"
    target: ClassVar[str] = "appended"
    description: ClassVar[str] = ("the recorded outputs lag the recorded input by a pure "
                                  "delay (exact: a linear phase -omega tau, no Pade)")
    params: ClassVar = (EffectParam("delay_s", 0.0, "delay, s", 0.0),)
    options: ClassVar = {}
    diagnosis: ClassVar = Diagnosable((FitParam("delay_s", "time", 1.0, minimum=0.0),))

    def contribute(self, values, options, setup):
        setup.delay_s += values["delay_s"]
