"""Campaign files: parsing and validation into a frozen :class:`CampaignSpec`.

A campaign is a TOML file (reference: docs/reference/campaign_file.md). It is checked
once, here: the TOML syntax, then every key and type (the pydantic models of its tables,
:mod:`truthbench.campaign.spec_tables`, with ``extra="forbid"``), then the
cross-references (stations the plant has, parameters it accepts, update parameters
against the data). Every problem is reported as a
:class:`~truthbench.errors.CampaignError` naming the file, the key path, what was
expected and what was received.
"""

from __future__ import annotations

import functools
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, ValidationError

from truthbench._validation import read_text
from truthbench.campaign.spec_tables import (
    LEVEL_RMS_RANGE,  # noqa: F401 - the tests read it here
    MAX_ELEMENTS,
    CampaignMeta,
    DiagnoseSpec,
    IdentifySpec,
    OutputSpec,
    PlantSpec,
    SensorSpec,
    StationPosition,
    TestSpec,
    TruthSpec,
    UncertaintySpec,
    UpdateSpec,
    _base_plant,
    _Strict,
    position_station_name,
)
from truthbench.errors import CampaignError, ModelError
from truthbench.update import UPDATERS


@functools.lru_cache(maxsize=16)
def _plant(plant_json: str):
    """The plant builder of a ``[plant]`` table (given as its JSON)."""
    from truthbench.plants import make_plant

    plant = PlantSpec.model_validate_json(plant_json)
    return make_plant(plant.type, **plant.plant_options())


def max_noise_fraction(averages: int) -> float:
    """Largest ``noise_fraction`` of a test with ``averages`` segments: ``sqrt(2 n_d)``.

    Output noise of standard deviation ``r`` times the signal's gives the coherence
    ``1 / (1 + r^2)``, and the normalised random error of the H1 magnitude is
    ``sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d)) = r / sqrt(2 n_d)`` (Bendat and Piersol,
    Random Data: the random error of a gain-factor estimate); above ``r = sqrt(2 n_d)``
    it exceeds 100 %: the FRF holds no information.
    """
    return math.sqrt(2.0 * averages)


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
    diagnose: DiagnoseSpec = Field(default_factory=DiagnoseSpec)
    source: str = "<memory>"

    def make_plant(self):
        """The plant builder of this campaign (section, material, stations and suspension
        points as node fractions): one per plant table and process (plants are
        immutable)."""
        return _plant(self.plant.model_dump_json())

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
            msg = e["msg"][:1].lower() + e["msg"][1:]  # "Input should be" -> "input ..."
            lines.append(f"  - key '{loc}': expected {msg}; got {received!r}")
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
    spec = _place_by_position(spec)
    _check_references(spec)
    return spec


def load_campaign(path: str | Path) -> CampaignSpec:
    """Read and validate a campaign TOML file.

    Raises
    ------
    CampaignError
        A missing file, a directory, a binary file (an HDF5 results file given by
        mistake), bytes that are not UTF-8, TOML syntax, or any problem
        :func:`parse_campaign` finds; the message names the file.
    """
    path = Path(path)
    text = read_text(path, what="campaign file (TOML)", error=CampaignError)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise CampaignError(f"{path}: not valid TOML: {exc}") from None
    return parse_campaign(data, str(path))


