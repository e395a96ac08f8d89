"""Several loops at once (issue 56): a 3-loop plant of order 40 (tests/engine/multiloop_references.py's
`random_plant`: a stable closed loop chosen first, light modes, open loop often unstable), a new
plant at every repetition, the two jobs interleaved:

- `loop_at_a_time`: every break's margins (`engine.multiloop.loops.break_margins`: gain, phase and
  delay margins at every crossing, the disk margin, Ms and Mt), target 50 ms a break;
- `multi_loop_disk_margin`: certified (`engine.multiloop.disk`), target 200 ms;
- `diagram_loop_at_a_time_per_break`, `diagram_multi_loop_disk_margin`: the same plant as one block of
  several ports in a diagram with unity feedback (`analyze` at each input, `diagram_disk_margin`): the
  diagram's path, no target;
- `diagram_delay_multi_loop_disk_margin`: that diagram with exp(-0.01 s) at every plant input (the sums
  feed delays that feed the block), the multi-loop margin at the delays' outputs, the delays exact
  (`engine.multiloop.delayed`): no target; `delay_certified` counts its certified runs, `delay_unstable`
  those whose closed loop the delays destabilize.

Absolute times: reported, not enforced (the machine's cores are shared)."""

from __future__ import annotations

import statistics

import numpy as np

from tests.bench.common import samples, timed
from tests.engine.multiloop_references import random_plant

ORDER, LOOPS = 40, 3
GRID = np.geomspace(1e-3, 1e3, 400)
DELAY = 0.01  # s, at every plant input of the diagram with delays


def multiloop_figures(repeat: int) -> dict:
    from engine.analysis import analyze
    from engine.multiloop.disk import multi_loop_disk_margin
    from engine.multiloop.loops import break_margins
    from engine.multiloop.network_breaks import diagram_disk_margin
    from engine.multiloop.plant import checked_plant

    matrices = [random_plant(np.random.default_rng(4000 + i), ORDER, LOOPS) for i in range(repeat + 1)]
    plants = [checked_plant(*m, "bench") for m in matrices]
    diagrams = [one_block_diagram(m) for m in matrices]
    delayed = [one_block_diagram(m, DELAY) for m in matrices]
    statuses: list[str] = []
    delay_statuses: list[str] = []
    breaks = [f"u{k}" for k in range(1, LOOPS + 1)]

    def loops(i: int) -> None:
        break_margins(plants[i], GRID)

    def together(i: int) -> None:
        statuses.append(multi_loop_disk_margin(plants[i]).status)

    def diagram_loops(i: int) -> None:
        for name in breaks:
            analyze(diagrams[i], name, GRID, {})

    def diagram_together(i: int) -> None:
        statuses.append(diagram_disk_margin(diagrams[i], breaks, {}).status)

    def delayed_together(i: int) -> None:
        delay_statuses.append(diagram_disk_margin(delayed[i], breaks, {}).status)

    each, whole, in_diagram, diagram_whole, with_delays = samples(
        [loops, together, diagram_loops, diagram_together, delayed_together], repeat
    )
    per_break = [t / LOOPS for t in each]
    return {
        "diagram_loop_at_a_time_per_break": timed(
            statistics.median([t / LOOPS for t in in_diagram]), None, order=ORDER, loops=LOOPS
        ),
        "diagram_multi_loop_disk_margin": timed(statistics.median(diagram_whole), None, order=ORDER, loops=LOOPS),
        "diagram_delay_multi_loop_disk_margin": timed(
            statistics.median(with_delays),
            None,
            order=ORDER,
            loops=LOOPS,
            delay=DELAY,
            delay_certified=sum(s == "certified" for s in delay_statuses),
            delay_unstable=sum(s == "unstable" for s in delay_statuses),
            runs=len(delay_statuses),
        ),
        "loop_at_a_time_per_break": timed(statistics.median(per_break), 0.050, order=ORDER, loops=LOOPS),
        "loop_at_a_time_every_break": timed(statistics.median(each), None, order=ORDER, loops=LOOPS),
        "multi_loop_disk_margin": timed(
            statistics.median(whole),
            0.200,
            order=ORDER,
            loops=LOOPS,
            certified=sum(s == "certified" for s in statuses),
            runs=len(statuses),  # the plant's and the diagram's
        ),
    }


def one_block_diagram(matrices, delay: float = 0.0):
    """The plant (A, B, C, D) as one block of m ports in a diagram, u_k = r_k - y_k (`engine.model.ports`);
    with a ``delay``, u_k = exp(-delay s) (r_k - y_k)."""
    from engine.model.blocks import DelayTransfer
    from engine.model.network import Block, Junction, PortedBlock, block_diagram
    from engine.model.ports.state_space_ports import PortedStateSpace

    m = np.shape(matrices[1])[1]
    ins, outs = tuple(f"u{k}" for k in range(1, m + 1)), tuple(f"y{k}" for k in range(1, m + 1))
    summed = "v" if delay else "u"
    sums = [Junction(f"e{k}", f"{summed}{k}", ((1.0, f"r{k}"), (-1.0, f"y{k}"))) for k in range(1, m + 1)]
    lags = [Block(f"lag{k}", f"v{k}", f"u{k}", DelayTransfer(delay)) for k in range(1, m + 1)] if delay else []
    block = PortedBlock("P", ins, outs, PortedStateSpace(*matrices, source="plant"))
    return block_diagram([block, *lags], sums, [f"r{k}" for k in range(1, m + 1)])
