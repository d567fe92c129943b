"""Diagnosis: from measured FRFs and a model to the effects the model lacks.

1. **Baseline.** The channels are placed on the model (:func:`~.data.prepare`) and the
   parameters the user declared (``[update] parameters``) are fitted: the best the model
   can do as declared.
2. **Adequacy** (:mod:`.adequacy`). Before any effect is tried: is the mesh fine enough
   for these data (else it is refined, or said to be too coarse), and does the data show
   a mode the model cannot show at these channels (named, and its lines left out)?
   With ``mounting``, the channels' reading of the beam's torsion and roll through
   their offsets from the axis is modelled in from the start
   (:mod:`truthbench.diagnose.mounting`).
3. **Candidates.** Every effect of the registry that declares a diagnosis form, at every
   location it can have (:mod:`.candidates`), is screened against the current fit
   (:func:`~.search.screen`); the best, and the best location of every other effect
   screened within a factor of the best, are refitted (quick) with the declared
   parameters and the effects already found; the best few refits are completed, each
   compared through the estimator at its own model.
4. **Selection** (stepwise, with backward elimination). Each refit is scored by the
   Bayesian information criterion with the noise scale profiled out (the weights
   ``1 / sigma`` fix the relative noise of every value, the common scale is estimated),

       delta_BIC = n ln(chi2_current / chi2_candidate) - k ln(n),

   n the independent real data values (the real values over the estimate's correlated
   lines per value, 1.8 for a Bartlett window) and k the candidate's parameters. The
   best candidate with a physical fit (inside its bounds, up to a slack) and ``delta_BIC
   > threshold + 2 ln M`` (M the candidates tried: the best of M noise-only drops is
   about 2 ln M) is added; a point attachment's position is then searched between the
   nodes next to it. After each addition every earlier effect is tested again (the
   model refitted without it) and dropped when it is no longer significant: a first
   finding that a later one explains better (a joint standing in for a mass between two
   nodes) does not stay. The search repeats until nothing is added or ``max_effects``
   are in the model. Data at the noise level find nothing: no effect is sought once the
   residual's variance is within ``noise_margin`` (10 %) of the noise's (the accuracy
   of the noise model itself: weights from the coherence of a few averages), and an
   effect must explain at least ``excess_share`` (a quarter) of the residual's excess
   over the noise. BIC assumes the model family contains the truth; where it does not
   (a sensor off the beam's axis, a mesh's last digits), a flexible candidate can absorb
   a sliver of a large residual with a high delta BIC, and that sliver is not a finding.
5. **Verdict** (:mod:`.verdict`). When the runner-up of a step explains the data within
   ``ambiguity_margin`` of delta BIC, the finding is "A or B" with both fits, and the
   sensor and excitation point that would tell them apart are named.
6. **After.** The residual views of the final model; the found effects with their
   fitted values and standard deviations (column-scaled Jacobian, noise scale from the
   residual, correlated lines counted), stated only when the final residual is at the
   noise level (:attr:`Diagnosis.uncertainty_holds`).
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import threadpool_limits

from truthbench.diagnose import adequacy
from truthbench.diagnose.candidates import (
    Candidate,
    at_fraction,
    bind_levels,
    catalogue,
    not_tried,
    references,
    with_node_stations,
)
from truthbench.diagnose.data import MeasuredTest, prepare
from truthbench.diagnose.fit import (
    ExtraModes,
    Fit,
    Problem,
    evaluate,
    fit,
    fit_magnitude,
    refit_error,
    residual_lines,
    with_mounting,
    with_offsets,
)
from truthbench.diagnose.mounting import mounting_check
from truthbench.diagnose.place import _Placement
from truthbench.diagnose.residual import ModeResidual, Residual, mpc, residual_views
from truthbench.diagnose.screen import POINT_EFFECTS
from truthbench.diagnose.search import (
    PHASE_EFFECTS,
    REFIT_ERRORS,
    Refit,
    Tried,
    accepted_lag,
    adapted,
    bounds_ok,
    crossed,
    data_delay,
    delay_drop,
    delta_bic,
    fitted_own,
    full_refit,
    partly_crossed,
    refit,
    screen,
    shortlist,
    signature_start,
    terms_of,
)
from truthbench.diagnose.settings import DiagnoseSettings
from truthbench.diagnose.verdict import (
    FAR_POLE,
    NESTED,
    Alternative,
    Measurement,
    ambiguous,
    far_pole_hz,
    measurements,
    parsimonious,
    ranked,
)
from truthbench.effects import EFFECTS
from truthbench.errors import IdentifiabilityError, ModelError
from truthbench.measure.frfdata import FRFData
from truthbench.measure.leakage import Estimator
from truthbench.plants.base import Plant
from truthbench.update.predictor import APPENDED_PARAMETERS, PredictedTest

MODEL_FORM = {"element_physics": {"scale": 1.0}}
"""Candidates that change the model's form everywhere (the element's shear and rotary
inertia), tried beside the best local finalists from their physical value
(:meth:`_Diagnosis.with_form`)."""

TWIN_ELEMENTS = 2
"""A second attachment (or joint) of a found one's kind within this many elements of it
is first tried as the found one moved (:meth:`_Diagnosis.twin`): the position searches
reach an element either side of where a candidate screened."""

REPLACE_ROUNDS = 3
"""Rounds of placing every found attachment and joint anew with the others in, at the
end of the search (:meth:`_Diagnosis.replace_all`), each followed by backward
elimination, until nothing moves: a place moves by at most :data:`TWIN_ELEMENTS`
elements a round."""


@dataclass(frozen=True)
class Found:
    """An effect the diagnosis added and kept.

    Attributes
    ----------
    effect : str
        Registry name.
    options : dict
        Its location (station, direction, sensor).
    parameters : dict
        The effect's own parameter values at the final fit.
    fitted : dict
        The fitted parameters (own names) at the final fit.
    std : dict
        Their standard deviations (NaN where a combination is not determined).
    delta_bic : float
        The evidence for it in the final model: the model refitted without it against
        the final model.
    node : int or None
        The model node nearest to it (located effects).
    label : str
    x_m : float or None
        Its position along the beam, m (located effects; between nodes for a point
        attachment whose position was searched).
    alternatives : tuple of Alternative
        Effects that explained the data within the ambiguity margin when it was found:
        the verdict is then "this or those".
    """

    effect: str
    options: dict
    parameters: dict
    fitted: dict
    std: dict
    delta_bic: float
    node: int | None
    label: str
    x_m: float | None = None
    alternatives: tuple[Alternative, ...] = ()

    @property
    def ambiguous(self) -> bool:
        return bool(self.alternatives)


def _kernel(frf: FRFData, settings: DiagnoseSettings):
    """The leakage kernel of a data set's estimator: its own (our files), or the one the
    settings state for data from other tools (``window``, segment = 1 / line spacing,
    ``fs_hz`` default twice the highest line; a random input: the continuum), or None."""
    if not settings.estimator:
        return None
    if frf.estimator is not None:
        return frf.estimator.kernel()
    if settings.window is None or frf.freq_hz.size < 2:
        return None
    df = float(np.median(np.diff(frf.freq_hz)))
    fs = settings.fs_hz or 2.0 * float(frf.freq_hz.max())
    return Estimator(settings.window, int(round(fs / df)), fs).kernel()


def _parts(tests: Sequence[MeasuredTest], vector: np.ndarray) -> list[np.ndarray]:
    out, k = [], 0
    for t in tests:
        n = t.H.size
        out.append(vector[k:k + n].reshape(t.H.shape))
        k += n
    return out


def _modes(tests, problem: Problem, fit_: Fit, data_modes) -> tuple[ModeResidual, ...]:
    """Identified data modes paired with the model's at the measured outputs."""
    from truthbench.identify import ModalParameters, pair_modes
    from truthbench.model import modal_table

    out = []
    for t, ident in zip(tests, data_modes, strict=True):
        if ident is None or ident.n_modes == 0:
            continue
        hw = problem.predictor(fit_.terms).hardware(fit_.theta, t.actuators, t.sensors,
                                                    test=t.name)
        model, modes = hw.model, hw.modes
        rows = modal_table(model, modes)
        f = np.array([r["freq_hz"] for r in rows])
        z = np.nan_to_num(np.array([r["damping_ratio"] for r in rows]))
        measured = model.C_out @ modes.shapes
        seen = np.linalg.norm(measured, axis=0)
        # modes the measured DOFs do not see (torsion of a beam measured in bending)
        # cannot be paired with a measured mode
        keep = ~modes.rigid & (f >= t.freq_hz.min()) & (f <= t.freq_hz.max()) & \
            (seen > 1e-6 * max(float(seen.max()), 1e-300))
        mm = ModalParameters(f[keep], z[keep], measured[:, keep])
        dm = ModalParameters(ident.modal.freq_hz, ident.modal.damping_ratio,
                             ident.modal.shapes)
        if mm.n_modes == 0:
            continue
        with warnings.catch_warnings():  # one measured DOF: every MAC is 1, the
            warnings.simplefilter("ignore")  # frequencies pair the modes
            pairing = pair_modes(mm, dm, mac_min=0.5)
        for (a, b), mac in zip(np.asarray(pairing.pairs, int).reshape(-1, 2),
                               np.ravel(pairing.mac), strict=True):
            fd, zd = float(dm.freq_hz[b]), float(dm.damping_ratio[b])
            out.append(ModeResidual(
                t.name, fd, 100 * (float(mm.freq_hz[a]) / fd - 1), zd,
                100 * (float(mm.damping_ratio[a]) / zd - 1) if zd > 0 else float("nan"),
                float(mac), mpc(np.asarray(dm.shapes)[:, b])))
    return tuple(out)