def _place_by_position(spec: CampaignSpec) -> CampaignSpec:
    """Locate every position in metres on the nominal mesh and place the sensors and
    actuators given by ``x_m`` at generated stations (:func:`position_station_name`),
    which join ``[plant] stations`` as ``{ x_m = ... }``.

    Raises
    ------
    CampaignError
        Naming the file and the key of a position that is off the beam or not on a node
        (with the nearest node, the distance and element counts that would put a node
        there), ``suspension_x_m`` for a plant without suspension, or a generated station
        name that is already a station elsewhere.
    """
    src, plant = spec.source, spec.plant
    positions = [(f"plant.stations.{k}.x_m", v.x_m) for k, v in plant.stations.items()
                 if isinstance(v, StationPosition)]
    positions += [(f"plant.suspension_x_m[{i}]", x)
                  for i, x in enumerate(plant.suspension_x_m or ())]
    positions += [(f"sensors[{i}].x_m", s.x_m) for i, s in enumerate(spec.sensors)
                  if s.x_m is not None]
    for j, t in enumerate(spec.tests):
        positions += [(f"tests[{j}].sensors[{i}].x_m", s.x_m)
                      for i, s in enumerate(t.sensors or []) if s.x_m is not None]
        positions += [(f"tests[{j}].actuators[{i}].x_m", a.x_m)
                      for i, a in enumerate(t.actuators) if a.x_m is not None]
    if not positions:
        return spec
    try:
        base = _base_plant(plant)
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant': {exc}") from None
    known = set(base.parameter_names())
    for key in plant.parameters:  # as _check_references would report them
        if key not in known:
            raise CampaignError(f"{src}: key 'plant.parameters.{key}': "
                                f"{base._unknown_parameter(key, known)}; got {key!r}")
    try:
        base.resolve(plant.parameters)
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant.parameters': {exc}") from None
    if plant.suspension_x_m is not None and not hasattr(base, "suspension_nodes"):
        raise CampaignError(f"{src}: key 'plant.suspension_x_m': {plant.type} has no "
                            f"suspension; expected no suspension_x_m (it belongs to a "
                            f"free_free_beam), got {plant.suspension_x_m}")
    nodes = {}
    for key, x in positions:
        try:
            nodes[key] = base.node_at_m(x, plant.parameters,
                                        tolerance_m=plant.node_tolerance_m)
        except ModelError as exc:
            raise CampaignError(f"{src}: key '{key}': {exc}") from None

    stations = dict(plant.stations)

    def station_node(name):
        value = stations.get(name, base.default_stations.get(name))
        if isinstance(value, StationPosition):
            return nodes[f"plant.stations.{name}.x_m"]
        pos = value * plant.n_elements
        return round(pos) if abs(pos - round(pos)) <= 1e-9 else None

    def place(item, key):
        if item.x_m is None:
            return item
        name = position_station_name(item.x_m)
        if name in stations or name in base.default_stations:
            if station_node(name) != nodes[key]:
                raise CampaignError(
                    f"{src}: key '{key}': the position {item.x_m:g} m gets the station name "
                    f"{name!r}, which already names another point; expected no station "
                    f"called {name!r} in [plant] stations, got one")
        else:
            stations[name] = StationPosition(x_m=item.x_m)
        return item.model_copy(update={"station": name, "x_m": None})

    sensors = [place(s, f"sensors[{i}].x_m") for i, s in enumerate(spec.sensors)]
    tests = []
    for j, t in enumerate(spec.tests):
        update = {"actuators": [place(a, f"tests[{j}].actuators[{i}].x_m")
                                for i, a in enumerate(t.actuators)]}
        if t.sensors is not None:
            update["sensors"] = [place(s, f"tests[{j}].sensors[{i}].x_m")
                                 for i, s in enumerate(t.sensors)]
        tests.append(t.model_copy(update=update))
    return spec.model_copy(update={"plant": plant.model_copy(update={"stations": stations}),
                                   "sensors": sensors, "tests": tests})


def _check_geometry_effects(spec: CampaignSpec, plant) -> None:
    """A geometry effect may only change dimensions the plant's section has."""
    from truthbench.effects.structural import _DIMENSION_RELS
    from truthbench.fe.beam import SECTIONS

    dims = SECTIONS[plant.section].dimensions
    entries = [(f"truth.effects[{k}]", e) for k, e in enumerate(spec.truth_effects())]
    for j in range(len(spec.tests)):
        entries += [(f"tests[{j}].effects[{k}]", e) for k, e in enumerate(spec.test_effects(j))]
    for where, eff in entries:
        if eff.name != "geometry":
            continue
        for rel, dim in _DIMENSION_RELS:
            d = eff.distributions[rel]
            if dim not in dims and (d.mean != 0.0 or d.std != 0.0):
                raise CampaignError(
                    f"{spec.source}: key '{where}.parameters.{rel}': {rel!r} scales {dim!r}, "
                    f"which the {plant.section} section does not have; expected one of "
                    f"{', '.join(r for r, m in _DIMENSION_RELS if m in dims)} (or 'L_rel'), "
                    f"got {rel!r} with mean {d.mean:g} and std {d.std:g}")


