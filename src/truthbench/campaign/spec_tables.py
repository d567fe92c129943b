"""The tables of a campaign file, one pydantic model each: ``[campaign]``, ``[plant]``,
``[[sensors]]``, ``[truth]``, ``[[tests]]`` with their actuators, ``[identify]``,
``[update]``, ``[uncertainty]``, ``[output]`` and ``[diagnose]`` with its study and
channel places; every key with its type, bounds and default, the checks that need no
other table, and the station name a position in metres gets
(:func:`position_station_name`). :class:`~truthbench.campaign.spec.CampaignSpec` puts
them together and checks what crosses tables (:mod:`truthbench.campaign.spec`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from numbers import Real
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from truthbench._validation import is_safe_name, name_rule
from truthbench.diagnose.settings import DiagnoseSettings
from truthbench.identify import PLSCFIdentifier
from truthbench.settings import declared, settings_model
from truthbench.update import UPDATERS

Direction = Literal["x", "y", "z", "rx", "ry", "rz"]
# every number of a campaign is finite: TOML has inf and nan literals, and an infinite
# rate or length would only fail deep inside the computation
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]

MAX_ELEMENTS = 500
"""Largest ``[plant] n_elements``. A beam of n elements has 6 (n + 1) DOFs; up to 500
elements (3006 DOFs) one sparse eigen solve of the lowest 20-60 modes takes under a
second here (0.35-0.9 s), while from about 700 elements the shift-invert solver slows
down sharply (800 elements: 4 s for 8 modes; 1000: 20 s; 2000 did not finish in a
minute). Discretization error is far below any test's at a few tens of elements
(Figure 10.2; docs/validation.md)."""

LEVEL_RMS_RANGE = (1e-6, 1e6)
"""Smallest and largest ``[[tests]] level_rms``, N (N m for a moment): a micronewton to a
meganewton, three decades beyond the lightest and heaviest laboratory excitation (a
shaker gives up to about a kilonewton). Every model here is linear in the level and the
noise is relative to the signal, so nothing is lost by the range, while the H1 estimate
needs the level's fourth power inside the float range: its coherence squares the
cross-spectrum (level^2 times the segment length and the response's gain). On the
quickstart the coherence overflows from about 1e75 N and underflows below about
1e-75 N; at 1e150 N the spectra overflow and at 1e200 N the simulated responses do."""

DEFAULT_NODE_TOLERANCE_M = 1e-4
"""``[plant] node_tolerance_m`` default (the plants' own
:data:`~truthbench.plants.base.DEFAULT_NODE_TOLERANCE_M`): a position in metres maps to a
node no farther than 0.1 mm away."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False,
                              use_attribute_docstrings=True)


def _one_placement(data: Any, what: str) -> Any:
    """A sensor or actuator is placed by ``station`` or by ``x_m``: exactly one."""
    if isinstance(data, Mapping):
        given = [k for k in ("station", "x_m") if data.get(k) is not None]
        if len(given) != 1:
            raise PydanticCustomError(
                "placement", f"{what} placed by 'station' (a station name) or by 'x_m' "
                f"(metres along the beam from its first end), exactly one of them; "
                f"{'both are given' if given else 'neither is given'}")
    return data


class SensorSpec(_Strict):
    """A sensor: station (or position ``x_m``), direction and quantity.

    A sensor given by ``x_m`` is placed at a generated station (see
    :func:`position_station_name`) when the campaign is validated."""

    station: str | None = None
    """A station name (``[plant] stations`` or the plant's own: ``end_a``, ``mid``, ...);
    give this or ``x_m``."""
    x_m: FiniteFloat | None = None
    """Position along the beam from its first end, m, on a node (within
    ``[plant] node_tolerance_m``); give this or ``station``."""
    direction: Direction
    """Measured direction: translation along x, y, z or rotation about them."""
    quantity: Literal["displacement", "velocity", "acceleration", "strain"] = "acceleration"
    """What the sensor measures (strain: bending strain at the surface)."""

    @model_validator(mode="before")
    @classmethod
    def _placement(cls, data):
        return _one_placement(data, "a sensor")


