"""`projection`: constrained differential-algebraic design by sequential
projection with extrapolation (report 004)."""

from engine.projection.algorithm import Projection, ProjectionSettings
from engine.projection.present import ProjectionPresenter
from engine.stepping.protocol import register

register(
    "projection",
    Projection,
    ProjectionSettings,
    "alternating projections with extrapolation for constrained DAE systems (report 004)",
    ProjectionPresenter(),
)

__all__ = ["Projection", "ProjectionSettings"]
