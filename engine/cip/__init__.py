"""`cip`: constraint improvement on margins (Mitchell & McDaniel, report 000)."""

from engine.cip.algorithm import Cip, CipSettings
from engine.cip.present import CipPresenter
from engine.stepping.protocol import register

register(
    "cip",
    Cip,
    CipSettings,
    "constraint improvement on gain/phase/stability/attenuation margins (report 000, CIP)",
    CipPresenter(),
)

__all__ = ["Cip", "CipSettings"]
