"""Nonlinear effects (Table 10.1): weak (cubic stiffness, amplitude-dependent damping)
and strong (Coulomb friction with stick-slip, dead band), each grounded at one DOF of a
station (the hub bearing is ``station = "hub"``, ``direction = "rz"``).

Each effect contributes a law of :mod:`truthbench.simulate.nonlinear_elements` (the
engine owns the laws; an effect only chooses one and places it). Hardware with a nonlinear effect is
simulated in the time domain (:meth:`truthbench.effects.Hardware.simulate`), whatever
the method asked for: the periodic steady state is exact only for a linear truth.
"""

from __future__ import annotations

from typing import ClassVar

from truthbench.effects.base import (
    Diagnosable,
    Effect,
    EffectParam,
    FitParam,
    register_effect,
)
from truthbench.simulate.nonlinear_elements import (
    AmplitudeDependentDamping,
    CoulombFriction,
    CubicStiffness,
    DeadBand,
)


class _Grounded(Effect):
    target: ClassVar[str] = "nonlinear"
    options: ClassVar = {"station": None, "direction": "z"}

    def law(self, values):  # pragma: no cover - abstract
        raise NotImplementedError

    def contribute(self, values, options, setup):
        setup.plant.station_node(options["station"])  # validates
        setup.nonlinear.append((options["station"], options["direction"], self.law(values)))


@register_effect
class CoulombFrictionEffect(_Grounded):
    name: ClassVar[str] = "coulomb_friction"
    description: ClassVar[str] = ("Coulomb friction at a DOF (e.g. the hub bearing): "
                                  "f = -F_c sign(v) while slipping, stick within F_c; its "
                                  "effect shrinks as the excitation grows")
    params: ClassVar = (EffectParam("force_n", 0.0, "friction force, N (N m at a rotation)",
                                    0.0),)
    diagnosis: ClassVar = Diagnosable(
        (FitParam("force_n", "force", 0.05, minimum=0.0),), location="station",
        directions="measured")
    """Diagnosed through its statistical linearisation: in each test a grounded dashpot
    ``sqrt(2 / pi) F_c / sigma_v`` (sigma_v the RMS velocity at the DOF in that test),
    so its damping falls as the excitation level rises (:mod:`truthbench.diagnose`)."""

    def law(self, values):
        return CoulombFriction(values["force_n"])


@register_effect
class CubicStiffnessEffect(_Grounded):
    name: ClassVar[str] = "cubic_stiffness"
    description: ClassVar[str] = "a grounded cubic spring, f = -k3 d^3 (weak nonlinearity)"
    params: ClassVar = (EffectParam("k3_n_m3", 0.0, "cubic stiffness, N/m^3"),)

    def law(self, values):
        return CubicStiffness(values["k3_n_m3"])


@register_effect
class DeadBandEffect(_Grounded):
    name: ClassVar[str] = "dead_band"
    description: ClassVar[str] = ("a grounded spring with free play: no force inside the "
                                  "gap, stiffness outside it (strong nonlinearity)")
    params: ClassVar = (EffectParam("gap_m", 0.0, "half-width of the free play, m", 0.0),
                        EffectParam("stiffness_n_m", 0.0, "contact stiffness, N/m", 0.0))

    def law(self, values):
        return DeadBand(values["gap_m"], values["stiffness_n_m"])


@register_effect
class AmplitudeDampingEffect(_Grounded):
    name: ClassVar[str] = "amplitude_damping"
    description: ClassVar[str] = ("quadratic damping f = -c2 |v| v: damping that grows "
                                  "with amplitude (weak nonlinearity)")
    params: ClassVar = (EffectParam("c2_n_s2_m2", 0.0, "coefficient, N s^2/m^2", 0.0),)

    def law(self, values):
        return AmplitudeDependentDamping(values["c2_n_s2_m2"])
