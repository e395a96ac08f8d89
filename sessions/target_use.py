"""Which algorithm uses which target: the Targets tab's 'used by' column and
the list shown when another algorithm is chosen, read from what each installed
algorithm's registration declares (`TargetUse`, engine.stepping.registry)."""

from __future__ import annotations

from collections.abc import Sequence

from engine.design.measure_kinds import MEASURE_KINDS
from engine.errors import EngineError
from engine.stepping.registry import Registration, lookup, registrations


def used_by(measure: str) -> str:
    """The algorithms whose targets may name ``measure`` ('cip, slp')."""
    found = [name for name, r in registrations().items() if r.targets.accepts(measure)]
    return ", ".join(found) if found else "none"


def _known(algorithm: str) -> Registration | None:
    try:
        return lookup(algorithm)
    except EngineError:
        return None


def target_note(measure: str, algorithm: str) -> str:
    """'' when ``algorithm`` uses the measure (or is not one installed), else a short
    note: 'not cip (slp)', 'ignored by qcg'."""
    registration = _known(algorithm)
    if registration is None or measure not in MEASURE_KINDS:
        return ""
    if not registration.targets.reads:
        return f"ignored by {algorithm}"
    if registration.targets.accepts(measure):
        return ""
    return f"not {algorithm} ({used_by(measure)})"


def unusable_targets(measures: Sequence[str], algorithm: str) -> list[str]:
    """One line per target ``algorithm`` will refuse or ignore, saying which and why."""
    registration = _known(algorithm)
    if registration is None or not measures:
        return []
    use = registration.targets
    if not use.reads:
        reason = use.refusal.removeprefix(f"is not read by {algorithm} ")
        return [f"{algorithm} {reason}: the {len(measures)} target(s) are kept but not used"]
    return [
        f"{m}: refused by {algorithm}, it {use.why_not(m)}; used by {used_by(m)}"
        for m in measures
        if m in MEASURE_KINDS and not use.accepts(m)
    ]
