"""Which algorithm uses which target: the Targets tab's 'used by' column and
the list shown when another algorithm is chosen, read from the one table of
measure kinds (`engine.design.measure_kinds`)."""

from __future__ import annotations

from collections.abc import Sequence

from engine.design.measure_kinds import ALGORITHMS, MEASURE_KINDS, refusal

READS_NO_TARGETS = ("qcg", "projection")  # they minimize their own cost / meet their own constraints


def used_by(measure: str) -> str:
    """The algorithms whose targets may name ``measure`` ('cip, slp')."""
    found = MEASURE_KINDS.get(measure)
    return ", ".join(sorted(found.algorithms)) if found else "none"


def target_note(measure: str, algorithm: str) -> str:
    """'' when ``algorithm`` uses the measure (or is not one the table knows),
    else a short note: 'not cip (slp)', 'ignored by qcg'."""
    if algorithm not in ALGORITHMS or measure not in MEASURE_KINDS:
        return ""
    if algorithm in READS_NO_TARGETS:
        return f"ignored by {algorithm}"
    if algorithm in MEASURE_KINDS[measure].algorithms:
        return ""
    return f"not {algorithm} ({used_by(measure)})"


def unusable_targets(measures: Sequence[str], algorithm: str) -> list[str]:
    """One line per target ``algorithm`` will refuse or ignore, saying which and why."""
    if algorithm not in ALGORITHMS or not measures:
        return []
    if algorithm in READS_NO_TARGETS:
        return [
            f"{algorithm} {ALGORITHMS[algorithm].removeprefix('is not read by ' + algorithm + ' ')}: "
            f"the {len(measures)} target(s) are kept but not used"
        ]
    return [
        f"{m}: refused by {algorithm}, it {refusal(algorithm, m)}; used by {used_by(m)}"
        for m in measures
        if m in MEASURE_KINDS and algorithm not in MEASURE_KINDS[m].algorithms
    ]
