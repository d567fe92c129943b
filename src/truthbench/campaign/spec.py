"""Campaign files: parsing and validation into a frozen :class:`CampaignSpec`.

A campaign is a TOML file (reference: README, "Campaign file reference"). It is checked
once, here: the TOML syntax, then every key and type (pydantic models with
``extra="forbid"``), then the cross-references (stations the plant has, parameters it
accepts, update parameters against the data). Every problem is reported as a
:class:`~truthbench.errors.CampaignError` naming the file, the key path, what was
expected and what was received.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from truthbench.errors import CampaignError, ModelError

Direction = Literal["x", "y", "z", "rx", "ry", "rz"]
PositiveFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=False)


class SensorSpec(_Strict):
    """A sensor: station, direction and quantity."""

    station: str
    direction: Direction
    quantity: Literal["displacement", "velocity", "acceleration", "strain"] = "acceleration"


class ActuatorSpec(_Strict):
    """A force or moment input at a station."""

    station: str
    direction: Direction


class CampaignMeta(_Strict):
    name: str
    description: str = ""
    seed: Annotated[int, Field(ge=0)] = 0
    trials: Annotated[int, Field(ge=1)] = 1


class PlantSpec(_Strict):
    type: Literal["free_free_beam", "hub_beam"]
    n_elements: Annotated[int, Field(ge=1, le=2000)] = 20
    n_groups: Annotated[int, Field(ge=1)] = 1
    stations: dict[str, Annotated[float, Field(ge=0, le=1)]] = Field(default_factory=dict)
    parameters: dict[str, float] = Field(default_factory=dict)


class TruthSpec(_Strict):
    """The hardware's truth: offsets from the nominal model plus effects (Table 10.1)."""

    relative: dict[str, Annotated[float, Field(gt=-1)]] = Field(default_factory=dict)
    """Fractional offsets: ``E_pa = 0.03`` means truth E = 1.03 x nominal E."""
    effects: list[dict[str, Any]] = Field(default_factory=list)
    """``[[truth.effects]]`` tables, validated by :func:`truthbench.effects.parse_effect`."""


class TestSpec(_Strict):
    """One test of the test matrix."""

    __test__ = False  # not a pytest test class

    name: str
    actuators: Annotated[list[ActuatorSpec], Field(min_length=1)]
    sensors: list[SensorSpec] | None = None
    level_rms: PositiveFloat = 1.0
    band_hz: tuple[NonNegFloat, PositiveFloat]
    fs_hz: PositiveFloat
    record_s: PositiveFloat
    averages: Annotated[int, Field(ge=1)] = 10
    window: Literal["rectangular", "bartlett", "hann", "hamming"] = "bartlett"
    noise_fraction: NonNegFloat = 0.0
    oversample: Annotated[int, Field(ge=1, le=64)] = 8
    simulation: Literal["periodic", "time"] = "periodic"
    """"periodic": exact steady state of the periodic record, line by line (linear truth);
    "time": exact first-order-hold time stepping at ``oversample`` times the rate."""
    assembly: Annotated[int, Field(ge=0)] = 0
    """Which assembly of the hardware (reassembly-scope effects are redrawn per value)."""
    time_h: NonNegFloat = 0.0
    """Time of the test since the campaign began, hours (drift-scope effects)."""
    effects: list[dict[str, Any]] = Field(default_factory=list)
    """Effects of this test only (added mass, other boundary conditions, ...)."""

    @field_validator("band_hz")
    @classmethod
    def _band_ordered(cls, v):
        if not v[0] < v[1]:
            raise ValueError(f"band_hz must be [low, high] with low < high; got {list(v)}")
        return v


class IdentifySpec(_Strict):
    """Modal identification of every test (pLSCF over the test's band)."""

    enabled: bool = True
    max_order: Annotated[int, Field(ge=2, le=200)] = 40


class UpdateSpec(_Strict):
    method: str | list[str] = "finite_difference"
    """An updater name from :data:`truthbench.update.UPDATERS`, a list of them (run side
    by side; the first is the primary), or "none"."""
    parameters: list[str] = Field(default_factory=list)
    band_hz: tuple[NonNegFloat, PositiveFloat] | None = None
    weighting: Literal["none", "coherence", "inverse_magnitude"] = "none"
    max_iterations: Annotated[int, Field(ge=1)] = 30
    tolerance: PositiveFloat = 1e-7
    relative_step: Annotated[float, Field(gt=0, lt=0.1)] = 1e-4
    scheme: Literal["central", "forward"] = "central"
    c_zeta: NonNegFloat = 1.0
    """Sensitivity localization: weight of the damping-ratio rows (used when a damping
    parameter is updated; identified damping is less accurate than frequency)."""
    mac_min: Annotated[float, Field(ge=0, le=1)] = 0.8
    """Sensitivity localization: least MAC of a measured-model mode pair."""


