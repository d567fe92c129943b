"""A campaign worked out once: :class:`CampaignPlan` and its per-test :class:`TestPlan`.

:meth:`CampaignPlan.compile` takes a validated
:class:`~truthbench.campaign.spec.CampaignSpec` and works out what every stage of a run
needs, once: the plant (one builder), the nominal and the truth parameters, the update
methods and the analysis bands, and per test its record (samples, segment, frequency
lines), its excited band and update band, its channels (actuators and sensors, with the
FRF channels at the stations' positions on the nominal beam) and its effects with their
random streams. The stages (:mod:`~truthbench.campaign.trial`,
:mod:`~truthbench.campaign.truth`, :mod:`~truthbench.campaign.identification`, ...) are
functions of ``(plan, test_plan, ...)``: they read settings from ``plan.spec`` (the
updaters', the identification's, the output policy) and work out nothing again.

A plan is read-only by contract: its dicts are shared by every trial (a stage that
changes parameters works on a copy), and it is what the engines send to their workers.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from truthbench.campaign.spec import CampaignSpec
    from truthbench.campaign.spec_tables import TestSpec

TEST_EFFECT_KEY = 1000
"""Stream key of a test's own effects: ``1000 + 100 j + n`` for the n-th effect of test
``j`` (:mod:`truthbench.campaign.truth`), so they never share a stream with the
campaign's effects (keys ``0, 1, ...``)."""


def record_samples(test: TestSpec) -> int:
    """Samples of a test's record: ``round(record_s * fs_hz)``."""
    return int(round(test.record_s * test.fs_hz))


def band_overlap(band_hz, limit_hz) -> tuple[float, float]:
    """``band_hz`` cut to ``limit_hz`` (Hz; ``limit_hz`` None leaves it whole): the
    update band of a test is its excited band cut to ``[update] band_hz``. The result
    may be empty (low > high)."""
    lo, hi = band_hz
    if limit_hz is not None:
        lo, hi = max(lo, limit_hz[0]), min(hi, limit_hz[1])
    return lo, hi


def lines_in(freq_hz: np.ndarray, band_hz) -> np.ndarray:
    """Boolean mask of the lines of ``freq_hz`` (Hz) inside ``band_hz`` and above 0 Hz."""
    lo, hi = band_hz
    return (freq_hz >= lo) & (freq_hz <= hi) & (freq_hz > 0)


@dataclass(frozen=True, eq=False)
class TestPlan:
    """One test of a campaign, worked out.

    Attributes
    ----------
    index : int
        The test's position in the campaign (its random streams are keyed by it).
    test : TestSpec
        The test's table (rate, level, window, averages, noise, simulation path, assembly
        and time).
    samples : int
        Samples of the record, ``round(record_s * fs_hz)``.
    segment : int
        Samples per averaged segment, ``samples // averages`` (the H1 estimate's
        ``nperseg``).
    band_hz : (float, float)
        The excited band, Hz.
    update_band_hz : (float, float)
        The excited band cut to ``[update] band_hz`` (Hz; the lines the update uses).
    actuators, sensors : tuple of Actuator, tuple of Sensor
        The test's inputs and outputs (:mod:`truthbench.plants`).
    inputs, outputs : tuple of Channel
        The FRF channels of the actuators and sensors, at the stations' positions on the
        nominal beam (m).
    effects : tuple of (int, EffectSpec)
        The campaign's effects then the test's own, each with its stream key.
    time_path : bool
        Whether the truth is stepped in time (``simulation = "time"`` or a nonlinear
        effect), at ``oversample`` times the rate.
    """

    __test__ = False  # not a pytest test class

    index: int
    test: TestSpec
    samples: int
    segment: int
    band_hz: tuple[float, float]
    update_band_hz: tuple[float, float]
    actuators: tuple
    sensors: tuple
    inputs: tuple
    outputs: tuple
    effects: tuple
    time_path: bool

    @property
    def name(self) -> str:
        return self.test.name

    @property
    def fs_hz(self) -> float:
        return self.test.fs_hz

    @cached_property
    def freq_hz(self) -> np.ndarray:
        """The FRF's lines, ``numpy.fft.rfftfreq(segment, 1 / fs_hz)`` (Hz), as the H1
        estimate gives them."""
        f = np.fft.rfftfreq(self.segment, 1.0 / self.fs_hz)
        f.setflags(write=False)
        return f

    def update_lines(self, freq_hz: np.ndarray | None = None) -> np.ndarray:
        """Mask of the lines the update uses: inside :attr:`update_band_hz`, above 0 Hz;
        of ``freq_hz`` (a record's lines, Hz), default :attr:`freq_hz`."""
        return lines_in(self.freq_hz if freq_hz is None else freq_hz, self.update_band_hz)


