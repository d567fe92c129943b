"""The truth simulator's uncertainty table (Table 10.1): effects, scopes, registry.

See :mod:`truthbench.effects.base` for the protocol and the scopes. Importing this
package registers every effect.
"""

from truthbench.effects import appended, loop, measurement, nonlinear, structural  # noqa: F401
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
    parse_effect,
    register_effect,
)
from truthbench.effects.setup import Filter, SetupBuilder, TestSetup

__all__ = ["EFFECTS", "SCOPES", "TARGETS", "Distribution", "Effect", "EffectParam",
           "EffectSpec", "Filter", "SetupBuilder", "TestSetup", "draw", "effect_from_inject",
           "parse_effect", "register_effect"]