def _check_references(spec: CampaignSpec) -> None:
    from truthbench.campaign.plan import CampaignPlan, record_samples
    from truthbench.campaign.resources import check_memory

    src = spec.source
    try:
        plant = spec.make_plant()
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant': {exc}") from None
    known = set(plant.parameter_names())

    def check_param(key: str, where: str):
        if key not in known:
            raise CampaignError(f"{src}: key '{where}': "
                                f"{plant._unknown_parameter(key, known)}; got {key!r}")

    for key in spec.plant.parameters:
        check_param(key, f"plant.parameters.{key}")
    try:
        plant.resolve(spec.plant.parameters)
    except ModelError as exc:
        raise CampaignError(f"{src}: key 'plant.parameters': {exc}") from None
    for key in spec.truth.relative:
        check_param(key, f"truth.relative.{key}")
    effects = [(f"truth.effects[{k}]", e) for k, e in enumerate(spec.truth_effects())]
    for j in range(len(spec.tests)):
        effects += [(f"tests[{j}].effects[{k}]", e) for k, e in enumerate(spec.test_effects(j))]
    for where, eff in effects:  # stations named in effect options must exist
        if "station" in eff.options:  # (on a node, unless the effect is a point attachment)
            locate = (plant.station_fraction if eff.effect.locates_between_nodes(eff.options)
                      else plant.station_node)
            try:
                locate(eff.options["station"])
            except ModelError as exc:
                raise CampaignError(f"{src}: key '{where}.station': effect {eff.name!r}: "
                                    f"{exc}; got {eff.options['station']!r}") from None
        if eff.name == "boundary" and eff.options["support"] != "all":
            from truthbench.effects.structural import support_node

            try:  # one suspension point: the plant must have it
                support_node(plant, eff.options["support"])
            except ModelError as exc:
                raise CampaignError(f"{src}: key '{where}.support': {exc}") from None
    _check_geometry_effects(spec, plant)
    check_refinement(spec, effects)
    from truthbench.update import APPENDED_PARAMETERS, make_updater

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
        limit = max_noise_fraction(t.averages)
        if t.noise_fraction > limit:
            raise CampaignError(
                f"{src}: key 'tests[{j}].noise_fraction': expected at most sqrt(2 averages) "
                f"= {limit:.4g} for {t.averages} averages (beyond it the random error of "
                f"|H1| exceeds 100 %: the FRF holds no information); got {t.noise_fraction!r}")
        n = record_samples(t)
        if n // t.averages < 16:
            raise CampaignError(f"{src}: key 'tests[{j}].averages': {t.averages} averages of a "
                                f"{n}-sample record leave fewer than 16 samples per segment")
    _check_channels(spec)
    _check_update_band(spec)
    plan = CampaignPlan.compile(spec)
    check_memory(plan)  # first: the lines of a record that cannot fit are not listed
    _check_update_lines(plan)
    # m r > p (Eq. 10.21): SISO pairs over all tests against updated parameters
    if any("frf" in UPDATERS[m].needs for m in spec.update_methods()):
        pairs = plan.n_pairs
        p = len(spec.update.parameters)
        if pairs <= p:
            raise CampaignError(
                f"{src}: key 'update.parameters': the finite-difference method needs more "
                f"SISO transfer functions than parameters (m r > p); the tests give "
                f"m r = {pairs} for p = {p}. Add sensors or tests, or update fewer parameters.")