def _identify(tests, max_order: int = 40):
    """The data's own modes per test (pLSCF over its compared lines), or None."""
    from truthbench.identify import identify_frfs

    out = []
    for t in tests:
        try:
            data = t.frf.lines(t.lines)
            out.append(identify_frfs(data, max_order=max_order,
                                     band_hz=(float(t.freq_hz.min()), float(t.freq_hz.max()))))
        except (ValueError, np.linalg.LinAlgError):
            out.append(None)
    return out


def diagnose(data: FRFData | Sequence[FRFData], plant: Plant, nominal: Mapping[str, float],
             parameters: Sequence[str], settings: DiagnoseSettings | None = None, **kwargs):
    """Find the effects a model lacks from measured FRFs.

    Parameters
    ----------
    data : FRFData or sequence of FRFData
        The measured tests (from :func:`truthbench.load_frf`: UFF, LVM, our HDF5).
    plant : Plant
        The model's plant (the user's article).
    nominal : mapping
        Its nominal parameters.
    parameters : sequence of str
        What the user trusts the model to get wrong: fitted first, as the baseline, and
        refitted with every candidate (plant parameters, ``delay_s``, ``sensor_gain``).
    settings : DiagnoseSettings, optional
        Or its fields as keyword arguments: ``candidates`` (registry names to try; default
        all), ``band_hz``, ``tolerance_m``, ``point_map`` and ``channel_map`` (placing
        the channels: :func:`~truthbench.diagnose.data.prepare`),
        ``max_effects`` (most effects in the final model), ``threshold`` (delta BIC),
        ``refits`` (the best screened candidates refitted at each step, besides the best
        location of every other effect), ``ambiguity_margin`` (delta BIC within which a
        runner-up makes the verdict "A or B"), ``estimator`` (compare through the data's
        leakage when known), ``window`` and ``fs_hz`` (the segment window of data from
        other tools, whose files do not say, and their sampling rate), ``averages``
        (their number of averages, which with the coherence sets the noise weights; the
        data's own when they state it), ``identify_modes`` (identify the data's modes
        for the paired-mode views), ``check_modes`` (look for modes the model lacks:
        :mod:`.adequacy`),
        ``mesh_tolerance`` and ``max_refinement`` (the mesh check: :mod:`.adequacy`),
        ``noise_margin`` (no effect is sought once the residual's variance is within
        this fraction of the noise's: the noise model's own accuracy) and
        ``excess_share`` (an effect must explain at least this share of the residual's
        excess over the noise: a flexible candidate absorbing a sliver of a residual the
        catalogue cannot explain is not a finding).

    Returns
    -------
    Diagnosis

    Raises
    ------
    DataFormatError
        A channel that cannot be placed, no input, no line in the band.
    IdentifiabilityError
        Fewer data than parameters, or the declared parameters cannot be separated.
    """
    if settings is None:
        settings = DiagnoseSettings(**kwargs)
    elif kwargs:
        settings = replace(settings, **kwargs)
    data = (data,) if isinstance(data, FRFData) else tuple(data)
    if settings.averages is not None:
        data = tuple(d if d.n_averages is not None else replace(d, n_averages=settings.averages)
                     for d in data)
    # small dense matrices: BLAS threads only add overhead (as in the campaign's trials)
    with threadpool_limits(limits=1, user_api="blas"):
        return _Diagnosis(data, plant, nominal, parameters, settings).run()


def _near(c: Candidate, x: float, a: Candidate, plant: Plant) -> bool:
    """Whether ``a`` is a located effect of ``c``'s kind and direction within
    :data:`TWIN_ELEMENTS` elements of the fraction ``x`` (``c``'s place)."""
    return (a.effect == c.effect and a.node is not None
            and a.options.get("direction") == c.options.get("direction")
            and abs(plant.stations.get(a.options["station"], np.inf) - x)
            <= TWIN_ELEMENTS / plant.n_elements + 1e-12)


def _renamed_station(options: Mapping, renamed: Mapping[str, str]) -> dict:
    st = options.get("station")
    return dict(options) if st is None else {**options, "station": renamed.get(st, st)}


def _renamed_label(label: str, options: Mapping, renamed: Mapping[str, str]) -> str:
    st = options.get("station")
    if st is None or st not in renamed:
        return label
    return label.replace(f"@{st}", f"@{renamed[st]}", 1)


