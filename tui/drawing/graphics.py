"""Which graphics protocol the terminal speaks (sixel, or kitty's terminal graphics
protocol), asked once before the app takes the terminal: textual-image queries the
terminal when it is imported and cannot once Textual runs.  None: text plots (tmux
without passthrough, plain SSH, a pipe)."""

from __future__ import annotations

from dataclasses import dataclass

from textual.widget import Widget


@dataclass(frozen=True)
class Graphics:
    """The terminal's graphics: the protocol's name, the image widget that speaks it and
    the size of a cell in pixels."""

    protocol: str
    widget: type[Widget]
    cell: tuple[int, int]


def probe() -> Graphics | None:
    """The terminal's graphics protocol (None: the terminal shows none)."""
    from textual_image import renderable
    from textual_image.widget import SixelImage, TGPImage, get_cell_size  # (importing it asks the terminal)

    found = {renderable.SixelImage: ("sixel", SixelImage), renderable.TGPImage: ("kitty", TGPImage)}
    if renderable.Image not in found:
        return None
    protocol, widget = found[renderable.Image]
    size = get_cell_size()
    return Graphics(protocol, widget, (int(size.width), int(size.height)))
