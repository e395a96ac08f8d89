"""The step plot's setup line: ``INPUT OUTPUT [HORIZON]`` read and written
(`engine.closed_loop.step_response` computes the response and its measures)."""

from __future__ import annotations

from engine.closed_loop.step_response import MAX_HORIZON, StepSetup, default_output
from engine.loop.realization import StateSpace


def parse_step_setup(text: str, inputs: tuple[str, ...], outputs: tuple[str, ...]) -> StepSetup:
    """'INPUT OUTPUT [HORIZON]' ('' : the defaults); names checked against the loop's signals."""
    words = text.split()
    if not words:
        return StepSetup()
    if len(words) not in (2, 3):
        raise ValueError("write INPUT OUTPUT [HORIZON in s], or nothing for the defaults")
    if words[0] not in inputs:
        raise ValueError(f"{words[0]!r} is not an input; inputs: {', '.join(inputs)}")
    if words[1] not in outputs:
        raise ValueError(f"{words[1]!r} is not a signal; signals: {', '.join(outputs)}")
    span = None
    if len(words) == 3:
        try:
            span = float(words[2])
        except ValueError:
            raise ValueError(f"horizon: expected seconds, got {words[2]!r}") from None
        if not 0 < span <= MAX_HORIZON:
            raise ValueError(f"horizon: between 0 and {MAX_HORIZON:g} s")
    return StepSetup(words[0], words[1], span)


def format_step_setup(setup: StepSetup, ss: StateSpace | None) -> str:
    """The setup as its line, the defaults written out when the loop is known."""
    source = setup.input or (ss.inputs[0] if ss is not None else "")
    output = setup.output or (default_output(ss) if ss is not None else "")
    return " ".join(w for w in (source, output, f"{setup.horizon:g}" if setup.horizon else "") if w)
