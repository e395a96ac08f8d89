"""`qcg`: quadratic cost in the frequency domain with the scaled, sign-constrained
conjugate gradient of report 001 (Seidel & Lehtinen)."""

from engine.qcg.algorithm import Qcg, QcgSettings
from engine.qcg.memory import QcgMemory
from engine.qcg.present import QcgPresenter
from engine.qcg.setup import TARGETS
from engine.stepping.registry import Registration

REGISTRATION = Registration(
    name="qcg",
    bind=Qcg.bind,
    settings=QcgSettings,
    memory_type=QcgMemory,
    summary="frequency-domain quadratic cost, scaled sign-constrained conjugate gradient (report 001, CGFM) "
    "or L-BFGS-B",
    presenter=QcgPresenter(),
    targets=TARGETS,
)

__all__ = ["REGISTRATION", "Qcg", "QcgSettings"]