@dataclass(frozen=True, eq=False)
class CampaignPlan:
    """A campaign worked out once (:meth:`compile`); see the module docstring.

    Attributes
    ----------
    spec : CampaignSpec
    plant : truthbench.plants.Plant
        The plant builder (one per campaign).
    nominal : dict
        The nominal parameters, resolved (every parameter of the plant).
    truth : dict
        The truth parameters: nominal times ``1 + offset`` for every ``truth.relative``.
    tests : tuple of TestPlan
    methods : tuple of str
        The updaters to run, primary first (empty for "none").
    update_names : tuple of str
        ``[update] parameters``.
    analysis_band_hz : (float, float)
        The update band, else the span of the tests' excited bands (Hz): where the modes
        are scored against the truth.
    uncertainty_band_hz : (float, float)
        ``[uncertainty] band_hz``, else the analysis band (Hz).
    test_times_h : tuple of float
        0 and every test's ``time_h``, sorted, distinct: the times of the drift path.
    """

    spec: CampaignSpec
    plant: object
    nominal: dict
    truth: dict
    tests: tuple[TestPlan, ...]
    methods: tuple[str, ...]
    update_names: tuple[str, ...]
    analysis_band_hz: tuple[float, float]
    uncertainty_band_hz: tuple[float, float]
    test_times_h: tuple[float, ...]

    @classmethod
    def compile(cls, spec: CampaignSpec) -> CampaignPlan:
        """Work out what every stage of a run of ``spec`` needs (see the module
        docstring); ``spec`` is a validated campaign."""
        from truthbench.measure.frfdata import Channel

        plant = spec.make_plant()
        nominal = spec.nominal_parameters()
        xyz = plant.node_coordinates_m(nominal)

        def at(station):
            return tuple(float(v) for v in xyz[plant.station_node(station)])

        shared = tuple(enumerate(spec.truth_effects()))
        tests = []
        for j, t in enumerate(spec.tests):
            actuators, sensors = spec.test_io(j)
            effects = shared + tuple((TEST_EFFECT_KEY + 100 * j + n, e)
                                     for n, e in enumerate(spec.test_effects(j)))
            samples = record_samples(t)
            tests.append(TestPlan(
                index=j, test=t, samples=samples, segment=samples // t.averages,
                band_hz=tuple(t.band_hz),
                update_band_hz=band_overlap(t.band_hz, spec.update.band_hz),
                actuators=actuators, sensors=sensors,
                inputs=tuple(Channel(a.label, "force", a.direction, station=a.station,
                                     coordinates_m=at(a.station)) for a in actuators),
                outputs=tuple(Channel(s.label, s.quantity, s.direction, station=s.station,
                                      coordinates_m=at(s.station)) for s in sensors),
                effects=effects,
                time_path=t.simulation == "time" or any(
                    e.effect.target == "nonlinear" for _, e in effects)))
        analysis = tuple(spec.update.band_hz or (min(t.band_hz[0] for t in spec.tests),
                                                 max(t.band_hz[1] for t in spec.tests)))
        return cls(spec=spec, plant=plant, nominal=nominal, truth=spec.truth_parameters(),
                   tests=tuple(tests),
                   methods=tuple(spec.update_methods()),
                   update_names=tuple(spec.update.parameters), analysis_band_hz=analysis,
                   uncertainty_band_hz=tuple(spec.uncertainty.band_hz or analysis),
                   test_times_h=tuple(sorted({0.0, *(t.time_h for t in spec.tests)})))

    @property
    def n_pairs(self) -> int:
        """SISO transfer functions over the tests (inputs x outputs, summed)."""
        return sum(len(t.actuators) * len(t.sensors) for t in self.tests)