class UncertaintySpec(_Strict):
    """The uncertainty model of the tests (Eq. 10.46-10.50) and its check against truth."""

    k_sigma: PositiveFloat = 3.0
    """Bound multiplier (Eq. 10.50 uses 3)."""
    band_hz: tuple[NonNegFloat, PositiveFloat] | None = None
    """The modes the bound covers; default the update band, else the tests' span."""
    holdout: list[str] = Field(default_factory=list)
    """Names of tests that do not build the bound; their true modal parameters are new
    draws against it (the calibration the Monte Carlo report scores)."""


class OutputSpec(_Strict):
    """What the results file keeps."""

    time_histories: Literal["first_trial", "all", "none"] = "first_trial"
    """Recorded time histories (u, y) of every test: of trial 0 only, of every trial, or
    of none (FRFs, truth records and modes are always kept)."""


class CampaignSpec(_Strict):
    """A validated campaign (frozen)."""

    campaign: CampaignMeta
    plant: PlantSpec
    sensors: Annotated[list[SensorSpec], Field(min_length=1)]
    truth: TruthSpec = Field(default_factory=TruthSpec)
    tests: Annotated[list[TestSpec], Field(min_length=1)]
    identify: IdentifySpec = Field(default_factory=IdentifySpec)
    update: UpdateSpec = Field(default_factory=UpdateSpec)
    uncertainty: UncertaintySpec = Field(default_factory=UncertaintySpec)
    output: OutputSpec = Field(default_factory=OutputSpec)
    source: str = "<memory>"

    def make_plant(self):
        """The plant builder of this campaign."""
        from truthbench.plants import make_plant

        return make_plant(self.plant.type, n_elements=self.plant.n_elements,
                          n_groups=self.plant.n_groups, stations=dict(self.plant.stations))

    def nominal_parameters(self) -> dict[str, float]:
        return self.make_plant().resolve(self.plant.parameters)

    def truth_parameters(self) -> dict[str, float]:
        """Nominal values times ``1 + offset`` for every truth offset."""
        nominal = self.nominal_parameters()
        out = dict(nominal)
        for key, frac in self.truth.relative.items():
            base = key.split("@")[0]
            out[key] = nominal.get(key, nominal[base]) * (1.0 + frac)
        return out

    def update_methods(self) -> list[str]:
        """The updaters to run, primary first (empty for "none")."""
        m = self.update.method
        methods = [m] if isinstance(m, str) else list(m)
        return [x for x in methods if x != "none"]

    def truth_effects(self) -> list:
        """The campaign's effects, validated (:class:`~truthbench.effects.EffectSpec`)."""
        from truthbench.effects import parse_effect

        return [parse_effect(e, f"truth.effects[{k}]", self.source)
                for k, e in enumerate(self.truth.effects)]

    def test_effects(self, j: int) -> list:
        """Test ``j``'s own effects, validated."""
        from truthbench.effects import parse_effect

        return [parse_effect(e, f"tests[{j}].effects[{k}]", self.source)
                for k, e in enumerate(self.tests[j].effects)]

    def test_sensors(self, i: int) -> list[SensorSpec]:
        return self.tests[i].sensors if self.tests[i].sensors is not None else self.sensors

    def test_io(self, j: int) -> tuple[tuple, tuple]:
        """Test ``j``'s actuators and sensors as the plant's
        :class:`~truthbench.plants.Actuator` and :class:`~truthbench.plants.Sensor`."""
        from truthbench.plants import Actuator, Sensor

        return (tuple(Actuator(a.station, a.direction) for a in self.tests[j].actuators),
                tuple(Sensor(s.station, s.direction, s.quantity)
                      for s in self.test_sensors(j)))

    def to_toml_dict(self) -> dict[str, Any]:
        return self.model_dump(mode="json", exclude={"source"}, exclude_none=True)


