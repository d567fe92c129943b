"""Resource estimates against what is measured: the report's memory per trial."""

import dataclasses
import tracemalloc
import warnings

import pytest

from truthbench.campaign.plan import CampaignPlan
from truthbench.campaign.resources import estimate_resources
from truthbench.campaign.runner import run_campaign
from truthbench.campaign.spec import parse_campaign
from truthbench.campaign.summary import TrialSummary, trial_summary
from truthbench.campaign.tables import Tables

from .conftest import full_dict


@pytest.mark.slow
def test_the_report_estimate_covers_the_tables_memory_per_trial():
    """The report keeps every trial's rows (Tables): the estimate's memory per trial is
    at least what 400 trials' tables hold (tracemalloc, numpy's arrays included), and
    not more than four times it."""
    spec = parse_campaign(full_dict())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sensitivity method on noisy 4 s records
        result = run_campaign(spec, trials=1)
    (tr,) = result.trials
    text = trial_summary(spec, tr).to_json()
    n = 400
    tables = Tables(spec)
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    for k in range(n):  # fresh objects per trial, as read from a file
        tables.add(dataclasses.replace(TrialSummary.from_json(text, tr.seconds), trial=k))
    measured = (tracemalloc.get_traced_memory()[0] - before) / n
    tracemalloc.stop()
    assert len(tables.frame("parameters")) == n * 4  # two parameters, two updaters
    plan = CampaignPlan.compile(spec)
    a, b = estimate_resources(plan, 1000), estimate_resources(plan, 2000)
    per_trial = (b.report_mb - a.report_mb) * 1e6 / 1000
    assert measured <= per_trial <= 4 * measured, (measured, per_trial)
