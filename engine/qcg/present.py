"""How `qcg` records are shown: report 001's printout of a record (Appendix C): the listing's F and
its parts, the counters, the parameters, and the INST = 4 frequency response."""

from __future__ import annotations

from engine.design.problem import Problem
from engine.errors import EngineError
from engine.qcg.setup import cascade_problem
from engine.stepping.presenter import Presenter, tableau_text
from engine.stepping.protocol import StepRecord


def qcg_report_text(record: StepRecord, response: list[dict] | None = None) -> str:
    """The record as the listing prints it, with both cost conventions labelled."""
    e = record.extra
    parts = e.get("parts", {})
    lines = [
        f"ITERATION {record.iteration}   STATUS {record.status.value}"
        + (f" ({record.reason})" if record.reason else ""),
        f"F= {e.get('F', float('nan')):.9e}   (the listing's F = sum F(w_i)(w_i+1 - w_i-1) = 2 pi C)",
        f"C= {e.get('C', float('nan')):.9e}   (eq. 22: C = (1/pi) integral of F(w) dw)",
        f"KNT, KOUNT, SIZE= {record.counters.get('KNT', 0)} {record.counters.get('KOUNT', 0)} "
        f"{e.get('size', float('nan')):.3e}   (evaluations {record.counters.get('evaluations', 0)}, "
        f"{record.counters.get('gradients', 0)} with the gradient; optimizer {e.get('optimizer', 'cgfm')})",
        "FDQ, FDR, FVQ, FVR= " + " ".join(f"{parts.get(k, 0.0):.3e}" for k in ("FDQ", "FDR", "FVQ", "FVR")),
        "B= " + "  ".join(f"{name}={value:.6g}" for name, value in record.parameters.items()),
    ]
    squares = e.get("averaged_squares")
    if squares:
        lines.append("averaged squares: " + "  ".join(f"{k}={v:.4g}" for k, v in squares.items()))
    if response:
        lines += ["", f"{'HZ':>10} {'/Y/':>10} {'DEG':>10} {'REAL':>11} {'IMAG':>11}"]
        lines += [
            f"{r['hz']:>10.4g} {r['magnitude']:>10.4g} {r['phase_deg']:>10.2f} {r['open_real']:>11.4g} "
            f"{r['open_imag']:>11.4g}"
            for r in response
        ]
    return "\n".join(lines)


class QcgPresenter(Presenter):
    """The listing's printout with the frequency response (INST = 4); sweeps keep the averaged squares."""

    def summary(self, record: StepRecord) -> dict:
        squares = record.extra.get("averaged_squares")
        return {"averaged_squares": dict(squares)} if squares else {}

    def report(self, record: StepRecord, problem: Problem) -> str:
        if record.iteration == 0:
            return tableau_text(record.measures, problem.grid.unit)
        params = {k: float(v[0] if isinstance(v, list) else v) for k, v in record.parameters.items()}
        try:
            response = cascade_problem(problem).frequency_response(params)
        except EngineError as exc:
            raise EngineError(f"frequency response: {exc}") from None
        return qcg_report_text(record, response)
