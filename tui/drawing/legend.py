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
    """The entries packed into at most ``most`` rows of ``width`` cells, each whole; what does
    not fit is counted at the end of the last row ("+3").  An entry is cut ("…") only alone
    on its row (wider than the row): beside others it is counted (a cut one read "S >= 0.505 tar…")."""
    lines: list[list[Text]] = [[]]
    for k, entry in enumerate(found):
        piece = Text.assemble((entry.sample, entry.color or ""), " ", entry.label)
        if _joined([*lines[-1], piece]).cell_len <= width:
            lines[-1].append(piece)
            continue
        if lines[-1] and len(lines) < most:  # on the next row
            lines.append([])
            if piece.cell_len <= width:
                lines[-1].append(piece)
                continue
        return [*map(_joined, lines[:-1]), _counted(lines[-1], piece, len(found) - k - 1, width)]
    return [_joined(line) for line in lines if line]


def _joined(pieces: list[Text]) -> Text:
    return Text(GAP).join(pieces)


def _counted(row: list[Text], piece: Text, more: int, width: int) -> Text:
    """The last row, ``piece`` and ``more`` entries after it left out: counted at its end, its
    own last entries counted too until the count fits; ``piece`` cut alone on an empty row."""
    if row:
        more += 1
        while len(row) > 1 and _joined(row).cell_len + len(f" +{more}") > width:
            row, more = row[:-1], more + 1
    line = _joined(row or [piece])
    tail = f" +{more}" if more else ""
    line.truncate(max(width - len(tail), 1), overflow="ellipsis")
    line.append(tail, style="dim")
    return line