class ActuatorSpec(_Strict):
    """A force or moment input at a station (or position ``x_m``)."""

    station: str | None = None
    """A station name; give this or ``x_m``."""
    x_m: FiniteFloat | None = None
    """Position along the beam from its first end, m, on a node; give this or
    ``station``."""
    direction: Direction
    """Direction of the force (x, y, z) or of the moment (rx, ry, rz)."""

    @model_validator(mode="before")
    @classmethod
    def _placement(cls, data):
        return _one_placement(data, "an actuator")


class StationPosition(_Strict):
    """A station given by its position: ``{ x_m = 0.42 }``, metres along the beam from its
    first end on the nominal length."""

    x_m: FiniteFloat
    """Metres along the beam from its first end."""


def _safe_name(value, portable: bool):
    if not is_safe_name(value, portable):
        raise PydanticCustomError("name", f"a name of {name_rule(portable)}")
    return value


class CampaignMeta(_Strict):
    name: str
    """Names the output folder ``results/<name>`` and the HDF5 results: a portable name
    (:func:`truthbench._validation.check_name`), never a path."""
    description: str = ""
    """One line shown in the report."""
    seed: Annotated[int, Field(ge=0)] = 0
    """Root of every random draw (hardware, excitation, noise); results do not depend on
    the worker count."""
    trials: Annotated[int, Field(ge=1)] = 1
    """Monte Carlo trials: each draws new hardware from the truth and runs every test."""

    @field_validator("name")
    @classmethod
    def _portable_name(cls, v):
        return _safe_name(v, portable=True)


