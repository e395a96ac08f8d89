"""`qcg`: quadratic cost in the frequency domain with the scaled, sign-constrained
conjugate gradient of report 001 (Seidel & Lehtinen)."""

from engine.qcg.algorithm import Qcg, QcgSettings
from engine.qcg.present import QcgPresenter
from engine.stepping.protocol import register

register(
    "qcg",
    Qcg,
    QcgSettings,
    "frequency-domain quadratic cost, scaled sign-constrained conjugate gradient (report 001, CGFM) or L-BFGS-B",
    QcgPresenter(),
)

__all__ = ["Qcg", "QcgSettings"]
