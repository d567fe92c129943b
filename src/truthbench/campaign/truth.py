"""The truth of every test: hardware draws, reassembly, drift, per-test variation.

For trial ``i`` and test ``j`` the truth is the nominal plant with the campaign's
``truth.relative`` offsets, then every effect of ``truth.effects`` and of the test's own
``effects`` contributes a draw made according to its scope:

=============  ===========================================================================
scope          random stream (``SeedSequence(seed, spawn_key=...)``)
=============  ===========================================================================
hardware       ``(i, 1, k)``: one draw per trial for effect ``k``
reassembly     ``(i, 2, k, assembly)``: one draw per assembly index of the hardware
test           ``(i, 3, k, j)``: one draw per test
drift          ``(i, 4, k)``: a Wiener path over the sorted test times ``time_h``
=============  ===========================================================================

Test-only effects use ``k = 1000 + j * 100 + index`` so they never share a stream with
the campaign's effects (the keys are worked out once, in
:attr:`TestPlan.effects <truthbench.campaign.plan.TestPlan>`). The excitation and
sensor noise of test ``j`` use ``(i, 0, j)``. So the draws do not depend on worker count
or order, and changing one test's settings changes only that test's data (unless it
changes its assembly index or time).
"""

from __future__ import annotations

import numpy as np

from truthbench.effects import Hardware, SetupBuilder, draw


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def _drift(plan, eff, k: int, seed: int, trial: int, t_h: float) -> dict[str, float]:
    """Value at time ``t_h`` of a Wiener path through the campaign's test times."""
    times = plan.test_times_h
    rng = _rng(seed, trial, 4, k)
    walk = {p.name: [0.0] for p in eff.effect.params}
    for a, b in zip(times[:-1], times[1:], strict=True):
        for name in walk:
            walk[name].append(walk[name][-1] + np.sqrt(b - a) * rng.standard_normal())
    idx = times.index(t_h)
    out = {}
    for p in eff.effect.params:
        d = eff.distributions[p.name]
        v = d.mean + d.std * walk[p.name][idx]
        out[p.name] = float(max(v, p.minimum) if p.minimum is not None else v)
    return out


def _values(plan, test, eff, k: int, seed: int, trial: int) -> dict[str, float]:
    if eff.scope == "hardware":
        return draw(eff, _rng(seed, trial, 1, k))
    if eff.scope == "reassembly":
        return draw(eff, _rng(seed, trial, 2, k, test.test.assembly))
    if eff.scope == "test":
        return draw(eff, _rng(seed, trial, 3, k, test.index))
    return _drift(plan, eff, k, seed, trial, test.test.time_h)


def build_hardware(plan, test, trial: int, seed: int, extra_effects=()) -> Hardware:
    """The realised truth of ``test`` (a :class:`~truthbench.campaign.plan.TestPlan` of
    ``plan``) in trial ``trial``, instrumented with the test's actuators and sensors.

    ``extra_effects`` (:class:`~truthbench.effects.EffectSpec`) are added after the
    campaign's own effects, with streams of their own: this is how data with an
    undeclared effect are made (``truthbench simulate --inject``).
    """
    builder = SetupBuilder(plant=plan.plant, parameters=dict(plan.truth),
                           actuators=test.actuators, sensors=test.sensors)
    entries = list(test.effects)
    entries += [(100000 + n, e) for n, e in enumerate(extra_effects)]
    for k, eff in entries:
        label = eff.name if eff.name not in builder.effects else f"{eff.name}#{k}"
        builder.add(eff, _values(plan, test, eff, k, seed, trial), label)
    return builder.freeze()
