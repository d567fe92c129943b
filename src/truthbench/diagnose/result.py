"""The result of a diagnosis: what was found, the residual before and after, the evidence.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from truthbench.diagnose.adequacy import MeshCheck, MissingMode
from truthbench.diagnose.core import DiagnoseSettings, Found, Tried
from truthbench.diagnose.fit import Fit
from truthbench.diagnose.mounting import MountingCheck
from truthbench.diagnose.residual import Residual
from truthbench.diagnose.verdict import Measurement
from truthbench.plants.base import Plant

TABLES = ("found", "checks", "candidates", "channels", "modes", "pairs", "measurements",
          "summary")


def _clean(value):
    """JSON-safe: NaN and inf to None, numpy scalars and arrays to Python."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, np.ndarray):
        return [_clean(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """What :func:`~truthbench.diagnose.diagnose` found.

    Attributes
    ----------
    found : tuple of Found
        The effects added, in the order found (empty: nothing missing).
    before, after : Residual
        The residual views of the baseline (declared parameters fitted) and of the final
        model (with the found effects).
    baseline, final : Fit
    tried : tuple of Tried
        Every candidate screened or refitted, per step.
    settings : DiagnoseSettings
    tests : tuple of MeasuredTest
    plant : Plant
        The model's plant (with the stations the data and candidates use).
    nominal : dict
    declared : tuple of str
    n : int
        Real data values compared (lines x outputs x inputs x 2).
    n_independent : float
        ``n`` over the estimate's correlated lines per value: the n of the criterion.
    thresholds : tuple of float
        The delta BIC a candidate had to exceed at each step (``threshold + 2 ln M``).
    mesh : MeshCheck or None
        The mesh check (the mesh used, refined or not).
    missing : tuple of MissingMode
        Modes in the data the model lacks at these channels (their lines left out).
    dropped : tuple of Found
        Effects added at an earlier step and dropped when a later one made them
        insignificant (backward elimination).
    measurements : tuple of Measurement
        Where an ambiguous finding's explanations differ most against the noise.
    not_tried : tuple of (str, str)
        Effects asked for that could not be tried at all here, each with the reason
        (friction without the tests' input levels, a boundary without a suspension).
    mounting : MountingCheck or None
        What the channels' off-axis mounting, modelled in, took up (None: not modelled).
    """

    found: tuple[Found, ...]
    before: Residual
    after: Residual
    baseline: Fit
    final: Fit
    tried: tuple[Tried, ...]
    settings: DiagnoseSettings
    tests: tuple
    plant: Plant
    nominal: dict
    declared: tuple[str, ...]
    n: int
    n_independent: float = float("nan")
    thresholds: tuple[float, ...] = ()
    mesh: MeshCheck | None = None
    missing: tuple[MissingMode, ...] = ()
    dropped: tuple[Found, ...] = ()
    measurements: tuple[Measurement, ...] = ()
    not_tried: tuple[tuple[str, str], ...] = ()
    mounting: MountingCheck | None = None

    UNCERTAINTY_CHI2 = 2.0
    """The reduced chi2 of the final model (in units of the data's noise) below which
    its standard deviations are stated: above it the residual is model error, not noise,
    and a covariance scaled by it does not describe the error of the values."""

    @property
    def noise_ratio(self) -> float:
        """The final residual's variance over the data's noise variance (1 when the
        residual is noise): the reduced chi2 over the noise variance of the weighted
        data (1 for weights from coherence; the roughness estimate for relative weights,
        :func:`~truthbench.diagnose.adequacy.noise_variance`)."""
        noise = self.mesh.noise_variance if self.mesh is not None else 1.0
        return float(self.after.reduced_chi2 / noise)

    @property
    def uncertainty_holds(self) -> bool:
        """Whether the final residual is at the noise level (:attr:`noise_ratio` below
        :attr:`UNCERTAINTY_CHI2`), so that the standard deviations of the fitted values
        mean what they say (a Monte Carlo test checks that +-2 sigma then covers the
        true value about 95 % of the time)."""
        return bool(self.noise_ratio < self.UNCERTAINTY_CHI2)

    @property
    def verdict(self) -> str:
        """One line: what the model lacks (each finding, "A or B" where the data cannot
        tell them apart), or that nothing is missing."""
        if not self.found:
            return "nothing missing"
        parts = []
        for f in self.found:
            names = [f.effect + (f" ({where(f.options)})" if f.options else "")] + [
                a.effect + (f" ({where(a.options)})" if a.options else "")
                for a in f.alternatives]
            parts.append(" or ".join(names))
        return "; ".join(parts)

    @property
    def frf_error_before(self) -> float:
        return self.before.frf_error

    @property
    def frf_error_after(self) -> float:
        return self.after.frf_error

    def ranked(self, step: int = 0) -> list[Tried]:
        """The candidates refitted at ``step``, best delta BIC first."""
        done = [t for t in self.tried if t.step == step and not math.isnan(t.delta_bic)]
        return sorted(done, key=lambda t: -t.delta_bic)

    def declared_values(self, fit: str = "final") -> dict[str, float]:
        f = self.final if fit == "final" else self.baseline
        return {k: float(f.theta[k]) for k in self.declared}

    def to_dict(self) -> dict:
        """One JSON-safe object: ``found`` (registry names, parameters, options, std,
        delta BIC), ``frf_error_before`` / ``frf_error_after`` (the noise-weighted relative
        RMS of the FRF residual), ``reduced_chi2_before`` / ``after``, ``declared`` (the
        declared parameters before and after), ``candidates`` (ranked per step, with the
        criterion), ``modes`` (frequency and damping errors before and after), ``channels``
        and ``pairs`` (the other residual views), ``settings``."""
        holds = self.uncertainty_holds
        return _clean({
            "verdict": self.verdict,
            "found": [{"effect": f.effect, "parameters": f.parameters,
                       "options": f.options, "fitted": f.fitted,
                       "std": f.std if holds else None,
                       "delta_bic": f.delta_bic, "node": f.node, "x_m": f.x_m,
                       "alternatives": [asdict(a) for a in f.alternatives]}
                      for f in self.found],
            "uncertainty_holds": holds, "noise_ratio": self.noise_ratio,
            "mesh": None if self.mesh is None else {
                "n_elements": list(self.mesh.n_elements), "change": list(self.mesh.change),
                "tolerance": self.mesh.tolerance, "adequate": self.mesh.adequate,
                "used": self.mesh.used, "summary": self.mesh.summary()},
            "missing_modes": [{**asdict(m), "summary": m.summary()} for m in self.missing],
            "mounting": None if self.mounting is None else {
                **asdict(self.mounting), "summary": self.mounting.summary()},
            "dropped": [{"effect": f.effect, "options": f.options,
                         "parameters": f.parameters, "delta_bic": f.delta_bic}
                        for f in self.dropped],
            "measurements": [{**asdict(m), "summary": m.summary()}
                             for m in self.measurements],
            "not_tried": [{"effect": e, "reason": r} for e, r in self.not_tried],
            "frf_error_before": self.frf_error_before,
            "frf_error_after": self.frf_error_after,
            "reduced_chi2_before": self.before.reduced_chi2,
            "reduced_chi2_after": self.after.reduced_chi2,
            "delay_s_before": self.before.delay_s, "delay_s_after": self.after.delay_s,
            "declared": {"names": list(self.declared),
                         "before": self.declared_values("baseline"),
                         "after": self.declared_values("final")},
            "candidates": [{"step": t.step, "candidate": t.label, "effect": t.effect,
                            "options": t.options, "delta_bic": t.delta_bic,
                            "screen_chi2_drop": t.screen_drop, "fitted": t.fitted,
                            "parameters": t.parameters, "status": t.status}
                           for step in sorted({t.step for t in self.tried})
                           for t in self.ranked(step)],
            "modes": {"before": [asdict(m) for m in self.before.modes],
                      "after": [asdict(m) for m in self.after.modes]},
            "channels": {"before": [asdict(c) for c in self.before.channels],
                         "after": [asdict(c) for c in self.after.channels]},
            "pairs": [asdict(p) for p in self.before.pairs],
            "n_values": self.n, "n_independent": self.n_independent,
            "thresholds": list(self.thresholds),
            "settings": {k: v for k, v in asdict(self.settings).items()},
        })

    def to_pandas(self, table: str | None = None):
        """A table of the diagnosis.

        Parameters
        ----------
        table : {"found", "checks", "candidates", "channels", "modes", "pairs", \
"measurements", "summary"}, optional
            ``found`` (the default): the effects found, their values, standard deviations
            (where :attr:`uncertainty_holds`), evidence and alternatives; ``checks``: the
            model adequacy checks (mesh, modes the model lacks); ``measurements``: where
            an ambiguous finding's explanations differ most.

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        table = "found" if table is None else table
        if table not in TABLES:
            raise ValueError(f"table must be one of {', '.join(TABLES)}; got {table!r}")
        if table == "found":
            holds = self.uncertainty_holds
            return pd.DataFrame([{"effect": f.effect, "location": where(f.options, "-"),
                                  "x_m": f.x_m,
                                  **{f"{k}": v for k, v in f.parameters.items()},
                                  **{f"std {k}": (v if holds else float("nan"))
                                     for k, v in f.std.items()},
                                  "delta_bic": f.delta_bic,
                                  "or": "; ".join(f"{a.effect} ({where(a.options, '-')})"
                                                  for a in f.alternatives)}
                                 for f in self.found])
        if table == "checks":
            rows = []
            if self.mesh is not None:
                rows.append({"check": "mesh", "finding": self.mesh.summary(),
                             "ok": self.mesh.adequate})
            rows += [{"check": "mode the model lacks", "finding": m.summary(), "ok": False}
                     for m in self.missing]
            if self.mounting is not None:
                rows.append({"check": "mounting", "finding": self.mounting.summary(),
                             "ok": True})
            return pd.DataFrame(rows, columns=["check", "finding", "ok"])
        if table == "measurements":
            return pd.DataFrame([{**asdict(m), "summary": m.summary()}
                                 for m in self.measurements])
        if table == "candidates":
            rows = [{"step": t.step, "candidate": t.label, "effect": t.effect,
                     "delta_bic": t.delta_bic, "screen_chi2_drop": t.screen_drop,
                     "status": t.status, **{f"fit {k}": v for k, v in t.fitted.items()}}
                    for t in self.tried]
            df = pd.DataFrame(rows)
            return df.sort_values(["step", "delta_bic", "screen_chi2_drop"],
                                  ascending=[True, False, False], na_position="last",
                                  ignore_index=True) if not df.empty else df
        if table == "channels":
            rows = []
            for when, res in (("before", self.before), ("after", self.after)):
                rows += [{"model": when, **asdict(c)} for c in res.channels]
            return pd.DataFrame(rows)
        if table == "modes":
            rows = []
            for when, res in (("before", self.before), ("after", self.after)):
                rows += [{"model": when, **asdict(m)} for m in res.modes]
            return pd.DataFrame(rows)
        if table == "pairs":
            return pd.DataFrame([asdict(p) for p in self.before.pairs])
        return pd.DataFrame([{"model": when, "frf_error": r.frf_error, "chi2": r.chi2,
                              "reduced_chi2": r.reduced_chi2, "delay_s": r.delay_s}
                             for when, r in (("before", self.before), ("after", self.after))])

    def model_frfs(self, which: str = "final") -> list[np.ndarray]:
        """The model FRFs at each test's lines (as compared: signs applied, through the
        estimator), shape (n_lines, n_out, n_in) each."""
        f = self.final if which == "final" else self.baseline
        out, k = [], 0
        for t in self.tests:
            out.append(f.model[k:k + t.H.size].reshape(t.H.shape))
            k += t.H.size
        return out

    def plot(self, kind: str | None = None, ax=None, *, test: int = 0):
        """A figure of the diagnosis.

        Parameters
        ----------
        kind : {"residual", "frf", "candidates", "modes"}, optional
            ``residual`` (the default): the noise-weighted residual per channel against
            frequency, before and after; ``frf``: data, baseline and final model of one
            test; ``candidates``: delta BIC of the refitted candidates per step;
            ``modes``: frequency errors before and after against mode. Bands left out
            as modes the model lacks are shaded.
        ax : matplotlib.axes.Axes, optional
            Draw into these axes (figures of one panel only).
        test : int
            The test of ``frf`` and ``residual``.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from truthbench.diagnose.figures import plot_diagnosis

        return plot_diagnosis(self, kind, ax=ax, test=test)


def where(options: dict, empty: str = "the whole structure", x_m: float | None = None
          ) -> str:
    """An effect's place in words (``"station n12, direction z (x = 0.6 m)"``, with its
    coordinate ``x_m`` where it has one), ``empty`` for an effect with no place (a global
    one); the command line and the report use it too."""
    place = ", ".join(f"{k} {v}" for k, v in options.items()) or empty
    return place if x_m is None else f"{place} (x = {x_m:.4g} m)"