class PlantSpec(_Strict):
    """The test article: plant type, mesh, section, material, stations, suspension."""

    type: Literal["free_free_beam", "hub_beam"]
    """The plant: a free-free beam on its suspension, or a clamped beam on a rotating
    hub."""
    n_elements: Annotated[int, Field(ge=1)] = 20
    """Equal elements along the beam, at most :data:`MAX_ELEMENTS`."""
    n_groups: Annotated[int, Field(ge=1)] = 1
    """Element groups along the beam, each with its own copy of every element parameter
    (``E_pa@g2``), for localized updating."""
    section: str = "tube"
    """Cross-section, one of :data:`truthbench.fe.beam.SECTIONS` (its dimensions are plant
    parameters: ``r_m``, ``t_m``; ``b_m``, ``h_m``; ``d_m``)."""
    material: str = "aluminium"
    """Material preset (:data:`truthbench.plants.base.MATERIALS`): the defaults of
    ``E_pa``, ``rho_kg_m3``, ``nu``."""
    stations: dict[str, float | StationPosition] = Field(default_factory=dict)
    """Named stations: a fraction of the length (``gauge = 0.35``) or a position
    (``gauge = { x_m = 0.42 }``)."""
    suspension_x_m: Annotated[list[FiniteFloat], Field(min_length=1)] | None = None
    """Suspension points of the free-free beam, metres from the first end (default the
    nodes nearest 0.224 L and 0.776 L)."""
    supports: Literal["springs", "foam", "none"] | None = None
    """What holds the free-free beam (:data:`truthbench.plants.base.SUPPORTS`): "springs"
    (it touches ground only at its suspension points, through springs), "foam" (it lies
    on soft blocks there) or "none" (nothing touches it: no suspension); unset: hung on
    its suspension, as before the key existed."""
    node_tolerance_m: PositiveFloat = DEFAULT_NODE_TOLERANCE_M
    """Largest distance from a position in metres to the node it maps to."""
    parameters: dict[str, FiniteFloat] = Field(default_factory=dict)
    """The nominal model's parameters in SI, units in the names (``E_pa``,
    ``rho_kg_m3``, ``r_m``, ...); unlisted ones take the plant's defaults."""

    @field_validator("n_elements")
    @classmethod
    def _solvable_size(cls, v):
        if v > MAX_ELEMENTS:
            raise PydanticCustomError(
                "size", f"at most {MAX_ELEMENTS} elements ({6 * (MAX_ELEMENTS + 1)} DOFs), "
                f"what the eigensolver handles in about a second; {v} elements give "
                f"{6 * (v + 1)} DOFs")
        return v

    @field_validator("section")
    @classmethod
    def _known_section(cls, v):
        from truthbench.fe.beam import SECTIONS

        if v not in SECTIONS:
            raise PydanticCustomError("choice", f"one of {', '.join(map(repr, SECTIONS))}")
        return v

    @field_validator("material")
    @classmethod
    def _known_material(cls, v):
        from truthbench.plants.base import MATERIALS

        if v not in MATERIALS:
            raise PydanticCustomError("choice", f"one of {', '.join(map(repr, MATERIALS))}")
        return v

    @field_validator("supports")
    @classmethod
    def _supports_of_a_free_free_beam(cls, v, info):
        if v is None:
            return v
        if info.data.get("type") not in (None, "free_free_beam"):
            raise PydanticCustomError(
                "supports", "no supports: what holds a {kind} is fixed by its kind (supports "
                "belongs to a free_free_beam)", {"kind": info.data["type"]})
        if v == "none" and info.data.get("suspension_x_m") is not None:
            raise PydanticCustomError(
                "supports", "supports = 'none' (nothing touches the beam) without "
                "suspension_x_m; suspension_x_m = {x} is given", {"x": info.data["suspension_x_m"]})
        return v

    @field_validator("stations", mode="before")
    @classmethod
    def _station_values(cls, v):
        if not isinstance(v, Mapping):
            return v  # pydantic reports the type
        def number(x):
            return isinstance(x, Real) and not isinstance(x, bool) and math.isfinite(x)

        out = {}
        for name, value in v.items():
            if isinstance(value, StationPosition):
                out[name] = value
            elif isinstance(value, Mapping) and set(value) == {"x_m"} and number(value["x_m"]):
                out[name] = StationPosition(x_m=float(value["x_m"]))
            elif number(value) and 0.0 <= float(value) <= 1.0:
                out[name] = float(value)
            else:
                raise PydanticCustomError(
                    "station", f"station {name!r} as a fraction of the length in [0, 1] or "
                    f"as a position {{ x_m = <metres from the first end> }}, not {value!r}")
        return out

    def resolved_positions(self) -> tuple[dict[str, float], tuple[float, ...] | None]:
        """Stations and suspension points as node fractions (``node / n_elements``):
        positions in metres mapped to their nodes on the nominal length.

        Returns
        -------
        stations : dict of str -> float
        suspension : tuple of float or None
            None: the plant's default suspension points.

        Raises
        ------
        ModelError
            A position is off the beam or farther than ``node_tolerance_m`` from a node
            (a campaign file reports this with its key when it is loaded).
        """
        return _plant_positions(self.model_dump_json())

    def plant_options(self) -> dict[str, Any]:
        """Keyword options of :func:`truthbench.plants.make_plant` for this plant."""
        stations, suspension = self.resolved_positions()
        options = dict(n_elements=self.n_elements, n_groups=self.n_groups,
                       stations=stations, section=self.section, material=self.material)
        if suspension is not None:
            options["suspension_fractions"] = suspension
        if self.supports is not None:
            options["supports"] = self.supports
        return options


def _base_plant(plant: PlantSpec):
    """The plant with only its fraction stations and default suspension: the mesh on
    which positions in metres are located."""
    from truthbench.plants import make_plant

    return make_plant(plant.type, n_elements=plant.n_elements, n_groups=plant.n_groups,
                      stations={k: v for k, v in plant.stations.items()
                                if not isinstance(v, StationPosition)},
                      section=plant.section, material=plant.material)


@functools.lru_cache(maxsize=64)
def _plant_positions(plant_json: str) -> tuple[dict[str, float], tuple[float, ...] | None]:
    plant = PlantSpec.model_validate_json(plant_json)
    metres = [v for v in plant.stations.values() if isinstance(v, StationPosition)]
    if not metres and plant.suspension_x_m is None:
        return dict(plant.stations), None
    base = _base_plant(plant)
    tol = plant.node_tolerance_m
    stations = {k: (base.fraction_at_m(v.x_m, plant.parameters, tolerance_m=tol)
                    if isinstance(v, StationPosition) else v)
                for k, v in plant.stations.items()}
    suspension = None if plant.suspension_x_m is None else tuple(
        base.fraction_at_m(x, plant.parameters, tolerance_m=tol) for x in plant.suspension_x_m)
    return stations, suspension


