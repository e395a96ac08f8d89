"""Several loops at once (issue 56): a 3-loop plant of order 40 (tests/engine/multiloop_references.py's
`random_plant`: a stable closed loop chosen first, light modes, open loop often unstable), a new
plant at every repetition, the two jobs interleaved:

- `loop_at_a_time`: every break's margins (`engine.multiloop.loops.break_margins`: gain, phase and
  delay margins at every crossing, the disk margin, Ms and Mt), target 50 ms a break;
- `multi_loop_disk_margin`: certified (`engine.multiloop.disk`), target 200 ms.

Absolute times: reported, not enforced (the machine's cores are shared)."""

from __future__ import annotations

import statistics

import numpy as np

from tests.bench.common import samples, timed
from tests.engine.multiloop_references import random_plant

ORDER, LOOPS = 40, 3
GRID = np.geomspace(1e-3, 1e3, 400)


def multiloop_figures(repeat: int) -> dict:
    from engine.multiloop.disk import multi_loop_disk_margin
    from engine.multiloop.loops import break_margins
    from engine.multiloop.plant import checked_plant

    plants = [
        checked_plant(*random_plant(np.random.default_rng(4000 + i), ORDER, LOOPS), "bench") for i in range(repeat + 1)
    ]
    statuses: list[str] = []

    def loops(i: int) -> None:
        break_margins(plants[i], GRID)

    def together(i: int) -> None:
        statuses.append(multi_loop_disk_margin(plants[i]).status)

    each, whole = samples([loops, together], repeat)
    per_break = [t / LOOPS for t in each]
    return {
        "loop_at_a_time_per_break": timed(statistics.median(per_break), 0.050, order=ORDER, loops=LOOPS),
        "loop_at_a_time_every_break": timed(statistics.median(each), None, order=ORDER, loops=LOOPS),
        "multi_loop_disk_margin": timed(
            statistics.median(whole),
            0.200,
            order=ORDER,
            loops=LOOPS,
            certified=sum(s == "certified" for s in statuses),
            runs=len(statuses),
        ),
    }
