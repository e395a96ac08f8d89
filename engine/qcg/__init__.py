"""`qcg`: quadratic cost in the frequency domain with the scaled, sign-constrained
conjugate gradient of report 001 (Seidel & Lehtinen)."""

from ..algorithm import register
from .algorithm import Qcg, QcgSettings
from .present import QcgPresenter

register("qcg", Qcg, QcgSettings,
         "frequency-domain quadratic cost, scaled sign-constrained conjugate gradient (report 001, CGFM) or L-BFGS-B",
         QcgPresenter())

__all__ = ["Qcg", "QcgSettings"]
