"""A figure's legend, drawn in rows under the plot (never over its data): one entry per
labelled series that has a point in view, each with a sample of its marker, so curves
are told apart without colour."""

from __future__ import annotations

from dataclasses import dataclass

from rich.text import Text

from tui.figures.data import Figure, Series, in_view

RICH_COLORS = {"gray": "grey50", "orange": "orange1"}  # plotext's colour names that rich spells otherwise
SAMPLES = {"braille": "⠒⠒", "dot": "••", "hd": "▀▀", "fhd": "▀▀", "sd": "██"}
GAP = "  "


@dataclass(frozen=True)
class Entry:
    sample: str
    label: str
    color: str | None


def sample(series: Series) -> str:
    """Two cells of what the series is drawn with (a scatter's marker once)."""
    glyph = SAMPLES.get(series.marker, series.marker[:1] or "?")
    return glyph[:1] if series.scatter else (glyph * 2)[:2]


def entries(figure: Figure) -> list[Entry]:
    """The legend of a figure and its panels: each label once, in drawing order."""
    out: dict[str, Entry] = {}
    for fig in [figure, *figure.panels]:
        for s in fig.series:
            if s.label and s.label not in out and in_view(s, fig):
                out[s.label] = Entry(sample(s), s.label, RICH_COLORS.get(s.color or "", s.color))
    return list(out.values()) if figure.legend else []


def rows(found: list[Entry], width: int, most: int) -> list[Text]:
    """The entries packed into at most ``most`` rows of ``width`` cells; what does not fit
    is counted at the end of the last row ("+3")."""
    lines: list[Text] = []
    line = Text()
    for k, entry in enumerate(found):
        piece = Text.assemble((entry.sample, entry.color or ""), " ", entry.label)
        room = width - line.cell_len - (len(GAP) if line.cell_len else 0)
        if piece.cell_len <= room:
            line.append_text(Text(GAP) + piece if line.cell_len else piece)
            continue
        if line.cell_len and len(lines) + 1 < most:
            lines.append(line)
            line = Text()
            if piece.cell_len <= width:
                line.append_text(piece)
                continue
        line.append_text(Text(GAP if line.cell_len else "") + piece)
        line.truncate(width, overflow="ellipsis")
        more = len(found) - k - 1
        if more:
            tail = f" +{more}"
            line.truncate(max(width - len(tail), 1), overflow="ellipsis")
            line.append(tail, style="dim")
        break
    if line.cell_len:
        lines.append(line)
    return lines[:most]
