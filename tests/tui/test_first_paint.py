"""The workbench's first paint of a cip session (`make run`'s) or a qcg session
loads no scipy: nothing on that screen needs it, and scipy.linalg or
scipy.optimize took a fifth to a third of a second of the start (first paint
0.89 -> 0.69 s and 0.92 -> 0.61 s, medians of interleaved starts)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("session", ["cip_launch_vehicle", "seidel_inlet_pi"])
def test_a_session_paints_before_scipy_is_imported(workdir, session):
    script = (
        "import asyncio, sys\nfrom pathlib import Path\nfrom tests.bench.tui_latency import _first_paint\n"
        f"painted = asyncio.run(_first_paint(Path({str(workdir / (session + '.json'))!r})))\n"
        "print('PAINTED', painted is not None, 'SCIPY', sorted(m for m in sys.modules if m.startswith('scipy')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT, check=True
    )
    assert out.stdout.split("PAINTED")[-1].split() == ["True", "SCIPY", "[]"], out.stdout[-500:]
