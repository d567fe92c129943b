"""The report a person reads: well-formed tables, rounded numbers, no Python in the
text, figures with units, the same report from memory and from the file, and
report.html as a browser renders it."""

import re
import struct

from truthbench.campaign.results import CampaignResult
from truthbench.report.accuracy import figure_name, write_report

from .conftest import assert_renders_with_figures


def _tables(md: str):
    """Each markdown table as a list of rows of cells (split at unescaped bars)."""
    tables, block = [], []
    for line in md.splitlines() + [""]:
        if line.startswith("|"):
            block.append(line)
        elif block:
            tables.append(block)
            block = []
    out = []
    for block in tables:
        rows = []
        for line in block:
            inner = line.strip()
            assert inner.startswith("|") and inner.endswith("|"), line
            assert not inner.endswith("\\|"), line
            rows.append(re.split(r"(?<!\\)\|", inner[1:-1]))
        out.append(rows)
    return out


def test_every_markdown_table_is_well_formed(report_dir):
    md = (report_dir / "report.md").read_text()
    tables = _tables(md)
    assert len(tables) >= 8
    for rows in tables:
        n = len(rows[0])
        assert all(len(r) == n for r in rows), rows[0]
        assert all(re.fullmatch(r"-{3,}", c.strip()) for c in rows[1]), rows[1]
    headers = [[c.strip() for c in rows[0]] for rows in tables]
    assert ["updater", "parameter RMS error [%]", "mean abs. frequency error [%]",
            "smallest MAC", "failed trials"] in headers
    # a bar inside a cell (a test named "fourth | bar") is escaped, not a column
    assert "| fourth \\| bar |" in md


def _significant(cell: str) -> int:
    mantissa = cell.lstrip("-").split("e")[0].replace(".", "").lstrip("0")
    return len(mantissa)


def test_numbers_are_rounded_and_no_python_leaks(report_dir):
    md = (report_dir / "report.md").read_text()
    for rows in _tables(md):
        header = [c.strip() for c in rows[0]]
        for row in rows[2:]:
            for head, cell in zip(header, (c.strip() for c in row), strict=True):
                if re.fullmatch(r"-?\d+\.\d+(e[+-]\d+)?", cell):
                    if "[%]" in head:
                        assert re.fullmatch(r"-?\d+\.\d{1,2}", cell), (head, cell)
                    elif "MAC" in head or "coherence" in head:  # in [0, 1], 4 decimals
                        assert re.fullmatch(r"[01]\.\d{4}", cell), (head, cell)
                    else:
                        assert _significant(cell) <= 4, (head, cell)
    for leak in ("['", "True", "False", "None", "e+10"):
        assert leak not in md, leak
    assert not re.search(r"trial 0\d{3}", md, re.I)  # trials by number, not HDF5 key
    assert "converged" in md
    assert '"Modeling: Limitations and Realities"' in md and "1998" in md


def test_report_figures(report_dir, report_result):
    md = (report_dir / "report.md").read_text()
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    trial = report_result.trials[0]
    expected = {figure_name(r.name) for r in trial.tests} | {
        "poles.png", "frf_band.png", "calibration.png"}
    assert set(images) == expected
    assert figure_name("fourth | bar") == "frf_fourth___bar.png"
    for name in images:
        data = (report_dir / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        width, height = struct.unpack(">II", data[16:24])
        assert 300 < width <= 1600 and 200 < height <= 1200, (name, width, height)


def test_same_report_from_memory_and_from_the_file(report_result, report_dir, tmp_path):
    path = report_result.save(tmp_path / "results.h5")
    write_report(CampaignResult.load(path), tmp_path, results_path=report_dir / "results.h5")

    def body(p):
        return [line for line in p.read_text().splitlines()
                if not line.startswith("- truthbench ")
                and not re.match(r"\| (simulate|frf|identify|bound|update|score) \|", line)]

    assert body(tmp_path / "report.md") == body(report_dir / "report.md")


def test_single_test_file_report(small_dict, tmp_path):
    from truthbench.campaign.runner import simulate_one
    from truthbench.campaign.spec import parse_campaign
    from truthbench.campaign.store import write_test_record

    spec = parse_campaign(small_dict)
    path = write_test_record(simulate_one(spec, 0, 1), tmp_path / "one.h5", spec=spec,
                             seed=1, trial=0, injected=["time_delay:delay_s=0.002"])
    md = write_report(CampaignResult.load(path), tmp_path).read_text()
    assert "injected effects: `time_delay:delay_s=0.002`" in md
    assert "![FRFs of shaker_quarter](frf_shaker_quarter.png)" in md
    assert "## Parameter errors" not in md


def test_report_html_renders_in_chromium(report_dir, browser):
    """Every figure loads, and nothing is wider than the window (wide tables scroll
    in their own box, at most twice the window)."""
    r = browser.probe(report_dir / "report.html")
    n_md = len(re.findall(r"!\[", (report_dir / "report.md").read_text()))
    assert r["images"] == n_md and r["broken"] == []
    assert r["page"] <= r["viewport"] and r["wide"] == []
    assert r["tables"] <= 2.0


def test_report_html_screenshot_shows_every_figure(report_dir, browser):
    """The screenshot of the whole report is not blank, and every figure's box on it
    holds a drawing (not an empty or broken image)."""
    n_md = len(re.findall(r"!\[", (report_dir / "report.md").read_text()))
    assert_renders_with_figures(browser, report_dir / "report.html", n_md)
