"""Run commands side by side and measure each run's wall time and peak memory, as /usr/bin/time.

Used by ``startup.py`` and ``cloud_job.py``. Every command runs in its own process; its peak
resident memory comes from ``os.wait4``'s resource usage of exactly that process (maxrss), its
time is the wall time from start to exit as seen by this script. The commands are interleaved,
one run of each per round in a rotating order, so machine noise (a shared 2-core box) hits them
alike; the figures to read are the medians and their ratios.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Run:
    seconds: float
    peak_mib: float


@dataclass(frozen=True)
class Summary:
    median_s: float
    low_s: float  # fastest run
    high_s: float  # slowest run
    peak_mib: float  # median of the runs' peaks


def console_script(name: str) -> str:
    """The installed console script next to this interpreter (what a user of the venv runs)."""
    path = Path(sys.executable).with_name(name)
    if not path.exists():
        sys.exit(f"{path} not found: install the package first (pip install -e .)")
    return str(path)


def run_once(argv: list[str], cwd: Path = ROOT) -> Run:
    """Run ``argv`` to the end; its wall time and peak RSS. Exits naming it if it fails."""
    with tempfile.TemporaryFile() as stderr:
        start = time.perf_counter()
        process = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=stderr)
        _, status, usage = os.wait4(process.pid, 0)
        seconds = time.perf_counter() - start
        process.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
        if process.returncode != 0:
            stderr.seek(0)
            sys.exit(f"{' '.join(argv)} failed ({process.returncode}):\n{stderr.read().decode()}")
    return Run(seconds, usage.ru_maxrss / 1024.0)  # Linux reports KiB


def side_by_side(cases: dict[str, list[str]], repeats: int, cwd: Path = ROOT) -> dict[str, Summary]:
    """Run every case ``repeats`` times, interleaved, after one warm-up round (file caches)."""
    runs: dict[str, list[Run]] = {name: [] for name in cases}
    names = list(cases)
    for round_number in range(repeats + 1):
        shift = round_number % len(names)
        for name in names[shift:] + names[:shift]:
            run = run_once(cases[name], cwd)
            if round_number > 0:
                runs[name].append(run)
    return {
        name: Summary(
            median_s=statistics.median(r.seconds for r in rs),
            low_s=min(r.seconds for r in rs),
            high_s=max(r.seconds for r in rs),
            peak_mib=statistics.median(r.peak_mib for r in rs),
        )
        for name, rs in runs.items()
    }


def print_table(summaries: dict[str, Summary], yardstick: str) -> None:
    """One line per case: median, fastest and slowest s, peak MiB, ratios to the yardstick."""
    base = summaries[yardstick]
    width = max(len(name) for name in summaries)
    print(
        f"  {'command':<{width}}  {'median s':>8}  {'min s':>6}  {'max s':>6}  "
        f"{'peak MiB':>8}  {'x time':>6}  {'x peak':>6}"
    )
    for name, s in summaries.items():
        print(
            f"  {name:<{width}}  {s.median_s:8.3f}  {s.low_s:6.3f}  {s.high_s:6.3f}  "
            f"{s.peak_mib:8.1f}  {s.median_s / base.median_s:6.2f}  "
            f"{s.peak_mib / base.peak_mib:6.2f}"
        )


def machine() -> str:
    """A line naming the interpreter and the machine's load, printed with every result."""
    load = ", ".join(f"{v:.1f}" for v in os.getloadavg())
    return f"Python {sys.version.split()[0]}, {os.cpu_count()} CPUs, load average {load}"