def position_station_name(x_m: float) -> str:
    """The station name given to a sensor or actuator placed by position: ``x`` then the
    position in millimetres (up to 6 decimals, trailing zeros dropped) with the decimal
    point written ``p``, then ``mm``; a minus sign (a position just before the first end,
    within the tolerance) is written ``m``. Only ``[a-z0-9]``: safe in channel labels and
    file formats. ``0.05`` -> ``x50mm``, ``0.0125`` -> ``x12p5mm``, ``1.1`` ->
    ``x1100mm``."""
    mm = f"{x_m * 1000.0:.6f}".rstrip("0").rstrip(".")
    if mm in ("-0", ""):
        mm = "0"
    return "x" + mm.replace("-", "m").replace(".", "p") + "mm"


class TruthSpec(_Strict):
    """The hardware's truth: offsets from the nominal model plus effects (Table 10.1)."""

    relative: dict[str, Annotated[float, Field(gt=-1, allow_inf_nan=False)]] = Field(
        default_factory=dict)
    """Fractional offsets: ``E_pa = 0.03`` means truth E = 1.03 x nominal E."""
    effects: list[dict[str, Any]] = Field(default_factory=list)
    """``[[truth.effects]]`` tables, validated by :func:`truthbench.effects.parse_effect`."""


def _ordered_band(v):
    if not v[0] < v[1]:
        raise PydanticCustomError("band", "[low, high] in Hz with low < high")
    return v


class TestSpec(_Strict):
    """One test of the test matrix."""

    __test__ = False  # not a pytest test class

    name: str
    """Names the test in the results, the report and file names."""
    actuators: Annotated[list[ActuatorSpec], Field(min_length=1)]
    """``[[tests.actuators]]``: the inputs of the test (one or more)."""
    sensors: list[SensorSpec] | None = None
    """``[[tests.sensors]]``: this test's sensors (default: the campaign's
    ``[[sensors]]``)."""
    level_rms: PositiveFloat = Field(1.0, json_schema_extra={"unit": "N or N m"})
    """RMS of each input's band-limited random force (or moment) over the record."""
    band_hz: tuple[NonNegFloat, PositiveFloat]
    """The excited band: the input's flat spectrum spans it (upper edge at or below
    Nyquist)."""
    fs_hz: PositiveFloat
    """Sampling rate of the recorded time histories."""
    record_s: PositiveFloat
    """Record length; the record holds ``round(record_s fs_hz)`` samples."""
    averages: Annotated[int, Field(ge=1)] = 10
    """Segments averaged in the H1 estimate (Bartlett's method, no overlap)."""
    window: Literal["rectangular", "bartlett", "hann", "hamming"] = "bartlett"
    """Window of every segment."""
    noise_fraction: NonNegFloat = 0.0
    """Output noise: its standard deviation as a fraction of each output's RMS (at most
    ``sqrt(2 averages)``)."""
    oversample: Annotated[int, Field(ge=1, le=64)] = 8
    """Time steps per sample of the "time" simulation."""
    simulation: Literal["periodic", "time"] = "periodic"
    """"periodic": exact steady state of the periodic record, line by line (linear truth);
    "time": exact first-order-hold time stepping at ``oversample`` times the rate."""
    assembly: Annotated[int, Field(ge=0)] = 0
    """Which assembly of the hardware (reassembly-scope effects are redrawn per value)."""
    time_h: NonNegFloat = 0.0
    """Time of the test since the campaign began, hours (drift-scope effects)."""
    effects: list[dict[str, Any]] = Field(default_factory=list)
    """Effects of this test only (added mass, other boundary conditions, ...)."""

    @field_validator("name")
    @classmethod
    def _group_name(cls, v):
        return _safe_name(v, portable=False)

    @field_validator("band_hz")
    @classmethod
    def _band_ordered(cls, v):
        return _ordered_band(v)

    @field_validator("level_rms")
    @classmethod
    def _level_in_range(cls, v):
        low, high = LEVEL_RMS_RANGE
        if not low <= v <= high:
            raise PydanticCustomError(
                "level", f"a level from {low:g} to {high:g} N (N m for a moment): the "
                f"models are linear in it, and the H1 estimate's coherence (its fourth "
                f"power) must stay inside the float range")
        return v


