"""`cip`: constraint improvement on margins (Mitchell & McDaniel, report 000)."""

from ..algorithm import register
from .algorithm import Cip, CipSettings

register("cip", Cip, CipSettings,
         "constraint improvement on gain/phase/stability/attenuation margins (report 000, CIP)",
         maximize=True)  # sweeps rank cip runs by their smallest stability margin

__all__ = ["Cip", "CipSettings"]
