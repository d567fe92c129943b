"""The truth simulator's uncertainty table (Table 10.1): effects, scopes, registry, and
the :class:`Hardware` they realise (exact FRFs and time histories).

See :mod:`truthbench.effects.base` for the protocol and the scopes,
:mod:`truthbench.effects.hardware` for the hardware. Importing this package registers
every effect.
"""

from truthbench.effects import (  # noqa: F401  (registration)
    appended,
    attachments,
    loop,
    measurement,
    mounting,
    nonlinear,
    structural,
)
from truthbench.effects.base import (
    EFFECTS,
    SCOPES,
    TARGETS,
    Distribution,
    Effect,
    EffectParam,
    EffectSpec,
    draw,
    effect_from_inject,
    mean_values,
    parse_effect,
    register_effect,
)
from truthbench.effects.hardware import Filter, Hardware
from truthbench.effects.setup import SetupBuilder, realise

__all__ = ["EFFECTS", "SCOPES", "TARGETS", "Distribution", "Effect", "EffectParam",
           "EffectSpec", "Filter", "Hardware", "SetupBuilder", "draw", "effect_from_inject",
           "mean_values", "parse_effect", "realise", "register_effect"]