def _refined_candidate(c: Candidate, renamed: Mapping[str, str], plant
                       ) -> tuple[Candidate, dict[str, float]]:
    """A candidate on ``plant``'s mesh refined to twice its elements, and the station it
    needs there (name -> fraction; empty when it has one).

    A located candidate's node station is renamed to the same point's new node. A joint
    is a hinge at a point: it stays there, in the half of its element the point falls
    in (its loss re-expressed for that half's length: :func:`_refined_theta`)."""
    n = plant.n_elements
    if c.effect == "joint" and c.node is not None:
        point = float(plant.stations[c.options["station"]])
        return at_fraction(c, point, 2 * n), {c.options["station"]: point}
    label = _renamed_label(c.label, c.options, renamed)
    return replace(c, options=_renamed_station(c.options, renamed), label=label,
                   node=None if c.node is None else c.node * 2), {}


def _relabelled(by_label: Mapping[str, object], renamed: Mapping[str, str]) -> dict:
    """``by_label`` with its keys renamed (labels not in ``renamed`` kept)."""
    return {renamed.get(k, k): v for k, v in by_label.items()}


def _refined_theta(theta: Mapping[str, float], accepted: Sequence[Candidate],
                   refined: Sequence[Candidate]) -> dict:
    """Parameter values with the candidates' keys renamed for the refined mesh
    (:func:`_refined_candidate`).

    A joint's stiffness loss is that of one element: the same rotational flexibility,
    ``loss h / (EI (1 - loss))``, on an element of half the length is a loss
    ``2 loss / (1 + loss)``."""
    out = dict(theta)
    for old, new in zip(accepted, refined, strict=True):
        for p, old_key, new_key in zip(old.fitted, old.keys(), new.keys(), strict=True):
            if old_key in out:
                value = out.pop(old_key)
                if old.effect == "joint" and p.name == "stiffness_loss":
                    value = 2 * value / (1 + value)
                out[new_key] = value
    return out


def _renamed_term(t, renamed: Mapping[str, str]):
    """An effect term on the refined mesh."""
    opts = _renamed_station(t.spec.options, renamed)
    label = _renamed_label(t.label, t.spec.options, renamed)
    share = None if t.share is None else _renamed_label(t.share, t.spec.options, renamed)
    return replace(t, label=label, spec=replace(t.spec, options=opts), share=share)


def _renamed_theta(theta: Mapping[str, float], terms, renamed: Mapping[str, str]) -> dict:
    """Parameter values with the effect terms' keys renamed for the refined mesh (their
    node stations renamed; not for joints: :func:`_refined_theta`)."""
    out = dict(theta)
    for t in terms:
        new = _renamed_term(t, renamed)
        for old_key, new_key in zip(t.keys(), new.keys(), strict=True):
            if old_key in out:
                out[new_key] = out.pop(old_key)
    return out


