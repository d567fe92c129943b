"""The one result protocol (truthbench.presentation): every result a person looks at has
``to_pandas(table=None)`` and ``plot(kind=None, ax=None) -> Figure``, every table and
figure it names works, and library code never chooses a matplotlib backend."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import truthbench
from truthbench.presentation import Presentable, choose, figure_axes

SRC = Path(truthbench.__file__).parent


def _modal_frf():
    """Two modes, 3 outputs, 1 input, displacement FRF."""
    f = np.arange(0.5, 60.0, 0.25)
    s = 2j * np.pi * f[:, None, None]
    phi = np.array([[1.0, 0.6], [0.5, -1.0], [-0.7, 0.4]])
    H = np.zeros((f.size, 3, 1), complex)
    for r, (fn, z) in enumerate(((12.0, 0.02), (31.0, 0.01))):
        w = 2 * np.pi * fn
        H += np.outer(phi[:, r], phi[0, r])[None] / (s**2 + 2 * z * w * s + w**2)
    return f, H


def _frfdata():
    from truthbench.measure import Channel, FRFData

    f, H = _modal_frf()
    return FRFData("t", f, H, tuple(Channel(f"y{k}", "displacement", "z") for k in range(3)),
                   (Channel("u", "force", "z"),), coherence=np.full(H.shape, 0.9))


def _results() -> dict[str, object]:
    """One small instance of every result class, by class name."""
    from truthbench.campaign.coverage import coverage_summary
    from truthbench.campaign.frf_band_stage import FrfBandStage
    from truthbench.campaign.uncertainty_stage import UncertaintyStage
    from truthbench.identify import (
        IdentifyReport,
        ModalParameters,
        identify_frfs,
        identify_plscf,
        pair_modes,
        peak_picking,
    )
    from truthbench.io import TimeRecord, ladisk_beam_impact
    from truthbench.measure import estimate_frf
    from truthbench.simulate.nonlinear import NonlinearResult
    from truthbench.studies import DampingSmoothingStudy, discretization_study
    from truthbench.uncertainty import calibration_curve, frf_uncertainty, uncertainty_model
    from truthbench.update import SensitivityResult, UpdateResult

    rng = np.random.default_rng(0)
    f, H = _modal_frf()
    data = _frfdata()
    plscf = identify_plscf(f, H, max_order=10)
    modal = plscf.modal
    dataset = identify_frfs(data, max_order=10)
    update = dict(names=("E_pa", "delay_s"), initial=np.array([7e10, 0.0]),
                  values=np.array([7.1e10, 1e-4]),
                  history=np.array([[7e10, 0.0], [7.08e10, 8e-5], [7.1e10, 1e-4]]),
                  cost_history=np.array([1.0, 0.1, 0.01]), singular_values=np.array([2., 1.]),
                  condition_number=2.0, correlation=np.array([[1.0, 0.3], [0.3, 1.0]]),
                  converged=True)
    tests = np.array([[10.0, 0.02], [10.1, 0.021], [9.95, 0.019], [10.05, 0.02]])
    x = rng.standard_normal((1, 2048))
    H_tests = H[None] * (1 + 0.01 * (rng.standard_normal((4, 1, 1, 1))
                                    + 1j * rng.standard_normal((4, 1, 1, 1))))
    band = frf_uncertainty(H_tests, freq_hz=f)
    mu, sigma = np.array([50.0, 0.01]), np.array([0.25, 0.001])
    stages = []
    for _ in range(8):
        truth = mu + sigma * rng.standard_normal((5, 2))
        um = uncertainty_model(truth[:4], mu, covariance="diagonal")
        hold = np.r_[np.zeros(4, bool), True]
        stages.append(UncertaintyStage(("f1_hz", "zeta1"), mu, truth, truth, um.mean, um.std,
                                       um.bound, um.contains(truth), np.array([0]), hold))
    n = 64
    return {
        "FRFData": data,
        "FRFEstimate": estimate_frf(x, x * 2.0, 128.0, n_averages=4),
        "ModalParameters": modal,
        "ModePairing": pair_modes(modal, ModalParameters(modal.freq_hz * 1.01,
                                                         modal.damping_ratio, modal.shapes)),
        "StabilizationDiagram": plscf.diagram,
        "PLSCFResult": plscf,
        "PeakPickingResult": peak_picking(f, H, n_modes=2),
        "DatasetIdentification": dataset,
        "IdentifyReport": IdentifyReport(Path("x.uff"), "uff", "plscf", 10, (dataset,)),
        "UpdateResult": UpdateResult(**update),
        "SensitivityResult": SensitivityResult(**update, method="sensitivity"),
        "UncertaintyModel": uncertainty_model(tests, tests.mean(axis=0), names=["f_hz", "z"]),
        "FrfUncertainty": band,
        "CalibrationCurve": calibration_curve(rng.standard_normal((20, 4, 2))),
        "NonlinearResult": NonlinearResult(
            y=rng.standard_normal((2, n)), f_nl=rng.standard_normal((1, n)),
            displacement=np.full((1, n), np.nan), velocity=rng.standard_normal((1, n)),
            stuck=np.zeros((1, n), bool), n_stick_events=np.array([2]),
            n_reversals=np.array([3]), dt=0.01),
        "TimeRecord": TimeRecord(rng.standard_normal((2, n)), 0.01, ("force", "acc"),
                                 ("N", "m/s^2")),
        "ImpactRecord": ladisk_beam_impact(),
        "DiscretizationStudy": discretization_study(max_elements=3),
        "DampingSmoothingStudy": DampingSmoothingStudy(  # readings as a study gives them
            np.array([100, 1000]), ("bartlett",), ("amplification", "half_power"),
            0.01 * (1 + 0.1 * rng.random((1, 2, 2, 3))), 10.0 + 0.01 * rng.random((1, 2, 3)),
            0.01, 10.0, 200.0, 10, 0.5, 0, "exact"),
        "CoverageSummary": coverage_summary(stages, 3.0),
        "FrfBandStage": FrfBandStage(("a", "b"), band, np.ones(f.size, bool),
                                     {"initial": 0.5}, ("y0", "y1", "y2"), ("u",)),
    }


@pytest.fixture(scope="module")
def results():
    return _results()


def _subclasses(cls):
    out = set()
    for sub in cls.__subclasses__():
        out |= {sub} | _subclasses(sub)
    return out


def test_every_result_class_is_checked_here(results):
    for mod in pkgutil.walk_packages([str(SRC)], "truthbench."):
        if not mod.name.startswith(("truthbench.cli", "truthbench.__main__")):
            importlib.import_module(mod.name)
    names = {c.__name__ for c in _subclasses(Presentable)}
    assert names - set(results) == set(), "results without an instance in this test"


def test_tables_and_figures_by_name(results):
    for name, result in results.items():
        assert isinstance(result, Presentable), name
        assert result.TABLES and result.PLOTS, name
        default = result.to_pandas()
        assert isinstance(default, pd.DataFrame), name
        assert default.equals(result.to_pandas(result.TABLES[0])), name
        for table in result.TABLES:
            assert isinstance(result.to_pandas(table), pd.DataFrame), (name, table)
        with pytest.raises(ValueError, match=f"{type(result).__name__}: unknown table 'nope'"):
            result.to_pandas("nope")
        for kind in result.PLOTS:
            fig = result.plot(kind)
            assert isinstance(fig, Figure) and fig.axes, (name, kind)
            plt.close(fig)
        with pytest.raises(ValueError, match=f"{type(result).__name__}: unknown kind 'nope'; "
                                             f"expected one of {result.PLOTS[0]!r}"):
            result.plot("nope")


def test_a_figure_draws_into_the_callers_axes(results):
    """Given enough axes, plot draws there and returns their figure (nothing new)."""
    for name, result in results.items():
        for kind in result.PLOTS:
            fig = result.plot(kind)
            n = len([a for a in fig.axes if a.get_label() != "<colorbar>"])
            plt.close(fig)
            mine, axes = plt.subplots(n + 1, 1, squeeze=False)  # one to spare
            before = len(plt.get_fignums())
            assert result.plot(kind, ax=axes.ravel()[:max(n, 1)] if n > 1
                               else axes[0, 0]) is mine, (name, kind)
            assert len(plt.get_fignums()) == before, (name, kind)
            plt.close(mine)


def test_choose_and_figure_axes():
    assert choose(1, "table", None, ("a", "b")) == "a"
    with pytest.raises(ValueError, match="int: unknown table 'c'; expected one of 'a', 'b'"):
        choose(1, "table", "c", ("a", "b"))
    fig, axes = figure_axes(None, 2, 3)
    assert axes.shape == (6,) and axes[0].figure is fig
    with pytest.raises(ValueError, match="this figure has 6 panels; got 2 axes"):
        figure_axes(axes[:2], 2, 3)
    plt.close(fig)


def test_library_code_never_chooses_a_backend():
    """matplotlib.use only in the command line and the report writers."""
    allowed = ("cli", "report")
    pending = {"diagnose/figures.py"}  # the diagnosis's figures: the lead's to conform
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.split("/")[0] in allowed or rel in pending:
            continue
        if re.search(r"matplotlib\.use\(|\.use\(\s*[\"']Agg", path.read_text()):
            found.append(rel)
    assert found == []
