"""FRF prediction for updating: a model builder, channels and lines, appended dynamics.

An :class:`FRFPredictor` turns a parameter set ``theta`` into model FRFs at the measured
lines of each test: it realises the plant at ``theta``'s plant parameters with the
declared effects at ``theta``'s effect parameters (:class:`EffectTerm`), instruments it
with every test's actuators and sensors, and multiplies in the appended dynamics
(:data:`APPENDED_PARAMETERS`). It declares the parameters it can vary and of which kind
each is, so updaters can say which they support.

Parameter names:

``E_pa``, ``rho_kg_m3@g2``, ...
    plant parameters (kind ``"plant"``);
``delay_s``, ``sensor_gain``
    appended dynamics (kind ``"appended"``): every model FRF is multiplied by
    ``sensor_gain exp(-j omega delay_s)``, what the ``time_delay`` and ``sensor_bias``
    (gain) effects do to data;
``<label>.<parameter>``
    a parameter of an effect term (kind ``"effect"``), e.g.
    ``joint@mid.stiffness_loss``.

One structural solution per parameter set serves every test: the model carries the
union of the tests' channels and each test takes its rows and columns (unless an effect
depends on the test's own channels, e.g. sensor mass or a closed loop: then each test is
realised on its own).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from truthbench._validation import readonly
from truthbench.effects.base import EffectSpec, mean_values
from truthbench.effects.hardware import Hardware
from truthbench.effects.setup import SetupBuilder
from truthbench.errors import ModelError
from truthbench.measure.leakage import LeakageKernel, expected_h1
from truthbench.plants.base import Actuator, Plant, Sensor

APPENDED_PARAMETERS = {"delay_s": 0.0, "sensor_gain": 1.0}
"""Update parameters of the measurement chain, not of the plant, with their nominal
values."""

KINDS = ("plant", "appended", "effect")

HARDWARE_CACHE_SIZE = 4
"""Hardware objects (models with their modes) an :class:`FRFPredictor` keeps, by
parameter values."""


@dataclass(frozen=True)
class PredictedTest:
    """The lines and channels of one test to predict, and how its data were estimated.

    Parameters
    ----------
    name : str
    freq_hz : array_like, shape (n_lines,)
        Hz.
    actuators : sequence of Actuator
    sensors : sequence of Sensor
    decay_rad_s : float
        An exponential window's decay rate (impact data): the model is evaluated at
        ``s = decay_rad_s + j omega``, exactly what the window does to the FRF (1/s).
    kernel : LeakageKernel, optional
        The averaged estimate's smoothing (:mod:`truthbench.measure.leakage`), used by
        ``predict(..., estimator=True)``.
    band_hz : (float, float), optional
        The excitation's band (lines of the kernel outside it carry no input).
    """

    name: str
    freq_hz: np.ndarray
    actuators: tuple[Actuator, ...]
    sensors: tuple[Sensor, ...]
    decay_rad_s: float = 0.0
    kernel: LeakageKernel | None = None
    band_hz: tuple[float, float] | None = None

    def __post_init__(self):
        object.__setattr__(self, "freq_hz", readonly(self.freq_hz, float))
        object.__setattr__(self, "actuators", tuple(self.actuators))
        object.__setattr__(self, "sensors", tuple(self.sensors))
        if self.freq_hz.ndim != 1:
            raise ValueError(f"test {self.name!r}: freq_hz must be 1-D; got shape "
                             f"{self.freq_hz.shape}")

    @property
    def n_pairs(self) -> int:
        """SISO transfer functions of the test (m r)."""
        return len(self.actuators) * len(self.sensors)


@dataclass(frozen=True)
class EffectTerm:
    """An effect in the model whose parameters an update may vary.

    ``theta`` carries the fitted parameters as ``f"{label}.{name}"``; absent ones stay at
    ``start`` (default the effect's means). By default the fitted parameters are the
    effect's own; ``free`` and ``to_values`` give another parameterisation (e.g. a
    low-pass fitted by its time constant, which starts at 0, and turned into the
    effect's bandwidth).

    Parameters
    ----------
    label : str
        Unique among the predictor's effects.
    spec : EffectSpec
        The effect and its options (a station, a direction).
    free : tuple of str, optional
        Fitted parameter names (default: the effect's parameters).
    to_values : callable, optional
        ``to_values(fitted) -> effect parameter values`` (default: the identity).
    start : mapping, optional
        Starting values of the fitted parameters.
    tests : tuple of str, optional
        The tests (by name) the effect acts in (default all): a model form that differs
        by test, e.g. friction linearised at each test's level.
    share : str, optional
        The prefix of the fitted parameters' keys (default ``label``): terms with the
        same ``share`` fit the same parameters (one friction force for every test).
    """

    label: str
    spec: EffectSpec
    free: tuple[str, ...] | None = None
    to_values: Callable[[Mapping[str, float]], Mapping[str, float]] | None = None
    start: Mapping[str, float] | None = None
    tests: tuple[str, ...] | None = None
    share: str | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The fitted parameters' own names (without the label)."""
        return tuple(self.free) if self.free is not None else tuple(
            p.name for p in self.spec.effect.params)

    @property
    def prefix(self) -> str:
        return self.share if self.share is not None else self.label

    def keys(self) -> tuple[str, ...]:
        return tuple(f"{self.prefix}.{n}" for n in self.names)

    def acts_in(self, test: str) -> bool:
        return self.tests is None or test in self.tests

    def initial(self) -> dict[str, float]:
        """Starting fitted values, by own name."""
        means = mean_values(self.spec)
        start = dict(self.start or {})
        return {n: float(start.get(n, means.get(n, 0.0))) for n in self.names}

    def fitted(self, theta: Mapping[str, float]) -> dict[str, float]:
        """The fitted parameters in ``theta`` (``initial`` where absent), by own name."""
        return {n: float(theta.get(f"{self.prefix}.{n}", v))
                for n, v in self.initial().items()}

    def values(self, theta: Mapping[str, float]) -> dict[str, float]:
        """The effect's parameter values at ``theta``."""
        fitted = self.fitted(theta)
        values = mean_values(self.spec)
        values.update(self.to_values(fitted) if self.to_values is not None else fitted)
        return values


@dataclass(frozen=True)
class FRFPredictor:
    """Model FRFs at the measured lines of each test, as a function of ``theta``.

    Parameters
    ----------
    plant : Plant
        The model's plant builder.
    nominal : mapping
        Nominal plant parameters (the defaults of anything ``theta`` leaves out).
    tests : sequence of PredictedTest
    effects : sequence of EffectTerm, optional
        Effects in the model (a joint, a grounded dashpot, ...), in order.
    mode_tolerance : float, optional
        Leave out modes the channels barely see (:func:`truthbench.model.frf`): a
        speed-up for channels in one plane, at a cost of at most about the number of
        modes times this fraction of the largest resonance peak. 0 keeps every mode.
    reduced : bool, optional
        Solve only what the channels' FRFs need (:class:`Hardware
        <truthbench.effects.hardware.Hardware>` ``reduced``): the same FRFs to round-off,
        several times faster for a beam measured in one plane. With ``mode_tolerance``
        0 the analytic :meth:`jacobian` works on those blocks too.
    """

    plant: Plant
    nominal: Mapping[str, float]
    tests: tuple[PredictedTest, ...]
    effects: tuple[EffectTerm, ...] = field(default_factory=tuple)
    mode_tolerance: float = 0.0
    reduced: bool = False

    def __post_init__(self):
        object.__setattr__(self, "nominal", dict(self.plant.resolve(self.nominal)))
        object.__setattr__(self, "tests", tuple(self.tests))
        object.__setattr__(self, "effects", tuple(self.effects))
        if not self.tests:
            raise ValueError("FRFPredictor needs at least one test")
        labels = [t.label for t in self.effects]
        if len(set(labels)) != len(labels):
            raise ValueError(f"effect labels must be unique; got {labels}")
        acts = list(dict.fromkeys(a for t in self.tests for a in t.actuators))
        sens = list(dict.fromkeys(s for t in self.tests for s in t.sensors))
        object.__setattr__(self, "_actuators", tuple(acts))
        object.__setattr__(self, "_sensors", tuple(sens))
        object.__setattr__(self, "_per_test", any(
            t.spec.effect.per_test_channels or t.tests is not None for t in self.effects))
        object.__setattr__(self, "_hardware_cache", {})
        object.__setattr__(self, "_macro_cache", {})

    # ---- what it can vary ---------------------------------------------------------
    @property
    def kinds(self) -> dict[str, str]:
        """Every parameter the predictor can vary, with its kind (:data:`KINDS`)."""
        out = dict.fromkeys(self.plant.parameter_names(), "plant")
        out.update(dict.fromkeys(APPENDED_PARAMETERS, "appended"))
        for term in self.effects:
            out.update(dict.fromkeys(term.keys(), "effect"))
        return out

    @property
    def parameters(self) -> tuple[str, ...]:
        return tuple(self.kinds)

    @property
    def theta0(self) -> dict[str, float]:
        """Nominal values of every parameter: plant, appended, effects at their means."""
        out = dict(self.nominal)
        out.update(APPENDED_PARAMETERS)
        for term in self.effects:
            out.update({f"{term.prefix}.{k}": v for k, v in term.initial().items()})
        return out

    @property
    def n_pairs(self) -> int:
        """SISO transfer functions over all tests (m r, summed)."""
        return sum(t.n_pairs for t in self.tests)

    @property
    def f_max_hz(self) -> float:
        """Highest predicted line, Hz."""
        return max(float(t.freq_hz.max()) for t in self.tests if t.freq_hz.size)

    def additive_scales(self, names: Sequence[str]) -> dict[str, float]:
        """Parameters among ``names`` that start at 0 and are updated additively, with
        their scale: the delay, one radian of phase at the highest line."""
        return ({"delay_s": 1.0 / (2 * np.pi * self.f_max_hz)} if "delay_s" in names
                else {})

    def check(self, names: Sequence[str]) -> None:
        """Raise :class:`~truthbench.errors.ModelError` for names it cannot vary."""
        known = self.kinds
        bad = [n for n in names if n not in known]
        if bad:
            effects = [k for k, v in known.items() if v == "effect"] or "no effect parameters"
            raise ModelError(f"the FRF predictor cannot vary {bad}; it knows the plant "
                             f"parameters, {', '.join(APPENDED_PARAMETERS)} and {effects}")

    # ---- predictions --------------------------------------------------------------
    def plant_parameters(self, theta: Mapping[str, float]) -> dict[str, float]:
        """The plant parameters of ``theta`` (nominal where it leaves them out)."""
        names = set(self.plant.parameter_names())
        return {**self.nominal, **{k: v for k, v in theta.items() if k in names}}

    def hardware(self, theta: Mapping[str, float], actuators: Sequence[Actuator] | None = None,
                 sensors: Sequence[Sensor] | None = None, *, test: str | None = None
                 ) -> Hardware:
        """The model at ``theta`` as hardware, instrumented with ``actuators`` and
        ``sensors`` (default: the union of the tests'), with the effects that act in
        ``test`` (default: those that act in every test).

        The last :data:`HARDWARE_CACHE_SIZE` hardware objects are kept, keyed on the
        parameter values, channels and test, so that a prediction and a Jacobian at the
        same ``theta`` build the model and solve its modes once (a :class:`Hardware`
        caches its model and modes)."""
        try:
            key = (tuple(sorted((k, float(v)) for k, v in self.plant_parameters(theta).items())),
                   tuple(tuple(sorted(t.fitted(theta).items())) for t in self.effects),
                   float(theta.get("delay_s", 0.0)), float(theta.get("sensor_gain", 1.0)),
                   None if actuators is None else tuple(actuators),
                   None if sensors is None else tuple(sensors), test)
            hash(key)
        except (TypeError, ValueError):
            return self._hardware(theta, actuators, sensors, test)
        cache = self._hardware_cache
        if key in cache:
            cache[key] = cache.pop(key)  # most recently used last
            return cache[key]
        hw = self._hardware(theta, actuators, sensors, test)
        cache[key] = hw
        while len(cache) > HARDWARE_CACHE_SIZE:
            cache.pop(next(iter(cache)))
        return hw

    def _hardware(self, theta, actuators, sensors, test) -> Hardware:
        builder = SetupBuilder(
            plant=self.plant, parameters=self.plant.resolve(self.plant_parameters(theta)),
            actuators=self._actuators if actuators is None else tuple(actuators),
            sensors=self._sensors if sensors is None else tuple(sensors))
        for term in self.effects:
            if (term.tests is None) if test is None else term.acts_in(test):
                builder.add(term.spec, term.values(theta), term.label)
        builder.delay_s += float(theta.get("delay_s", 0.0))
        builder.bias_gain *= float(theta.get("sensor_gain", 1.0))
        hw = builder.freeze()
        return replace(hw, reduced=True) if self.reduced else hw

    def predict(self, theta: Mapping[str, float], *, estimator: bool = False
                ) -> tuple[np.ndarray, ...]:
        """Model FRFs of every test at its lines.

        Parameters
        ----------
        theta : mapping
            Parameter values (nominal where absent).
        estimator : bool
            Predict what each test's averaged estimate measures (its
            :class:`~truthbench.measure.leakage.LeakageKernel` applied to the model),
            for tests that declare a kernel; else the exact FRF.

        Returns
        -------
        tuple of ndarray, complex, shape (n_lines_j, n_out_j, n_in_j)
        """
        hw = None if self._per_test else self.hardware(theta)
        shared: dict = {}  # one structural solution per distinct line set and decay
        out = []
        for t in self.tests:
            if self._per_test:
                one = self.hardware(theta, t.actuators, t.sensors, test=t.name)

                def frf(f, one=one, t=t):
                    return one.frf(f, decay_rad_s=t.decay_rad_s,
                                   mode_tolerance=self.mode_tolerance)
            else:
                rows = [self._sensors.index(s) for s in t.sensors]
                cols = [self._actuators.index(a) for a in t.actuators]

                def frf(f, rows=rows, cols=cols, t=t):
                    return hw.frf(f, decay_rad_s=t.decay_rad_s,
                                  mode_tolerance=self.mode_tolerance)[:, rows][:, :, cols]
            if estimator and t.kernel is not None:
                out.append(expected_h1(t.freq_hz, frf, t.kernel, t.band_hz))
            elif self._per_test:
                out.append(frf(t.freq_hz))
            else:
                key = (t.decay_rad_s, t.freq_hz.size, t.freq_hz.tobytes())
                if key not in shared:
                    shared[key] = hw.frf(t.freq_hz, decay_rad_s=t.decay_rad_s,
                                         mode_tolerance=self.mode_tolerance)
                out.append(shared[key][:, rows][:, :, cols])
        return tuple(out)

    # ---- derivatives --------------------------------------------------------------
    def jacobian(self, theta: Mapping[str, float], names: Sequence[str], *,
                 additive: Mapping[str, float] | None = None) -> np.ndarray | None:
        """Analytic ``d predict_vector / dp`` for relative changes of ``names`` (per unit
        scale of the ``additive`` ones): the matrix that
        :func:`~truthbench.update.finite_difference.sensitivity_matrix` approximates by
        finite differences (:mod:`truthbench.update.jacobian`).

        Returns
        -------
        ndarray, complex, shape (N, p), or None
            None when the analytic form does not cover the case (effect parameters,
            closed loops, per-test instrumentation effects, ...): use finite differences.
        """
        from truthbench.update.jacobian import JacobianUnavailable, frf_jacobian

        names = tuple(names)
        plant = tuple(n for n in names if self.kinds.get(n) == "plant")
        cache = self._macro_cache.get(plant)
        if cache is None and plant:
            from truthbench.update.jacobian import MacroelementCache

            cache = MacroelementCache(_ModelAt(self), plant, reference=self.nominal)
            self._macro_cache.clear()
            self._macro_cache[plant] = cache
        try:
            return frf_jacobian(self, theta, names, additive=additive, cache=cache)
        except JacobianUnavailable as exc:
            import logging

            logging.getLogger(__name__).debug("analytic FRF Jacobian unavailable: %s", exc)
            return None

    def with_tests(self, tests: Sequence[PredictedTest]) -> FRFPredictor:
        """The same model at other lines (``tests`` with the same channels), sharing this
        predictor's cache of models and modes."""
        other = FRFPredictor(self.plant, self.nominal, tests, self.effects,
                             self.mode_tolerance, self.reduced)
        if (other._actuators, other._sensors) == (self._actuators, self._sensors):
            object.__setattr__(other, "_hardware_cache", self._hardware_cache)
        return other

    def vector_function(self) -> PredictVector:
        """:meth:`predict_vector` as a callable that also offers :meth:`jacobian` (what
        :func:`~truthbench.update.finite_difference.finite_difference_update` looks for)."""
        return PredictVector(self)

    def predict_vector(self, theta: Mapping[str, float], *, estimator: bool = False
                       ) -> np.ndarray:
        """:meth:`predict` of every test, raveled and concatenated (complex, 1-D)."""
        return np.concatenate([h.ravel() for h in self.predict(theta, estimator=estimator)])


class _ModelAt:
    """``predictor.hardware(theta).model``, with a ``content_key`` (what the model depends
    on besides ``theta``: the plant, the nominal values, the channels) when the predictor
    has no effect terms, so that macroelements taken at one ``theta`` serve every
    predictor of the same model in the process
    (:class:`~truthbench.update.jacobian.MacroelementCache`)."""

    def __init__(self, predictor: FRFPredictor):
        self.predictor = predictor
        p = predictor
        self.content_key = None if p.effects else (
            "FRFPredictor", repr(p.plant), tuple(sorted(p.nominal.items())),
            p._actuators, p._sensors, p.reduced, p.mode_tolerance)

    def __call__(self, theta: Mapping[str, float]):
        return self.predictor.hardware(theta).model


@dataclass(frozen=True)
class PredictVector:
    """``predict(theta) -> G`` (:meth:`FRFPredictor.predict_vector`) with the analytic
    Jacobian ``jacobian(theta, names, additive=...)`` (:meth:`FRFPredictor.jacobian`,
    None where it does not apply)."""

    predictor: FRFPredictor

    def __call__(self, theta: Mapping[str, float]) -> np.ndarray:
        return self.predictor.predict_vector(theta)

    def jacobian(self, theta: Mapping[str, float], names: Sequence[str], *,
                 additive: Mapping[str, float] | None = None) -> np.ndarray | None:
        return self.predictor.jacobian(theta, names, additive=additive)
