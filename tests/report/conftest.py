"""A small campaign with every report section: two trials, four tests (three share an
input: an FRF band; one held out: calibration), both updaters."""

import tomllib
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def small_quickstart() -> dict:
    """The quickstart with short records (as tests/campaign/conftest.py): 8 elements,
    three accelerometers, 4 s of 4 averages, the second shaker at the far end."""
    d = tomllib.loads((ROOT / "campaigns" / "quickstart.toml").read_text())
    d["plant"]["n_elements"] = 8
    d["sensors"] = [s for s in d["sensors"] if s["station"] != "quarter"]
    for t in d["tests"]:
        t.update(record_s=4.0, averages=4, oversample=2)
        if t["actuators"][0]["station"] == "quarter":
            t["actuators"] = [{"station": "end_b", "direction": "z"}]
    return d


@pytest.fixture(scope="session")
def report_result():
    from truthbench.campaign.runner import run_campaign
    from truthbench.campaign.spec import parse_campaign

    d = small_quickstart()
    d["tests"] += [{**d["tests"][0], "name": "third", "level_rms": 4.0},
                   {**d["tests"][0], "name": "fourth | bar", "level_rms": 3.0}]
    d["update"]["method"] = ["finite_difference", "sensitivity"]
    d["uncertainty"] = {"holdout": ["fourth | bar"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sensitivity method on noisy 4 s records
        return run_campaign(parse_campaign(d, source="small.toml"), trials=2)


@pytest.fixture(scope="session")
def report_dir(report_result, tmp_path_factory):
    from truthbench.report.accuracy import write_report

    out = tmp_path_factory.mktemp("report")
    write_report(report_result, out, results_path=out / "results.h5")
    return out


@pytest.fixture
def small_dict():
    return small_quickstart()


CHROMIUM = Path("/usr/bin/chromium")
# what headless Chromium needs on a machine with no network but the package registries:
# no sandbox as root, no GPU, and no background connections (refused here, many at once)
CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--hide-scrollbars",
                  "--force-device-scale-factor=1", "--virtual-time-budget=10000")
WIDTH = 1280

PROBE = """<script>
window.addEventListener('load', () => {
  const vw = document.documentElement.clientWidth;
  const imgs = [...document.images];
  const right = e => e.getBoundingClientRect().right;
  const box = e => { const r = e.getBoundingClientRect();
    return [r.left + scrollX, r.top + scrollY, r.width, r.height]; };
  const r = {images: imgs.length, viewport: vw,
    broken: imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt),
    boxes: imgs.map(box),
    page: document.documentElement.scrollWidth,
    height: document.documentElement.scrollHeight,
    wide: [...document.querySelectorAll('img, p, h1, h2, h3, ul, div.table')]
      .filter(e => right(e) > vw + 1).map(e => e.tagName),
    tables: Math.max(...[...document.querySelectorAll('table')].map(right)) / vw};
  const pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = JSON.stringify(r);
  document.body.appendChild(pre);
});
</script>"""


class Browser:
    """Headless Chromium on a self-contained HTML page: its layout as the page's own
    script measures it after loading (``probe``), and a screenshot (``screenshot``)."""

    def __init__(self, tmp_path: Path):
        self.tmp = tmp_path
        self.runs = 0

    def _run(self, url: str, *args: str, height: int = 900):
        import subprocess

        self.runs += 1
        profile = self.tmp / f"chromium-profile-{self.runs}"  # a fresh one every start
        return subprocess.run(
            [str(CHROMIUM), *CHROMIUM_FLAGS, f"--user-data-dir={profile}",
             f"--window-size={WIDTH},{height}", *args, url],
            capture_output=True, text=True, timeout=180)

    def probe(self, page: Path) -> dict:
        """The probe's measurements of ``page`` (a copy with the probe script added):
        image count, images not loaded, image boxes in page pixels, page width and
        height, elements wider than the window, widest table over the window."""
        import html
        import json
        import re

        probed = self.tmp / f"probe-{page.name}"
        probed.write_text(page.read_text().replace("</body>", PROBE + "</body>"))
        run = self._run(probed.as_uri(), "--dump-dom")
        found = re.search(r'<pre id="probe">(.*?)</pre>', run.stdout, re.S)
        assert found, run.stderr[-2000:]
        return json.loads(html.unescape(found.group(1)))

    def screenshot(self, page: Path, height: int):
        """The page as a window of ``WIDTH`` x ``height`` pixels shows it: an RGB array
        (height, width, 3) of uint8; the PNG stays in the test's folder."""
        import numpy as np
        from PIL import Image

        png = self.tmp / f"{page.stem}.png"
        run = self._run(page.as_uri(), f"--screenshot={png}", height=height)
        assert png.exists(), run.stderr[-2000:]
        return np.asarray(Image.open(png).convert("RGB"))


@pytest.fixture
def browser(tmp_path):
    """Chromium if installed; without it the test skips, or fails where
    ``TRUTHBENCH_BROWSER=required`` (``.ci/run``, which installs it)."""
    import os

    if not CHROMIUM.exists():
        message = f"{CHROMIUM} is not installed: the HTML is not rendered"
        if os.environ.get("TRUTHBENCH_BROWSER") == "required":
            pytest.fail(message + " (TRUTHBENCH_BROWSER=required)")
        pytest.skip(message)
    return Browser(tmp_path)


def painted_fraction(pixels, box=None) -> float:
    """Fraction of the pixels (inside ``box`` = left, top, width, height, when given)
    that differ from the most common colour: 0 for a blank area."""
    import numpy as np

    if box is not None:
        left, top, width, height = (int(round(v)) for v in box)
        pixels = pixels[top:top + height, left:left + width]
    flat = pixels.reshape(-1, 3)
    if flat.size == 0:
        return 0.0
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    return 1.0 - counts.max() / len(flat)


def assert_renders_with_figures(browser: Browser, page: Path, n_figures: int) -> dict:
    """``page`` renders in Chromium: every figure's <img> loaded, and the screenshot of
    the whole page is not blank and shows something drawn inside every figure's box."""
    r = browser.probe(page)
    assert r["images"] == n_figures and r["broken"] == [], r
    pixels = browser.screenshot(page, r["height"])
    assert pixels.shape[:2] == (r["height"], WIDTH)
    assert painted_fraction(pixels) > 0.02
    for k, box in enumerate(r["boxes"]):
        assert box[2] > 200 and box[3] > 150, (k, box)
        assert painted_fraction(pixels, box) > 0.01, (k, box)
    return r