def check_refinement(spec: CampaignSpec, effects, source: str | None = None) -> None:
    """A ``discretization`` effect meshes the truth ``refine`` times finer: an integer
    >= 1 whose mesh stays within :data:`MAX_ELEMENTS` (the truth's eigen solve is the
    model's, refined).

    Parameters
    ----------
    spec : CampaignSpec
    effects : iterable of (str, EffectSpec)
        Where each effect was given (a key, or ``--inject ...``) and the effect.
    source : str, optional
        The file or option named first in messages (default ``spec.source``).
    """
    src = spec.source if source is None else source
    n = spec.plant.n_elements
    for where, eff in effects:
        if eff.name != "discretization":
            continue
        k = eff.options.get("refine")
        if isinstance(k, bool) or not isinstance(k, int | float) or k != int(k) or k < 1:
            raise CampaignError(f"{src}: key '{where}.refine': expected an integer >= 1 "
                                f"(the truth's elements per model element); got {k!r}")
        k = int(k)
        if n * k > MAX_ELEMENTS:
            raise CampaignError(
                f"{src}: key '{where}.refine': the truth would have {n} x {k} = "
                f"{n * k} elements; expected at most {MAX_ELEMENTS} (what the eigensolver "
                f"handles in about a second), so refine at most {MAX_ELEMENTS // n}")


def _check_channels(spec: CampaignSpec) -> None:
    """No sensor or actuator twice in one list (same station, direction and quantity):
    a repeated channel makes the FRF matrix and the update rank-deficient."""
    src = spec.source

    def once(items, key, fields):
        seen = {}
        for i, item in enumerate(items):
            ident = tuple(getattr(item, f) for f in fields)
            if ident in seen:
                raise CampaignError(
                    f"{src}: key '{key}[{i}]': the same channel as {key}[{seen[ident]}] "
                    f"({', '.join(f'{f} {v!r}' for f, v in zip(fields, ident, strict=True))}); "
                    f"expected each {key.rsplit('.', 1)[-1][:-1]} once")
            seen[ident] = i

    once(spec.sensors, "sensors", ("station", "direction", "quantity"))
    for j, t in enumerate(spec.tests):
        once(t.actuators, f"tests[{j}].actuators", ("station", "direction"))
        if t.sensors is not None:
            once(t.sensors, f"tests[{j}].sensors", ("station", "direction", "quantity"))


def _check_update_band(spec: CampaignSpec) -> None:
    """``[update] band_hz`` lies inside the span of the tests' excited bands: beyond it no
    test has data, and the band also bounds the modes scored and the uncertainty model
    (which would otherwise be clipped, or look for modes nothing excited)."""
    if spec.update.band_hz is None:
        return
    lo = min(t.band_hz[0] for t in spec.tests)
    hi = max(t.band_hz[1] for t in spec.tests)
    ulo, uhi = spec.update.band_hz
    if ulo < lo or uhi > hi:
        side = " and ".join(w for w, out in (("below", ulo < lo), ("above", uhi > hi)) if out)
        raise CampaignError(
            f"{spec.source}: key 'update.band_hz': expected a band inside the tests' "
            f"excited band {lo:g}-{hi:g} Hz (the span of every [[tests]] band_hz: the "
            f"update has data only there); got {ulo:g}-{uhi:g} Hz, which reaches {side} "
            f"it")


def _check_update_lines(plan) -> None:
    """Every test has frequency lines inside the update band (a test without lines there
    cannot be updated against; :meth:`~truthbench.campaign.plan.TestPlan.update_lines`)."""
    spec = plan.spec
    if not plan.methods or spec.update.band_hz is None:
        return
    empty = [f"{t.name!r} (band {t.band_hz[0]:g}-{t.band_hz[1]:g} Hz)" for t in plan.tests
             if not t.update_lines().any()]
    if empty:
        ulo, uhi = spec.update.band_hz
        raise CampaignError(
            f"{spec.source}: key 'update.band_hz': expected a band that overlaps every "
            f"test's excited band with at least one frequency line; got "
            f"{ulo:g}-{uhi:g} Hz, which holds no line of {', '.join(empty)}")
