"""`loopcraft report FILE --format html|md --out DIR`: the design report, parsed, and
every embedded PNG decoded and read back by matplotlib: a valid image of plausible
size whose pixels are not uniform (tests/test_report_browser.py renders it in a real
browser)."""

from __future__ import annotations

import base64
import html
import io
import shutil
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from tui.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "sessions" / "examples"


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.headings, self.external, self._tag = [], [], [], None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self._tag = tag
        if tag == "img":
            self.images.append(attrs["src"])
        if tag in ("link", "script") or (tag == "img" and not attrs["src"].startswith("data:")):
            self.external.append(tag)

    def handle_data(self, data):
        if self._tag in ("h1", "h2", "h3") and data.strip():
            self.headings.append(data.strip())

    def handle_endtag(self, tag):
        self._tag = None


def _check_png(data: bytes) -> None:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pixels = imread(io.BytesIO(data), format="png")
    assert pixels.ndim == 3 and pixels.shape[0] >= 300 and pixels.shape[1] >= 500
    assert float(np.std(pixels[..., :3])) > 0.01  # a drawing, not a blank canvas


@pytest.mark.slow
def test_html_is_self_contained_with_valid_figures(ran_lag_lead, tmp_path, capsys):
    assert main(["report", str(ran_lag_lead), "--format", "html", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "lag_lead.html").read_text()
    parsed = _Collect()
    parsed.feed(text)
    assert parsed.external == []
    prefix = "data:image/png;base64,"
    # convergence, and Bode, Nyquist, Nichols, S/T, root locus, step of the one condition
    assert len(parsed.images) == 7 and all(src.startswith(prefix) for src in parsed.images)
    for src in parsed.images:
        _check_png(base64.b64decode(src[len(prefix) :], validate=True))
    for heading in (
        "Flight conditions and targets",
        "Compensator",
        "Constraints",
        "Loop analysis at the design",
        "Initial and final design",
        "Convergence history",
        "Figures",
        "Appendix: the algorithm's report",
        "Condition nominal",
        "Parameters",
        "Targets",
    ):
        assert heading in parsed.headings
    for word in ("T1", "phase_margin_deg", "gain_margin_db", "crossover_frequency", "UNMET", "met"):
        assert word in text
    capsys.readouterr()
    assert main(["report", str(ran_lag_lead)]) == 0  # the algorithm's own text: the appendix
    own = capsys.readouterr().out.strip()
    assert html.escape(own) in text


@pytest.mark.long
@pytest.mark.slow
def test_markdown_writes_its_pngs_beside_it(tmp_path):
    """Three flight conditions at the start: Bode, Nyquist, Nichols, S/T, root locus and
    step of each."""
    source = tmp_path / "vehicle.json"
    shutil.copy(EXAMPLES / "coebra_launch_vehicle.json", source)
    out = tmp_path / "out"
    assert main(["report", str(source), "--format", "md", "--out", str(out)]) == 0
    text = (out / "vehicle.md").read_text()
    pngs = sorted(out.glob("*.png"))
    assert len(pngs) == 18
    for png in pngs:
        assert f"]({png.name})" in text
        _check_png(png.read_bytes())
    for name in ("switch-in", "max-q", "switch-out"):
        assert f"### Condition {name}" in text
    assert "> **Note.** Report 003, Appendix B" in text  # the session's notes, shown as a note
    assert "No iteration has run yet." in text


def test_report_options_are_checked(ran_lag_lead, tmp_path, capsys):
    assert main(["report", str(ran_lag_lead), "--out", str(tmp_path)]) == 2
    assert "--out: only with --format html or md" in capsys.readouterr().err
    (tmp_path / "file").write_text("x")
    assert main(["report", str(ran_lag_lead), "--format", "html", "--out", str(tmp_path / "file")]) == 2
    assert "not a folder" in capsys.readouterr().err
