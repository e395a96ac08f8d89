"""Writes many_pole_loops.json: the exact closed-loop poles of tests/engine/many_pole_loops.py's
loops for the seeds in SEEDS (mpmath's polyroots at 60 digits, 200 bits more: 10-110 s a loop;
seed 0's agree bit for bit with 110 digits and 3000 bits more).

Run from the repository: .venv/bin/python -m tests.engine.data.make_many_pole_loops
"""

from __future__ import annotations

import json
from pathlib import Path

from tests.engine.many_pole_loops import exact_poles, many_pole_loop

SEEDS = [200, 201, 204, 215, 217, 235]


def main() -> None:
    cases = []
    for seed in SEEDS:
        loop = many_pole_loop(seed)
        cases.append({"seed": seed, "text": loop.text, "poles": [[z.real, z.imag] for z in exact_poles(loop)]})
    (Path(__file__).parent / "many_pole_loops.json").write_text(json.dumps(cases, indent=1) + "\n")


if __name__ == "__main__":
    main()
