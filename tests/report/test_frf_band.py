"""The report's FRF band: groups comparable tests, limits to the excited band, scores
the models."""

import numpy as np

from truthbench.report.frf_band import frf_band, plot_frf_band


def _results(n_tests, seed=0):
    rng = np.random.default_rng(seed)
    f = np.arange(0, 101) * 1.0
    s = 2j * np.pi * f
    G = (1.0 / (s**2 + 2 * 0.02 * 2 * np.pi * 40 * s + (2 * np.pi * 40) ** 2))[:, None, None]
    tests, spec_tests = {}, []
    for j in range(n_tests):
        H = G * (1 + 0.02 * (rng.standard_normal(G.shape) + 1j * rng.standard_normal(G.shape)))
        tests[f"t{j}"] = {"attrs": {"input_labels": np.array([b"a.z"]),
                                    "output_labels": np.array([b"b.z.acc"])},
                          "freq_hz": f, "H": H}
        spec_tests.append({"name": f"t{j}", "band_hz": [10.0, 90.0]})
    tests["other"] = {"attrs": {"input_labels": np.array([b"c.z"]),
                                "output_labels": np.array([b"b.z.acc"])}, "freq_hz": f, "H": G}
    spec_tests.append({"name": "other", "band_hz": [10.0, 90.0]})
    model = {"t0": {"H_initial": 1.5 * G[1:], "H_updated": G[1:]}}
    trial = {"attrs": {"status": "ok"}, "tests": tests, "model": model}
    return {"attrs": {"spec": {"tests": spec_tests}}, "trials": {"0000": trial}}


def test_band_over_comparable_tests_scores_the_models(tmp_path):
    fb = frf_band(_results(6))
    assert fb.tests == ("t0", "t1", "t2", "t3", "t4", "t5")  # not "other" (another input)
    assert fb.band.freq_hz[0] == 10.0 and fb.band.freq_hz[-1] == 90.0  # excited band only
    assert fb.inside["updated"] > 0.95 and fb.inside["initial"] < 0.2
    assert plot_frf_band(fb, tmp_path / "b.png").stat().st_size > 10_000


def test_fewer_than_three_comparable_tests_give_no_band():
    assert frf_band(_results(2)) is None
