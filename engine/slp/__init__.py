"""`slp`: COEBRA's sequential linear programming (Martin Marietta, report 003)."""

from engine.slp.algorithm import Slp, SlpSettings
from engine.slp.measures import TARGETS
from engine.slp.memory import SlpMemory
from engine.slp.present import SlpPresenter
from engine.stepping.registry import Registration

REGISTRATION = Registration(
    name="slp",
    bind=Slp.bind,
    settings=SlpSettings,
    memory_type=SlpMemory,
    summary="sequential linear programming over margins and time-domain measures, several flight "
    "conditions, load relief (report 003, COEBRA)",
    presenter=SlpPresenter(),
    targets=TARGETS,
    new_session_rank=0,
)

__all__ = ["REGISTRATION", "Slp", "SlpSettings"]