class _IdentifyTable(_Strict):
    """``[identify]``: modal identification of every test (pLSCF over the test's band);
    the settings are :class:`~truthbench.identify.PLSCFIdentifier`'s."""

    enabled: bool = True
    """Identify the modes of every test (sensitivity localization, the uncertainty model
    and the pole plot need them)."""


IdentifySpec = settings_model("IdentifySpec", [PLSCFIdentifier], base=_IdentifyTable)


class _UpdateTable(_Strict):
    """``[update]``: which parameters are updated, how, against which lines. The settings
    of the updaters (:data:`truthbench.update.UPDATERS`) are declared once by their
    classes; a setting two updaters share (``max_iterations``, ``tolerance``, ...) goes to
    both."""

    method: str | list[str] = "finite_difference"
    """An updater name from :data:`truthbench.update.UPDATERS`, a list of them (run side
    by side; the first is the primary), or "none"."""
    parameters: list[str] = Field(default_factory=list)
    """The model parameters to update (plant parameters, ``<name>@<group>`` for one
    group, or appended dynamics such as ``delay_s``)."""
    band_hz: tuple[NonNegFloat, PositiveFloat] | None = None
    """The update uses the lines of every test inside this band (default: each test's
    excited band); it must lie inside the span of the tests' bands."""
    weighting: Literal["none", "coherence", "inverse_magnitude"] = "none"
    """Weight of every FRF value in the finite-difference cost: none, the inverse of the
    H1 standard deviation from the coherence, or the inverse magnitude (relative
    errors)."""

    @field_validator("band_hz")
    @classmethod
    def _band_ordered(cls, v):
        return None if v is None else _ordered_band(v)


UpdateSpec = settings_model("UpdateSpec", UPDATERS.values(), base=_UpdateTable)


class UncertaintySpec(_Strict):
    """The uncertainty model of the tests (Eq. 10.46-10.50) and its check against truth."""

    k_sigma: PositiveFloat = 3.0
    """Bound multiplier (Eq. 10.50 uses 3)."""
    band_hz: tuple[NonNegFloat, PositiveFloat] | None = None
    """The modes the bound covers; default the update band, else the tests' span."""
    holdout: list[str] = Field(default_factory=list)
    """Names of tests that do not build the bound; their true modal parameters are new
    draws against it (the calibration the Monte Carlo report scores)."""

    @field_validator("band_hz")
    @classmethod
    def _band_ordered(cls, v):
        return None if v is None else _ordered_band(v)


class OutputSpec(_Strict):
    """What the results file keeps."""

    time_histories: Literal["first_trial", "all", "none"] = "first_trial"
    """Recorded time histories (u, y) of every test: of trial 0 only, of every trial, or
    of none (FRFs, truth records and modes are always kept)."""
    frfs: Literal["all", "first_trial"] = "all"
    """The FRFs, coherence, model FRFs and FRF band of every trial, or of trial 0 only:
    the other trials keep their summary (every number the report tabulates), truth
    records, identified modes, updates and uncertainty stage, a few kB instead of about
    a MB per test (for campaigns of thousands of trials)."""


class StudySpec(_Strict):
    """``[diagnose.study]``: a Monte Carlo study of the diagnosis itself
    (``truthbench diagnose-study``). Each trial injects none, one or two effects drawn
    from ``inject`` at random strengths (log-uniform in ``strength``) and locations,
    simulates the campaign's tests, diagnoses them against the nominal model and scores
    the diagnosis against what was injected."""

    inject: Annotated[list[str], Field(min_length=1)] = Field(
        default_factory=lambda: ["time_delay", "channel_gain", "added_mass",
                                 "grounded_dashpot", "grounded_spring", "joint"])
    strength: dict[str, tuple[PositiveFloat, PositiveFloat]] = Field(default_factory=dict)
    """Effect name -> (low, high) of its first parameter (the effect's own unit, e.g.
    ``added_mass = [0.01, 0.1]`` kg); default ranges per effect otherwise."""
    clean_fraction: Annotated[float, Field(ge=0, le=1)] = 0.2
    two_fraction: Annotated[float, Field(ge=0, le=1)] = 0.2
    trials: Annotated[int, Field(ge=1)] = 20
    form: Literal["other", "same", "both"] = "both"
    """The truth's model form: "other" (a finer mesh, shear and rotary inertia drawn on
    or off, effects anywhere along the article, sensors and shakers mounted off the
    axis), "same" (the model's own plant, mesh and elements, effects on its nodes) or
    "both", scored side by side on the same draws."""


