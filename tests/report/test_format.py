"""Rounding numbers for a person, and markdown tables that stay tables."""

import pandas as pd
import pytest

from truthbench.report import format as fmt
from truthbench.report.html import markdown_to_html, split_row


@pytest.mark.parametrize("value, text", [
    (7.1656e10, "7.166e+10"), (2619.0, "2619"), (2620.34, "2620"), (68.9, "68.90"),
    (71656.0, "71656"), (351342.0, "3.513e+05"), (0.002197, "0.002197"),
    (8.3202e-05, "8.320e-05"), (-0.127582, "-0.1276"), (0.0, "0"), (float("nan"), "-")])
def test_sig(value, text):
    assert fmt.sig(value) == text


@pytest.mark.parametrize("value, text", [
    (-0.000348779, "0.00"), (3.846153, "3.85"), (-0.241903, "-0.24"), (114.028, "114.03"),
    (float("nan"), "-")])
def test_pct(value, text):
    assert fmt.pct(value) == text


def test_si_scale():
    assert fmt.si_scale([68.9e9, 71.656e9], "Pa") == (1e9, "GPa")
    assert fmt.si_scale([0.00165], "m") == (1e-3, "mm")
    assert fmt.si_scale([2700.0], "kg/m^3") == (1.0, "kg/m^3")
    assert fmt.si_scale([200.0], "N/m") == (1.0, "N/m")


def test_bars_in_cells_are_escaped_and_read_back(tmp_path):
    df = pd.DataFrame({"a": ["x | y"], "b": [1.5]})
    md = fmt.markdown(fmt.table(df, [("a", "mean |err|", str), ("b", "b [%]", fmt.pct)]))
    head, sep, row = md.splitlines()
    assert head == "| mean \\|err\\| | b [%] |" and row == "| x \\| y | 1.50 |"
    assert split_row(row) == ["x | y", "1.50"]
    page = markdown_to_html(md, tmp_path)
    assert "<th>mean |err|</th><th>b [%]</th>" in page
    assert "<td>x | y</td><td>1.50</td>" in page
    assert fmt.markdown(pd.DataFrame()) == "(none)\n"
