"""diagnosis.html as a browser renders it: a diagnosis of simulated data with an added
mass the model lacks, written by the report writer, opened in headless Chromium."""

import re

import pytest

from truthbench.campaign.runner import simulate_one
from truthbench.campaign.spec import parse_campaign
from truthbench.diagnose import diagnose
from truthbench.effects import effect_from_inject
from truthbench.report.diagnosis import write_diagnosis

from .conftest import assert_renders_with_figures, small_quickstart


@pytest.fixture(scope="module")
def diagnosis_page(tmp_path_factory):
    """diagnosis.html of the small quickstart (two tests, three accelerometers) with
    50 g added at three quarters of the tube, two candidate effects."""
    spec = parse_campaign(small_quickstart())
    mass = [effect_from_inject("added_mass:station=three_quarter,mass_kg=0.05")]
    data = [simulate_one(spec, 0, j, None, mass).frf for j in range(len(spec.tests))]
    diag = diagnose(data, spec.make_plant(), spec.nominal_parameters(),
                    spec.update.parameters, candidates=("added_mass", "time_delay"),
                    max_effects=1)
    assert [f.effect for f in diag.found] == ["added_mass"]
    return write_diagnosis(diag, tmp_path_factory.mktemp("diagnosis"))


def test_diagnosis_html_renders_with_its_figures(diagnosis_page, browser):
    """Every figure of diagnosis.md loads in the page, the page is no wider than the
    window, and the screenshot shows a drawing in every figure's box."""
    md = diagnosis_page.with_suffix(".md").read_text()
    n_md = len(re.findall(r"!\[", md))
    assert n_md >= 4  # residual and FRF per test, candidates, modes
    r = assert_renders_with_figures(browser, diagnosis_page, n_md)
    assert r["page"] <= r["viewport"] and r["wide"] == []
