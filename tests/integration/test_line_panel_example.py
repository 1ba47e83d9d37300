"""examples/line_panel.py end to end: a vision program picks through `handeye-pick run`, an OPC UA
panel watches, and a PLC played through the simulated controller's inputs holds the cell after
three picks and releases it (docs/line.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_plc_holds_the_cell_after_three_picks_and_the_panel_counts_five(
    tmp_path: Path, loopback_host: str
) -> None:
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "line_panel.py"), "--host", loopback_host],
        cwd=tmp_path, capture_output=True, text=True, timeout=240, check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr[-3000:]
    lines = result.stdout.splitlines()
    assert "plc: 3 parts arrived: DI4 high (cycle stop)" in lines
    assert any("answered held (by input DI4 (cycle stop))" in line for line in lines)
    assert lines[-1] == "line panel example: every check passed"
    assert any("placed=5" in line for line in lines if line.startswith("panel:"))
