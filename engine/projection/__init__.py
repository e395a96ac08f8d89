"""`projection`: constrained differential-algebraic design by sequential
projection with extrapolation (report 004)."""

from engine.design.measure_kinds import TargetUse
from engine.projection.algorithm import Projection, ProjectionSettings
from engine.projection.memory import ProjectionMemory
from engine.projection.present import ProjectionPresenter
from engine.stepping.registry import Registration

REGISTRATION = Registration(
    name="projection",
    bind=Projection.bind,
    settings=ProjectionSettings,
    memory_type=ProjectionMemory,
    summary="alternating projections with extrapolation for constrained DAE systems (report 004)",
    presenter=ProjectionPresenter(),
    targets=TargetUse(
        reads=False,
        refusal="is not read by projection (it meets its DAE system's constraints and reads no targets)",
    ),
)

__all__ = ["REGISTRATION", "Projection", "ProjectionSettings"]