class _Diagnosis(_Placement):
    """One diagnosis's state as it runs (:func:`diagnose`)."""

    def __init__(self, data, plant, nominal, parameters, settings: DiagnoseSettings):
        self.settings = settings
        self.nominal = plant.resolve(nominal)
        self.declared = tuple(parameters)
        known = set(plant.parameter_names()) | set(APPENDED_PARAMETERS)
        bad = [p for p in self.declared if p not in known]
        if bad:
            raise ModelError(f"parameters {bad} are neither plant parameters of {plant.kind} "
                             f"nor {sorted(APPENDED_PARAMETERS)}")
        placed, self.tests = prepare(data, plant, self.nominal, band_hz=settings.band_hz,
                                     tolerance_m=settings.tolerance_m,
                                     point_map=settings.point_map,
                                     channel_map=settings.channel_map)
        self.placed = placed
        self.tried: list[Tried] = []
        self.thresholds: list[float] = []
        self.extra_poles: tuple[tuple[float, float], ...] = ()
        self.structural: dict | None = None  # the latest magnitude fit (:meth:`baseline`)
        self._evidence: dict[str, float] = {}
        self._reduced: dict[str, str] = {}  # second-order label -> its first-order one

    # ---- the problem ------------------------------------------------------------------
    def problem(self, plant, tests, accepted: Sequence[Candidate] = ()) -> Problem:
        """The fitting problem of ``tests`` on ``plant`` (node stations added), with the
        natural sizes of ``accepted``'s parameters (fitted additively: a joint's loss may
        come near 0, where a relative step has no size)."""
        s = self.settings
        ptests = tuple(PredictedTest(
            t.name, t.freq_hz, t.actuators, t.sensors, decay_rad_s=t.frf.window_decay_rad_s,
            kernel=_kernel(t.frf, s), band_hz=t.frf.band_hz) for t in tests)
        values = np.concatenate([t.H.ravel() for t in tests])
        weights = np.concatenate([1.0 / t.sigma.ravel() for t in tests])
        if 2 * values.size <= len(self.declared) + 1:
            raise IdentifiabilityError(
                f"{2 * values.size} real data values (lines x outputs x inputs x 2) cannot "
                f"determine {len(self.declared)} declared parameters and a candidate; widen "
                f"the band or add data")
        model_plant = with_node_stations(plant)
        f_max = max(float(t.freq_hz.max()) for t in tests)
        refs = references(model_plant, self.nominal, f_max,
                          f_min_hz=min(float(t.freq_hz.min()) for t in tests))
        levels = [r for t in tests if t.frf.input_rms is not None for r in t.frf.input_rms]
        refs["force"] = float(np.mean(levels)) if levels else 1.0
        self.refs = refs
        extra = ExtraModes.build(self.extra_poles, ptests, weights) if self.extra_poles \
            else None
        scales = {k: refs["time"] for k in self.declared if k == "delay_s"}
        for a in accepted:
            scales.update(a.scales(refs))
        problem = Problem(model_plant, dict(self.nominal), ptests, values, weights,
                          self.declared, scales, None,
                          {"max_iterations": s.max_iterations, "tolerance": s.tolerance},
                          extra)
        if not s.mounting:
            return problem
        # the mounting's columns at the latest magnitude fit (refreshed with the
        # estimator's offsets at every fit)
        hint = dict(self.structural or {})
        terms = terms_of(accepted, hint)
        return with_mounting(problem, terms, {**problem.theta0(terms), **hint})

    def baseline(self, problem: Problem, structural=None) -> tuple[Problem, Fit, Fit]:
        """The declared parameters fitted: (problem with the baseline's leakage offsets,
        the baseline, the magnitude fit the phase signatures are read against).

        ``structural``: a magnitude fit already made (on a coarser mesh, before a mode
        was modelled in), which is kept: a mode modelled in takes its residues from the
        complex residual, which a phase error (a delay of many radians) fills across
        the band, and a magnitude fit through it would carry that error."""
        if structural is None:
            structural = fit_magnitude(problem, start=self.level_start(problem))
        self.structural = structural
        try:
            current = fit(problem, start=structural)
            offset = with_offsets(problem, current)
            current = fit(offset, start=current.theta)
            problem = offset
        except REFIT_ERRORS:
            # where a phase error dwarfs the structure's, the complex fit's best is a
            # model near zero, where E and rho scale it alike and cannot be separated:
            # the magnitude fit is then the baseline
            problem = with_offsets(problem, evaluate(problem, (), self.declared,
                                                     structural))
            current = evaluate(problem, (), self.declared, structural)
        # the phase signatures are read against the magnitude fit, which a phase error
        # does not distort (the complex fit may bend the structure to mimic part of it)
        return problem, current, evaluate(problem, (), self.declared, structural)

    def margin(self, problem: Problem, fit_: Fit) -> float:
        """The ambiguity margin at this fit: ``ambiguity_margin`` while its residual is
        at the noise level (within :attr:`Diagnosis.UNCERTAINTY_CHI2` of it); beyond,
        the residual is model error, correlated across lines, and delta BIC counted over
        independent values overstates how well the data tell two explanations apart: the
        margin grows by the residual's lines per independent value over the estimator's
        (:func:`~.fit.residual_lines`)."""
        from truthbench.diagnose.result import Diagnosis

        ratio = fit_.chi2 / max(problem.n - len(fit_.names), 1) / self.noise
        if ratio < Diagnosis.UNCERTAINTY_CHI2:
            return self.settings.ambiguity_margin
        return self.settings.ambiguity_margin * residual_lines(problem, fit_) / \
            problem.correlation_lines

    def rebaseline(self, problem, tests, before_problem, baseline):
        """The baseline refitted on the terms the model is now compared on (its mesh,
        the modes modelled in), or the one before where that refit fails."""
        try:
            fresh, refitted, _ = self.baseline(self.problem(problem.plant, tests),
                                               self.structural)
        except REFIT_ERRORS:
            return before_problem, baseline
        return fresh, refitted

    def level_start(self, problem: Problem) -> dict[str, float] | None:
        """A start at the data's FRF level where the declared parameters can set it: the
        stiffness and the mass scaled together by ``1 / c`` leave the frequencies alone
        and scale every FRF by ``c``, so when ``E_pa`` and ``rho_kg_m3`` are both declared
        and the median ratio ``c = |D| / |M|`` over the lines is more than 5 % from 1, the
        fit starts there (the same record with its force scaled then gives the same
        fit). None: the nominal start."""
        if not {"E_pa", "rho_kg_m3"} <= set(self.declared):
            return None
        theta = problem.theta0()
        model = np.abs(np.asarray(problem.predict()(theta)))
        ok = model > 0
        if not ok.any():
            return None
        c = float(np.median(np.abs(problem.data[ok]) / model[ok]))
        if not np.isfinite(c) or c <= 0 or abs(np.log(c)) < np.log(1.05):
            return None
        return {**theta, "E_pa": theta["E_pa"] / c, "rho_kg_m3": theta["rho_kg_m3"] / c}

    # ---- adequacy --------------------------------------------------------------------
    def mesh_change(self, problem: Problem, fit_: Fit, noise: float):
        """The change of the model's FRFs (with ``fit_``'s effects) from its mesh to the
        mesh halved that refitting cannot absorb, in noise units; and the refined plant
        with its station renaming.

        A joint is left out of both meshes: its hinge is exact for the statics of the
        element it sits in, and its loss is stated per that element's length (the same
        hinge is another loss on the halved mesh); every other effect converges with the
        mesh (a point attachment between nodes to third order)."""
        fine, renamed = adequacy.refined_plant(problem.plant)
        kept = tuple(t for t in fit_.terms if t.spec.name != "joint")
        terms = tuple(_renamed_term(t, renamed) for t in kept)
        theta = _renamed_theta(fit_.theta, kept, renamed)
        fp = replace(problem, plant=with_node_stations(fine), tests=tuple(
            replace(pt, actuators=tuple(replace(a, station=renamed.get(a.station, a.station))
                                        for a in pt.actuators),
                    sensors=tuple(replace(x, station=renamed.get(x.station, x.station))
                                  for x in pt.sensors)) for pt in problem.tests))
        other = fp.predict(terms)(theta)
        coarse = fit_ if kept == fit_.terms else replace(
            fit_, model=np.asarray(problem.predict(kept)(fit_.theta)))
        return adequacy.unexplained_change(problem, coarse, other) / noise, fine, renamed

    def check_mesh(self, problem, tests, current, accepted, check=None):
        """Refine the mesh while halving it changes the model by more than the
        tolerance (module notes of :mod:`.adequacy`); the model's effects are carried
        over. Returns (the check, problem, tests, current, accepted, the magnitude fit
        of a refined baseline or None)."""
        s = self.settings
        noise = adequacy.noise_variance(tests) if check is None else check.noise_variance
        counts = list(check.n_elements[:-1]) if check is not None else []
        changes = list(check.change[:-1]) if check is not None else []
        limit = self.placed.n_elements * s.max_refinement
        signature = None
        while True:
            change, fine, renamed = self.mesh_change(problem, current, noise)
            counts.append(problem.plant.n_elements)
            changes.append(change)
            excess = max(current.chi2 / noise - problem.n, 0.0)
            tolerance = max(s.mesh_tolerance, adequacy.MESH_SHARE * excess)
            if change <= tolerance:
                adequate = True
                break
            if fine.n_elements > limit:
                adequate = False
                break
            renamed_tests = adequacy.renamed_tests(tests, renamed)
            refined = [_refined_candidate(c, renamed, problem.plant) for c in accepted]
            renamed_accepted = [c for c, _ in refined]
            theta = _refined_theta(current.theta, accepted, renamed_accepted)
            fine = replace(fine, stations={**fine.stations,
                                           **{k: v for _, st in refined for k, v in st.items()}})
            fresh = self.problem(fine, renamed_tests, renamed_accepted)
            try:
                if accepted:
                    refitted = fit(fresh, terms_of(renamed_accepted, theta), start=theta)
                    problem_f = with_offsets(fresh, refitted)
                    refitted = fit(problem_f, refitted.terms, start=refitted.theta)
                    sig_f = None
                else:
                    problem_f, refitted, sig_f = self.baseline(fresh, self.structural)
            except REFIT_ERRORS:
                adequate = False  # the refined model cannot be refitted: kept as it was
                break
            tests, accepted = renamed_tests, renamed_accepted
            problem, current, signature = problem_f, refitted, sig_f or signature
        return (adequacy.MeshCheck(tuple(counts), tuple(changes), tolerance, adequate,
                                   noise), problem, tests, current, accepted, signature)

    def lacking(self, problem, tests, current, accepted, mesh, missing: list, *,
                guided: bool = True):
        """Look for modes the model lacks at these channels (:func:`.adequacy.
        missing_modes`) in the residual of ``current`` (the model with its effects), and
        model each one found in; ``missing`` grows. Returns (problem, current, the
        magnitude fit of a refitted baseline or None)."""
        s = self.settings
        threshold = s.threshold + 2.0 * np.log(2.0)
        signature = None
        while s.check_modes and len(missing) < adequacy.MAX_MISSING:
            m = adequacy.missing_modes(tests, problem, current, mesh.noise_variance,
                                       problem.n_independent, threshold, guided=guided,
                                       known=[x.freq_hz for x in missing])
            if m is None:
                break
            self.extra_poles += ((m.freq_hz, m.damping_ratio),)
            fresh = self.problem(problem.plant, tests, accepted)
            try:
                if accepted:
                    refitted = fit(fresh, current.terms, start=current.theta)
                    problem_m = with_offsets(fresh, refitted)
                    refitted = fit(problem_m, refitted.terms, start=refitted.theta)
                    sig_m = None
                else:
                    problem_m, refitted, sig_m = self.baseline(fresh, self.structural)
            except REFIT_ERRORS:
                # the model with the mode in cannot be refitted: left as it was
                self.extra_poles = self.extra_poles[:-1]
                break
            missing.append(m)
            problem, current, signature = problem_m, refitted, sig_m or signature
        return problem, current, signature

    # ---- the search ------------------------------------------------------------------
    def run(self):
        from truthbench.diagnose.result import Diagnosis

        s = self.settings
        tests = self.tests
        self.noise = adequacy.noise_variance(tests)
        problem, base, signature = self.baseline(self.problem(self.placed, tests))
        mesh, problem, tests, base, _, sig2 = self.check_mesh(problem, tests, base, [])
        signature = sig2 or signature
        missing: list = []
        problem, base, sig2 = self.lacking(problem, tests, base, [], mesh, missing,
                                           guided=False)
        signature = sig2 or signature
        data_modes = _identify(tests) if s.identify_modes else [None] * len(tests)
        baseline, before_problem = base, problem
        n = problem.n_independent
        cands = catalogue(problem.plant, self.nominal, tests, names=s.candidates)
        current = base
        accepted: list[Candidate] = []
        alternatives: dict[str, tuple[Alternative, ...]] = {}
        dropped: list[Found] = []
        measured: tuple[Measurement, ...] = ()
        merged: set[str] = set()  # accepted attachments a twin was tried against
        for step in range(2 * s.max_effects + 1):
            if len(accepted) >= s.max_effects:
                break
            chosen, finals, paired = self.step(problem, current, cands, accepted, step, n,
                                               signature, tests)
            if chosen is None:
                # nothing more to add: a mode the model lacks that only the guided look
                # finds (the effects' residual is gone) changes the comparison, and the
                # search goes on once more
                poles = len(self.extra_poles)
                problem, current, _ = self.lacking(problem, tests, current, accepted, mesh,
                                                   missing)
                if len(self.extra_poles) == poles:
                    break
                before_problem, baseline = self.rebaseline(problem, tests, before_problem,
                                                           baseline)
                continue
            margin = self.margin(chosen.problem, chosen.fit)
            if paired is not None:  # the model's form and a finalist, together
                form, chosen = paired
                accepted.append(form)
                self._evidence[form.label] = chosen.delta_bic
            else:
                chosen = parsimonious(finals, chosen, margin,
                                      max(float(t.freq_hz.max()) for t in tests))
            twin = self.twin(accepted, chosen, problem, merged)
            if twin is not None:
                moved = self.move(problem, current, accepted, twin, n, step, tests)
                merged.add(twin.label)
                if moved is not None and delta_bic(
                        n, moved.fit.chi2, chosen.fit.chi2,
                        len(chosen.candidate.fitted)) < self.thresholds[-1]:
                    # the found attachment moved (and resized) explains the data as
                    # well as a second one beside it: one attachment, placed anew
                    c = chosen.candidate
                    self.tried.append(Tried(
                        step, c.label, c.effect, c.options, float("nan"), chosen.delta_bic,
                        status=f"not added: {twin.label} moved to "
                               f"{moved.candidate.label} explains as much"))
                    renamed = {twin.label: moved.candidate.label}
                    accepted = [moved.candidate if a is twin else a for a in accepted]
                    self._evidence = _relabelled(self._evidence, renamed)
                    alternatives = _relabelled(alternatives, renamed)
                    current, problem = moved.fit, moved.problem or problem
                    continue
            accepted.append(chosen.candidate)
            current, problem = chosen.fit, chosen.problem
            runners = ambiguous(finals, chosen, margin)
            if runners:
                alternatives[chosen.candidate.label] = tuple(self._alternative(r, margin)
                                                             for r in runners)
            for runner in runners:
                try:
                    measured += measurements(problem, chosen.fit, runner.fit,
                                             (chosen.candidate.label, runner.candidate.label),
                                             tests, problem.plant,
                                             problem_b=runner.problem)
                except REFIT_ERRORS:
                    pass
            newest = accepted[-1]
            self._evidence[newest.label] = chosen.delta_bic
            accepted, current, problem, gone = self.backward(problem, current, accepted, n,
                                                             step, self.thresholds[-1])
            dropped += gone
            # a second-order low-pass reduced to its first-order limit: the runners-up
            # it was chosen over were judged against the other form
            for old in self._reduced:
                alternatives.pop(old, None)
            if self._reduced.get(newest.label, newest.label) not in {a.label for a in accepted}:
                break  # the step added nothing that holds: the search has converged
            # the model with its effects must still be resolved by its mesh (an
            # attachment between nodes is represented to O(h^3) only)
            used = problem.plant.n_elements
            before_labels = [a.label for a in accepted]
            mesh, problem, tests, current, accepted, _ = self.check_mesh(
                problem, tests, current, accepted, mesh)
            if problem.plant.n_elements != used:
                cands = catalogue(problem.plant, self.nominal, tests, names=s.candidates)
                moved = dict(zip(before_labels, (a.label for a in accepted), strict=True))
                self._evidence = _relabelled(self._evidence, moved)
                alternatives = _relabelled(alternatives, moved)
            # a mode the model lacks may show only once the effects found are in
            poles = len(self.extra_poles)
            problem, current, _ = self.lacking(problem, tests, current, accepted, mesh,
                                               missing)
            if len(self.extra_poles) != poles or problem.plant.n_elements != used:
                # the baseline compared on the same terms (mesh, modes modelled in)
                before_problem, baseline = self.rebaseline(problem, tests, before_problem,
                                                           baseline)
        for _ in range(REPLACE_ROUNDS):  # each found place, with the others found
            if len(accepted) < 2:
                break
            accepted, current, problem, renamed = self.replace_all(
                problem, current, accepted, n, len(self.thresholds), tests)
            if not renamed:
                break
            self._evidence = _relabelled(self._evidence, renamed)
            alternatives = _relabelled(alternatives, renamed)
            accepted, current, problem, gone = self.backward(
                problem, current, accepted, n, len(self.thresholds), self.thresholds[-1])
            dropped += gone
        found = self.evidence(problem, current, accepted, n, alternatives)
        before = residual_views(tests, _parts(tests, baseline.model), len(baseline.names),
                                modes=_modes(tests, before_problem, baseline, data_modes))
        after = residual_views(tests, _parts(tests, current.model), len(current.names),
                               modes=_modes(tests, problem, current, data_modes))
        return Diagnosis(tuple(found), before, after, baseline, current, tuple(self.tried), s,
                         tests, problem.plant, dict(self.nominal), self.declared, problem.n,
                         float(n), tuple(self.thresholds), mesh=mesh, missing=tuple(missing),
                         dropped=tuple(dropped), measurements=measured,
                         not_tried=not_tried(problem.plant, tests, s.candidates),
                         mounting=mounting_check(problem, current, self.noise))

    def step(self, problem, current, cands, accepted, step, n, signature, tests):
        """One forward step: screen, refit, choose. Returns (the chosen full refit or
        None, every full refit of the step, a model-form candidate and the finalist
        refitted with it that beat the chosen one together (:meth:`with_form`) or
        None)."""
        s = self.settings
        refs = self.refs
        pred = problem.predictor(current.terms)
        cands = bind_levels(cands, lambda t, pred=pred, cur=current: pred.hardware(
            cur.theta, t.actuators, t.sensors, test=t.name), tests)
        screened = screen(problem, current, cands, accepted, refs, step, self.tried)
        if not screened:
            return None, [], None
        # the threshold grows with the number of candidates tried (look-elsewhere: the
        # best of M noise-only chi2 drops is about 2 ln M)
        threshold = s.threshold + 2.0 * np.log(max(len(screened), 1))
        self.thresholds.append(float(threshold))
        # the residual's excess over the noise: nothing is sought once the model is at
        # the noise level, within what the noise model itself can be trusted to
        excess = current.chi2 - self.noise * (problem.n - len(current.names))
        if excess <= s.noise_margin * self.noise * problem.n:
            self.tried.extend(Tried(step, sc.candidate.label, sc.candidate.effect,
                                    sc.candidate.options, sc.drop, status="at the noise level")
                              for sc in screened)
            return None, [], None
        # candidates a residual signature points at start where it points (a delay from
        # the matched-delay profile, a gain from the magnitude ratio), with the declared
        # parameters of the magnitude fit at the first step: a first-order score from
        # zero misjudges a phase error of several radians, so the phase candidates are
        # judged by the matched delay's exact drop too
        base = signature if step == 0 and signature is not None else current
        views = residual_views(tests, _parts(tests, base.model), len(base.names))
        delay, phase_drop = None, -np.inf
        if any(sc.candidate.effect in PHASE_EFFECTS for sc in screened):
            # read against the model without the modes it lacks: their residues are
            # projected from the data, so near them the model holds the data's own phase
            plain = problem if problem.extra is None else replace(problem, extra=None)
            model = np.asarray(plain.predict(base.terms)(base.theta))
            delay = data_delay(tests, model, views)
            phase_drop = delay_drop(plain, tests, model, delay)
            # a second phase effect beside an accepted one starts at half its lag: at
            # zero a low-pass's and a delay's columns are the same (-j omega), and the
            # accepted lag may hold the sum of both
            delay = max(delay, 0.5 * accepted_lag(accepted, current.theta))
        top = max(screened[0].drop, phase_drop)
        # nothing to refit when not even the best screened drop, three times over, would
        # be significant (exact profiles and line searches are lower bounds of what a
        # refit reaches; the factor covers the first-order scores' error)
        k = max(len(sc.candidate.fitted) for sc in screened)
        if delta_bic(n, current.chi2, max(current.chi2 - 3 * top, 1e-12 * current.chi2),
                     1) - (k - 1) * np.log(n) < threshold:
            self.tried.extend(Tried(step, sc.candidate.label, sc.candidate.effect,
                                    sc.candidate.options, sc.drop) for sc in screened)
            return None, [], None
        results: dict[str, Refit | None] = {}
        chosen = shortlist(screened, best=s.refits, factor=3.0)
        for sc in screened:
            c = sc.candidate
            drop = max(sc.drop, phase_drop) if c.effect in PHASE_EFFECTS else sc.drop
            if drop < top / 10 and sc not in chosen:
                continue
            start = signature_start(c, views, tests, base.model, delay)
            if start is not None:
                results[c.label] = refit(problem, current, accepted, c, sc.drop, start, refs,
                                         n, step, self.tried, declared_start=base.theta)
        for sc in chosen:
            c = sc.candidate
            if c.label not in results:
                results[c.label] = refit(problem, current, accepted, c, sc.drop, sc.guess,
                                         refs, n, step, self.tried,
                                         declared_start=adapted(current.theta, sc.adapt))
        # the best located refit's neighbours (a first-order score can rank a mirror
        # image or a neighbour first for a large change)
        best = next(iter(ranked(r for r in results.values()
                                if r and r.candidate.node is not None)), None)
        if best is not None:
            b = best.candidate
            for sc in screened:
                c = sc.candidate
                if (c.effect == b.effect and c.label not in results
                        and c.options.get("direction") == b.options.get("direction")
                        and abs(c.node - b.node) <= 1):
                    results[c.label] = refit(problem, current, accepted, c, sc.drop,
                                             sc.guess, refs, n, step, self.tried,
                                             declared_start=adapted(current.theta, sc.adapt))
        labels = {r.candidate.label for r in results.values() if r}
        self.tried.extend(Tried(step, sc.candidate.label, sc.candidate.effect,
                                sc.candidate.options, sc.drop) for sc in screened
                          if sc.candidate.label not in labels and sc.candidate.label
                          not in {t.label for t in self.tried if t.step == step})
        ok = ranked(r for r in results.values() if r and r.physical and
                    r.delta_bic > threshold)
        # the best two, and the best location of the next best effects, completed, each
        # with the estimator's leakage at its own model, compared on that chi2
        short = list(ok[:2])
        for r in ok[2:]:
            if r.candidate.effect not in {x.candidate.effect for x in short}:
                short.append(r)
        finals = []
        for r in short[:4]:
            if r.delta_bic < 0.5 * ok[0].delta_bic and finals:
                break
            try:
                full = full_refit(problem, current, accepted, r, refs, n, tests)
            except REFIT_ERRORS as exc:
                c = r.candidate
                self.tried.append(Tried(step, c.label, c.effect, c.options, float("nan"),
                                        status=f"full refit: {refit_error(exc)}"))
                continue
            if full.delta_bic > threshold and full.physical and \
                    current.chi2 - full.fit.chi2 >= s.excess_share * excess:
                finals.append(full)
            elif full.delta_bic > threshold and full.physical:
                c = r.candidate
                self.tried.append(Tried(
                    step, c.label, c.effect, c.options, float("nan"), full.delta_bic,
                    status=f"explains {100 * (current.chi2 - full.fit.chi2) / excess:.3g} % "
                           f"of the residual's excess over the noise, less than "
                           f"{100 * s.excess_share:g} %"))
        if not finals:
            return None, finals, None
        # every located contender is placed between the nodes before the choice: a mass
        # between two nodes, held at the nearer one, loses to a joint's two parameters
        best_bic = max(r.delta_bic for r in finals)
        finals = [self.refine_position(problem, current, accepted, r, n, step, tests)
                  if r.candidate.node is not None and r.delta_bic >= 0.5 * best_bic else r
                  for r in finals]
        best = ranked(finals)[0]
        return best, finals, self.with_form(problem, current, accepted, cands, finals, best,
                                            n, step, threshold, tests)

    def with_form(self, problem, current, accepted, cands, finals, best, n, step, threshold,
                  tests):
        """A located finalist with the model-form candidate (:data:`MODEL_FORM`: the
        element's shear and rotary inertia) that beats the step's best alone by more
        than the threshold: (the form, the finalist's :class:`Refit` with the form in,
        placed between nodes), or None.

        A local effect fitted on a model whose form is wrong can lose to another that
        mimics both (a joint on a Timoshenko article lost to a mass by 6000 of delta
        BIC, and the shear terms could not then join the mass; with them the joint
        brought the residual from 54 to 4 times the noise): the form is tried with each
        of the two best located finalists where they were placed (a quick refit from
        their fits, the form from its physical value: a joint's fit is sharp in its
        place); the best pair that beats ``best`` by more than the threshold, counting
        the form's parameter, is completed and placed. Not with
        ``best`` itself: the form beside the best is the next step's to judge, as every
        other effect."""
        form = next((c for c in cands if c.effect in MODEL_FORM), None)
        if form is None or any(a.effect in MODEL_FORM for a in accepted):
            return None
        b = best.candidate
        located = ranked(r for r in finals if r.candidate.node is not None and not (
            r.candidate.effect == b.effect and abs(r.candidate.node - b.node) <= 1))[:2]
        pairs = []
        for r in located:
            c = r.candidate
            pr = r.problem or problem
            terms = terms_of(accepted, r.fit.theta) + form.terms(
                start=MODEL_FORM[form.effect]) + c.terms(start=fitted_own(c, r.fit.theta))
            pc = replace(pr, scales={**pr.scales, **form.scales(self.refs),
                                     **c.scales(self.refs)})
            try:
                quick = fit(pc, terms, start=r.fit.theta, quick=True)
            except REFIT_ERRORS:
                continue
            if delta_bic(n, current.chi2, quick.chi2, len(c.fitted) + len(form.fitted)) > \
                    best.delta_bic + threshold:
                pairs.append((quick.chi2, c, pc, quick))
        if not pairs:
            return None
        _, c, pc, quick = min(pairs, key=lambda x: x[0])
        # the finalist placed with the form in: the model with the form is its "current"
        with_form = [*accepted, form]
        own = fitted_own(form, quick.theta)
        pseudo = replace(current, names=current.names + form.keys(),
                         theta={**current.theta, **{f"{form.label}.{k}": v
                                                    for k, v in own.items()}},
                         terms=terms_of(with_form, quick.theta))
        try:
            full = full_refit(pc, pseudo, with_form, Refit(
                delta_bic(n, current.chi2, quick.chi2, len(c.fitted)), c, quick, "refitted"),
                self.refs, n, tests)
        except REFIT_ERRORS:
            return None
        placed = self.refine_position(pc, pseudo, with_form, full, n, step, tests)
        dbic = placed.delta_bic - len(form.fitted) * np.log(n)
        if not placed.physical or bounds_ok(form, placed.fit.theta, placed.fit.std,
                                            form.scales(self.refs)) or \
                dbic <= best.delta_bic + threshold:
            return None
        c = placed.candidate
        own = fitted_own(c, placed.fit.theta)
        self.tried.append(Tried(step, c.label, c.effect, c.options, float("nan"), dbic, own,
                                c.effect_values(own), f"refitted with {form.label}: beats "
                                f"{best.candidate.label} alone"))
        return form, replace(placed, delta_bic=dbic)

    def twin(self, accepted, chosen: Refit, problem, merged) -> Candidate | None:
        """The accepted point attachment or joint of the chosen one's kind and direction
        within two elements of it, not tried as a twin before (``merged``), or None: a
        second mass beside a found one is as often the first one misplaced (its place
        searched on a coarser mesh, or before a later effect, within one element of
        where it screened) as a second mass."""
        c = chosen.candidate
        if (c.effect not in POINT_EFFECTS and c.effect != "joint") or c.node is None:
            return None
        x = (chosen.problem or problem).plant.stations.get(c.options["station"])
        if x is None:
            return None
        return next((a for a in accepted if a.label not in merged
                     and _near(c, x, a, problem.plant)), None)

    @staticmethod
    def without(problem, current, accepted, a: Candidate):
        """``(the accepted effects but a, the problem with current's offsets, the model
        refitted without a)``, or None when it cannot be refitted."""
        rest = [x for x in accepted if x is not a]
        try:
            pc = with_offsets(problem, current)
            return rest, pc, fit(pc, terms_of(rest, current.theta), start=current.theta)
        except REFIT_ERRORS:
            return None

    def move(self, problem, current, accepted, twin: Candidate, n, step, tests
             ) -> Refit | None:
        """``twin`` placed and sized anew with the other accepted effects in (its
        position searched :data:`TWIN_ELEMENTS` elements either side:
        :meth:`refine_position`), or None when the model without it cannot be
        refitted."""
        out = self.without(problem, current, accepted, twin)
        if out is None:
            return None
        others, pc, without = out
        here = Refit(delta_bic(n, without.chi2, current.chi2, len(twin.fitted)), twin,
                     current, "refitted", pc)
        return self.refine_position(pc, without, others, here, n, step, tests,
                                    reach=TWIN_ELEMENTS)

    def replace_all(self, problem, current, accepted, n, step, tests):
        """Every accepted point attachment and joint placed anew with all the other
        found effects in (:meth:`move`): each was placed at its own step, against a
        model that lacked the effects found after it, and a place biased so leaves a
        residual that a second, small effect of the same kind takes up (a joint placed
        3.7 cm from the truth's, and a 3 % joint at the other end). Returns (accepted,
        current, problem, {old label: new label})."""
        renamed = {}
        for a in list(accepted):
            if a.node is None or (a.effect not in POINT_EFFECTS and a.effect != "joint"):
                continue
            if a not in accepted:
                continue  # merged into a twin this round
            merged = self.merge(problem, current, accepted, a, n, step, tests)
            if merged is not None:
                b, moved = merged
                m = moved.candidate
                self.tried.append(Tried(
                    step, b.label, b.effect, b.options, float("nan"),
                    delta_bic(n, moved.fit.chi2, current.chi2, len(b.fitted)),
                    status=f"dropped: {a.label} moved to {m.label} explains as much"))
                renamed[a.label] = m.label
                accepted = [m if x is a else x for x in accepted if x is not b]
                current, problem = moved.fit, moved.problem or problem
                continue
            moved = self.move(problem, current, accepted, a, n, step, tests)
            if moved is None or moved.candidate.label == a.label or \
                    not moved.fit.chi2 < current.chi2:
                continue
            m = moved.candidate
            own = fitted_own(m, moved.fit.theta)
            self.tried.append(Tried(step, m.label, m.effect, m.options, float("nan"),
                                    moved.delta_bic, own, m.effect_values(own),
                                    f"{a.label} placed anew with the other effects in"))
            renamed[a.label] = m.label
            accepted = [m if x is a else x for x in accepted]
            current, problem = moved.fit, moved.problem or problem
        return accepted, current, problem, renamed

    def merge(self, problem, current, accepted, a: Candidate, n, step, tests):
        """``(b, refit)`` when ``a`` moved and resized, without ``b``, its weaker twin
        (another accepted effect of its kind and direction within
        :data:`TWIN_ELEMENTS` elements), explains the data within the last step's
        threshold of the two, else None: a pair found at two steps can each hold the
        other near a biased place (a spring 2 cm off with a 136 N/m spring beside it),
        which placing one at a time moves only slowly apart."""
        x = problem.plant.stations.get(a.options["station"], np.inf)
        twins = [b for b in accepted if b is not a and _near(a, x, b, problem.plant)
                 and self._evidence.get(b.label, 0.0) <= self._evidence.get(a.label, 0.0)]
        for b in twins:
            out = self.without(problem, current, accepted, b)
            if out is None:
                continue
            rest, pc, without = out
            moved = self.move(pc, without, rest, a, n, step, tests)
            if moved is not None and delta_bic(n, moved.fit.chi2, current.chi2,
                                               len(b.fitted)) < self.thresholds[-1]:
                return b, moved
        return None

    def backward(self, problem, current, accepted, n, step, threshold):
        """Drop the effects that are not significant in the model with the others (each
        refitted out of the model in turn; the least needed goes first, then the rest are
        tested again). The newest is tested too: a fit that an earlier effect's refit
        explains as well (a local minimum of a multimodal cost) did not add anything.
        An effect stays when it still passes the criterion it entered by (the step's
        ``threshold``, look-elsewhere term included). Returns (accepted, current,
        problem, the dropped effects as Found); the evidence of those kept is recorded
        for :meth:`evidence`.
        """
        gone = []
        accepted, current, problem = self.held(problem, current, accepted)
        accepted, current, problem = self.reduced(problem, current, accepted, n, step,
                                                  threshold)
        while len(accepted) > 1:
            worst = None
            for a in accepted:
                out = self.without(problem, current, accepted, a)
                if out is None:
                    continue
                _, pc, without = out
                dbic = delta_bic(n, without.chi2, current.chi2, len(a.fitted))
                self._evidence[a.label] = dbic
                # an effect whose values a later refit moved out of their physical
                # bounds (a joint's loss below 0, a mass below 0: its constrained fit
                # is no effect) goes first, whatever it explains
                beyond = crossed(a, current.theta)
                rank = -np.inf if (beyond and len(beyond) == len(a.fitted)) or bounds_ok(
                    a, current.theta, {}, a.scales(self.refs)) else dbic
                if (rank < threshold) and (worst is None or rank < worst[0]):
                    worst = (rank, a, without, pc)
            if worst is None:
                break
            rank, a, without, pc = worst
            dbic = self._evidence[a.label]
            why = ("dropped: out of its physical bounds after a later refit"
                   if rank == -np.inf else "dropped: no longer significant")
            own = fitted_own(a, current.theta)
            gone.append(Found(a.effect, dict(a.options), a.effect_values(own), own,
                              {k: float("nan") for k in own}, float(dbic), a.node, a.label))
            self.tried.append(Tried(step, a.label, a.effect, a.options, float("nan"),
                                    float(dbic), own, a.effect_values(own),
                                    why))
            accepted = [x for x in accepted if x is not a]
            current, problem = without, with_offsets(pc, without)
            accepted, current, problem = self.held(problem, current, accepted)
        return accepted, current, problem, gone

    def reduced(self, problem, current, accepted, n, step, threshold):
        """The accepted second-order low-passes whose ``s^2`` term the data no longer
        need, replaced by the first-order low-pass they contain (:data:`NESTED`), the
        model refitted. A term is not needed when the refit without it loses less than
        ``threshold`` of delta BIC, when its upper pole lies beyond :data:`FAR_POLE`
        times the band's top (a lag the band cannot resolve from a first-order one), or
        when a refit has held it at 0. A resonance chosen while the model lacked
        another effect can collapse to its first-order limit once that effect is in
        (in one study trial a natural frequency of 16 kHz with a damping ratio of 30,
        a corner at 278 Hz against the truth's 277 Hz), and its ``s^2`` coefficient at
        0 then breaks the finite differences of every later refit. Returns (accepted,
        current, problem); each replacement is recorded in ``self._reduced``."""
        f_max = max(float(t.freq_hz.max()) for t in self.tests)
        for a in list(accepted):
            if a.effect not in NESTED:
                continue
            fitted_values = fitted_own(a, current.theta)
            own = {**dict(a.pinned), **fitted_values}
            if not {"a_s2", "b_s"} <= set(own):
                continue
            simpler = NESTED[a.effect][0]
            b = Candidate(simpler, dict(a.options), a.label.replace(a.effect, simpler, 1),
                          EFFECTS[simpler].diagnosis.fitted, a.node)
            if any(x.label == b.label for x in accepted):
                continue  # the first-order one is already found beside it
            rest = [b if x is a else x for x in accepted]
            start = {k: v for k, v in current.theta.items()
                     if not k.startswith(f"{a.label}.")}
            start[f"{b.label}.tau_s"] = own["b_s"]
            try:
                pc = with_offsets(problem, current)
                pc = replace(pc, scales={**pc.scales, **b.scales(self.refs)})
                simple = fit(pc, terms_of(rest, start), start=start)
            except REFIT_ERRORS:
                continue
            far = own["a_s2"] <= 0 or far_pole_hz(own["a_s2"], own["b_s"]) > FAR_POLE * f_max
            dbic = delta_bic(n, simple.chi2, current.chi2, len(a.fitted) - len(b.fitted))
            if not far and dbic >= threshold:
                continue
            self.tried.append(Tried(
                step, a.label, a.effect, a.options, float("nan"), float(dbic),
                fitted_values, a.effect_values(fitted_values),
                f"reduced to {b.label}: " + ("its upper pole is beyond the band's resolution"
                                            if far else "its s^2 term is not significant")))
            self._reduced[a.label] = b.label
            self._evidence = _relabelled(self._evidence, {a.label: b.label})
            accepted, current, problem = rest, simple, with_offsets(pc, simple)
        return accepted, current, problem

    def held(self, problem, current, accepted):
        """The accepted effects with the fitted parameters a later refit moved beyond a
        physical bound, while others of theirs are within (a joint's damping below 0),
        held at the bound and the model refitted (the constrained fit). Returns
        (accepted, current, problem), unchanged when nothing crossed or the refit
        fails."""
        pins = {a.label: partly_crossed(a, current.theta) for a in accepted}
        if not any(pins.values()):
            return accepted, current, problem
        pinned = [a.pin(pins[a.label]) if pins[a.label] else a for a in accepted]
        try:
            pc = with_offsets(problem, current)
            refitted = fit(pc, terms_of(pinned, current.theta), start=current.theta)
        except REFIT_ERRORS:
            return accepted, current, problem
        return pinned, refitted, with_offsets(pc, refitted)

    def evidence(self, problem, current, accepted, n, alternatives) -> list[Found]:
        """The found effects with their evidence in the final model (delta BIC of the
        model refitted without each)."""
        out = []
        plant = problem.plant
        for a in accepted:
            own = fitted_own(a, current.theta)
            std = {p.name: current.std.get(f"{a.label}.{p.name}", float("nan"))
                   for p in a.fitted}
            station = a.options.get("station")
            x_m = None if station is None else float(
                plant.station_coordinates_m(station, self.nominal)[0])
            out.append(Found(a.effect, dict(a.options), a.effect_values(own), own, std,
                             float(self._evidence.get(a.label, float("nan"))),
                             a.node, a.label, x_m, alternatives.get(a.label, ())))
        return out

    def _alternative(self, r: Refit, margin: float) -> Alternative:
        c = r.candidate
        own = fitted_own(c, r.fit.theta)
        station = c.options.get("station")
        x_m = None if station is None or r.problem is None else float(
            r.problem.plant.station_coordinates_m(station, self.nominal)[0])
        return Alternative(c.effect, dict(c.options), c.label, c.effect_values(own), own,
                           r.delta_bic, c.node, margin, x_m)


__all__ = ["MODEL_FORM", "DiagnoseSettings", "Found", "Residual", "Tried", "diagnose"]
