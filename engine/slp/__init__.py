"""`slp`: COEBRA's sequential linear programming (Martin Marietta, report 003)."""

from engine.slp.algorithm import Slp, SlpSettings
from engine.slp.present import SlpPresenter
from engine.stepping.protocol import register

register(
    "slp",
    Slp,
    SlpSettings,
    "sequential linear programming over margins and time-domain measures, several flight "
    "conditions, load relief (report 003, COEBRA)",
    SlpPresenter(),
)

__all__ = ["Slp", "SlpSettings"]