class ChannelPlace(_Strict):
    """``[diagnose.channels]`` entry: where and in which direction a channel of the data
    measures, for files that do not say (LabVIEW records)."""

    direction: Direction
    x_m: NonNegFloat | None = None
    """Position along the beam from its first end, m (or give ``station``)."""
    station: str | None = None
    sign: Literal[1, -1] | None = None
    """-1 where the channel measures along the negative direction (default: the file's)."""

    @model_validator(mode="after")
    def _one_place(self):
        if (self.x_m is None) == (self.station is None):
            raise ValueError("give exactly one of x_m and station")
        return self


class _DiagnoseTable(_Strict):
    """``[diagnose]``: how ``truthbench diagnose`` treats data against this model. Its
    settings are declared once by :class:`truthbench.diagnose.DiagnoseSettings`; the
    table's own keys place the data and state their input levels."""

    candidates: list[str] | None = None
    """Registry names of the effects to try as missing (default: every diagnosable one)."""
    map: dict[str, float] = Field(default_factory=dict)
    """Point number (as a string key) -> position along the beam, m, for data whose
    coordinates are not in the model's frame."""
    channels: dict[str, ChannelPlace] = Field(default_factory=dict)
    """Channel label -> ``{ direction, x_m or station, sign }``, for data that do not say
    where or in which direction a channel measures."""
    input_rms_n: dict[str, float | list[float]] = Field(default_factory=dict)
    """Data-set name -> the RMS of its input over the record, N (N m for a moment): one
    number for every input or a list, one per input. Coulomb friction is tried only when
    every test's level is known, which UFF FRF sets do not carry (time records and our
    HDF5 files do). A UFF load case is named by its sets' ID line 1 when they all carry
    the same one, else ``"<file stem> load case <n>"`` (n: record 6 field 4) when the
    file holds several load cases, else ``"<file stem>"``; an LVM record by its file
    stem; a test of our HDF5 files ``"trial <k> / <test>"``
    (:func:`truthbench.io.load_measurements`). Applied when the data are loaded, not by
    :meth:`settings`."""
    study: StudySpec = Field(default_factory=StudySpec)

    @field_validator("input_rms_n", mode="before")
    @classmethod
    def _levels(cls, v):
        if not isinstance(v, Mapping):
            return v  # the type check names it
        for name, level in v.items():
            values = level if isinstance(level, list) else [level]
            ok = [isinstance(x, Real) and not isinstance(x, bool) and math.isfinite(x)
                  and x > 0 for x in values]
            if not name.strip() or not values or not all(ok):
                raise PydanticCustomError(
                    "level", f"a data-set name -> a number > 0 (its input's RMS, N) or a "
                    f"non-empty list of them (one per input); {name!r} has {level!r}")
        return v

    def settings(self) -> dict[str, Any]:
        """Keyword arguments of :func:`truthbench.diagnose.diagnose`: the declared
        settings and the places (``input_rms_n`` is not one: it goes to
        :func:`truthbench.io.load_measurements`)."""
        return {**{k: getattr(self, k) for k in declared(DiagnoseSettings)},
                "candidates": None if self.candidates is None else tuple(self.candidates),
                "point_map": {int(k): v for k, v in self.map.items()},
                "channel_map": {k: v.model_dump(exclude_none=True)
                                for k, v in self.channels.items()}}


DiagnoseSpec = settings_model("DiagnoseSpec", [DiagnoseSettings], base=_DiagnoseTable)
