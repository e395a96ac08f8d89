"""The workbench's first paint of a cip session (`make run`'s) loads no scipy:
scipy.linalg took a fifth of a second of the start (first paint 0.89 -> 0.69 s,
median of seven interleaved starts), and nothing on that screen needs it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_a_cip_session_paints_before_scipy_is_imported(workdir):
    script = ("import asyncio, sys\nfrom pathlib import Path\nfrom tests.bench.tui_latency import _first_paint\n"
              f"painted = asyncio.run(_first_paint(Path({str(workdir / 'cip_launch_vehicle.json')!r})))\n"
              "print('PAINTED', painted is not None, 'SCIPY', sorted(m for m in sys.modules if m.startswith('scipy')))")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT,
                         check=True)
    assert out.stdout.split("PAINTED")[-1].split() == ["True", "SCIPY", "[]"], out.stdout[-500:]