def _loc(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _format_validation_error(source: str, err: ValidationError) -> str:
    lines = [f"{source}: {err.error_count()} problem(s) in the campaign file:"]
    for e in err.errors():
        loc = _loc(tuple(p for p in e["loc"] if not (isinstance(p, str) and "[" in p)))
        received = e.get("input")
        if e["type"] == "extra_forbidden":
            lines.append(f"  - key '{loc}' is not a campaign key (unknown key); remove it or "
                         f"check its spelling")
        elif e["type"] == "missing":
            lines.append(f"  - key '{loc}' is required but missing")
        else:
            lines.append(f"  - key '{loc}': expected {e['msg'].lower()}; got {received!r}")
    return "\n".join(lines)


def parse_campaign(data: dict, source: str = "<memory>") -> CampaignSpec:
    """Validate a campaign given as a dict (the parsed TOML).

    Raises
    ------
    CampaignError
        Naming ``source``, the key path, what was expected and what was received.
    """
    try:
        spec = CampaignSpec.model_validate({**data, "source": source})
    except ValidationError as err:
        raise CampaignError(_format_validation_error(source, err)) from None
    _check_references(spec)
    return spec


def load_campaign(path: str | Path) -> CampaignSpec:
    """Read and validate a campaign TOML file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CampaignError(f"{path}: campaign file not found") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{path}: not valid TOML: {exc}") from None
    return parse_campaign(data, str(path))


def _check_references(spec: CampaignSpec) -> None:
    src = spec.source
    try:
        plant = spec.make_plant()
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant': {exc}") from None
    known = set(plant.parameter_names())

    def check_param(key: str, where: str):
        if key not in known:
            raise CampaignError(f"{src}: key '{where}': {spec.plant.type} has no parameter "
                                f"{key!r}; expected one of {', '.join(sorted(known))}")

    for key in spec.plant.parameters:
        check_param(key, f"plant.parameters.{key}")
    try:
        plant.resolve(spec.plant.parameters)
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant.parameters': {exc}") from None
    for key in spec.truth.relative:
        check_param(key, f"truth.relative.{key}")
    effects = spec.truth_effects()
    for j in range(len(spec.tests)):
        effects += spec.test_effects(j)
    for eff in effects:  # stations named in effect options must exist
        if "station" in eff.options:
            try:
                plant.station_node(eff.options["station"])
            except ModelError as exc:
                raise CampaignError(f"{src}: effect {eff.name!r}: {exc}") from None
    from truthbench.update import APPENDED_PARAMETERS, UPDATERS, make_updater

    for key in spec.update.parameters:
        if key not in APPENDED_PARAMETERS:
            check_param(key, "update.parameters")
    kinds = {k: ("appended" if k in APPENDED_PARAMETERS else "plant")
             for k in spec.update.parameters}
    for m in spec.update_methods():
        if m not in UPDATERS:
            raise CampaignError(f"{src}: key 'update.method': unknown updater {m!r}; expected "
                                f"one of {', '.join(sorted(UPDATERS))} or 'none'")
        try:
            updater = make_updater(m, spec.update.model_dump())
        except ValueError as exc:
            raise CampaignError(f"{src}: key 'update': {exc}") from None
        refused = updater.unsupported(kinds)
        if refused:
            reasons = "; ".join(f"{k}: {why}" for k, why in refused.items())
            raise CampaignError(f"{src}: key 'update.parameters': updater {m!r} cannot "
                                f"update {sorted(refused)} ({reasons}); update them with "
                                f"an FRF method such as 'finite_difference'")
        if "modes" in updater.needs and not spec.identify.enabled:
            raise CampaignError(f"{src}: key 'identify.enabled': updater {m!r} needs "
                                f"identified modes; expected true, got false")
    if spec.update_methods() and not spec.update.parameters:
        raise CampaignError(f"{src}: key 'update.parameters': expected at least one parameter "
                            f"for method {spec.update.method!r}; got an empty list")

    def check_station(station: str, where: str):
        try:
            plant.station_node(station)
        except ModelError as exc:
            raise CampaignError(f"{src}: key '{where}': {exc}") from None

    for i, s in enumerate(spec.sensors):
        check_station(s.station, f"sensors[{i}].station")
    names = [t.name for t in spec.tests]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise CampaignError(f"{src}: key 'tests': test names must be unique; "
                            f"got {sorted(dup)} more than once")
    unknown = [h for h in spec.uncertainty.holdout if h not in names]
    if unknown:
        raise CampaignError(f"{src}: key 'uncertainty.holdout': expected names of tests "
                            f"({names}); got unknown {unknown}")
    if spec.uncertainty.holdout and len(names) - len(set(spec.uncertainty.holdout)) < 2:
        raise CampaignError(f"{src}: key 'uncertainty.holdout': at least 2 tests must build "
                            f"the bound; {len(names)} tests with "
                            f"{len(set(spec.uncertainty.holdout))} held out leave fewer")
    for j, t in enumerate(spec.tests):
        for i, a in enumerate(t.actuators):
            check_station(a.station, f"tests[{j}].actuators[{i}].station")
        for i, s in enumerate(t.sensors or []):
            check_station(s.station, f"tests[{j}].sensors[{i}].station")
        nyquist = t.fs_hz / 2
        if t.band_hz[1] > nyquist:
            raise CampaignError(f"{src}: key 'tests[{j}].band_hz': expected an upper edge at or "
                                f"below the Nyquist frequency {nyquist} Hz; got {t.band_hz[1]}")
        n = int(round(t.record_s * t.fs_hz))
        if n // t.averages < 16:
            raise CampaignError(f"{src}: key 'tests[{j}].averages': {t.averages} averages of a "
                                f"{n}-sample record leave fewer than 16 samples per segment")
    # m r > p (METHOD 5.1): SISO pairs over all tests against updated parameters
    if any("frf" in UPDATERS[m].needs for m in spec.update_methods()):
        pairs = sum(len(t.actuators) * len(spec.test_sensors(j)) for j, t in
                    enumerate(spec.tests))
        p = len(spec.update.parameters)
        if pairs <= p:
            raise CampaignError(
                f"{src}: key 'update.parameters': the finite-difference method needs more "
                f"SISO transfer functions than parameters (m r > p); the tests give "
                f"m r = {pairs} for p = {p}. Add sensors or tests, or update fewer parameters.")
