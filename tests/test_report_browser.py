"""The HTML report in a real browser (issue 40, section 3): Debian's Chromium renders it
headless; every figure is loaded and drawn (its pixels read in the screenshot: the
plot lines' colours are there, as many figures as the report holds), no text is cut
(no element's content wider than its box, no page wider than the window), and
printing it gives a PDF whose page count is what its figures and tables need.
Skipped where Chromium is missing, except under CI=true (`.ci/run` installs it)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from tui.cli import main

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        CHROMIUM is None and os.environ.get("CI") != "true",
        reason="no chromium here (apt-get install chromium; .ci/run installs it)",
    ),
]
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-pdf-header-footer"]
CHECK = """<script>
addEventListener("load", () => {
  const boxes = [...document.querySelectorAll("h1,h2,h3,p,td,th,pre,figcaption,.note")];
  const cut = boxes.filter(e => e.scrollWidth > e.clientWidth + 1).map(e => e.textContent.slice(0, 40));
  const images = [...document.images].map(i => [i.complete, i.naturalWidth, Math.round(i.getBoundingClientRect().width)]);
  document.body.dataset.check = JSON.stringify({cut, images, wide: document.documentElement.scrollWidth > innerWidth});
});
</script></body>"""
BLUE = np.array([31, 119, 180]) / 255  # matplotlib's first line colour (the final design)


def _chromium(*args: str) -> subprocess.CompletedProcess:
    assert CHROMIUM is not None, "CI=true: chromium must be installed (.ci/run installs it)"
    return subprocess.run([CHROMIUM, *FLAGS, *args], capture_output=True, text=True, timeout=120, check=True)


@pytest.fixture(scope="module")
def report(ran_lag_lead) -> Path:
    """The HTML report of the lag-lead after four iterations (tests/conftest.py)."""
    assert main(["report", str(ran_lag_lead), "--format", "html", "--out", str(ran_lag_lead.parent)]) == 0
    return ran_lag_lead.parent / "lag_lead.html"


def test_every_figure_loads_and_no_text_is_cut(report, tmp_path):
    checked = tmp_path / "checked.html"
    checked.write_text(report.read_text().replace("</body>", CHECK, 1))
    dom = _chromium("--window-size=1200,900", "--virtual-time-budget=5000", "--dump-dom", checked.as_uri()).stdout
    found = json.loads(re.search(r'data-check="([^"]*)"', dom).group(1).replace("&quot;", '"'))
    assert len(found["images"]) == 7  # convergence, Bode, Nyquist, Nichols, S/T, root locus, step
    assert all(complete and width > 300 and shown > 300 for complete, width, shown in found["images"])
    assert found["cut"] == [] and not found["wide"]


@pytest.mark.long
def test_the_screenshot_shows_the_figures(report, tmp_path):
    shot = tmp_path / "page.png"
    _chromium("--window-size=1200,9000", f"--screenshot={shot}", report.as_uri())
    pixels = imread(shot)[..., :3]
    blue = np.all(np.abs(pixels - BLUE) < 0.06, axis=-1)
    rows = np.flatnonzero(blue.sum(axis=1) > 0)
    assert blue.sum() > 3000  # the plotted lines, drawn
    bands = np.split(rows, np.flatnonzero(np.diff(rows) > 40) + 1)  # vertical runs of blue: figures apart
    assert len(bands) >= 6


def test_printing_gives_a_clean_pdf(report, tmp_path):
    pdf = tmp_path / "report.pdf"
    _chromium(f"--print-to-pdf={pdf}", report.as_uri())
    pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf.read_bytes()))
    # 7 figures at most 120 mm high on A4 (267 mm of page): at least 4 pages for them, and the
    # first pages' tables; no more than a page a figure beside the text's 3
    assert 5 <= pages <= 10
