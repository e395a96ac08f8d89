"""`cip`: constraint improvement on margins (Mitchell & McDaniel, report 000)."""

from engine.cip.algorithm import Cip, CipSettings
from engine.cip.memory import CipMemory
from engine.cip.present import CipPresenter
from engine.cip.requirements import TARGETS
from engine.stepping.registry import Registration

REGISTRATION = Registration(
    name="cip",
    bind=Cip.bind,
    settings=CipSettings,
    memory_type=CipMemory,
    summary="constraint improvement on gain/phase/stability/attenuation margins (report 000, CIP)",
    presenter=CipPresenter(),
    targets=TARGETS,
    new_session_rank=1,
)

__all__ = ["REGISTRATION", "Cip", "CipSettings"]
