"""Run commands side by side and measure each run's wall time and peak memory, as /usr/bin/time.

Used by ``startup.py`` and ``cloud_job.py``. Every command runs in its own process, started by
a bare launcher (``python -S``, about 9 MiB): a process's peak RSS counts what it held before
``exec`` too, so a command started straight from this script (which holds numpy and a test
cloud) would inherit this script's size. The launcher reports the command's peak resident memory
(``os.wait4``'s maxrss of exactly that process) and its wall time from spawn to exit. The
commands are interleaved, one run of each per round in a rotating order, so machine noise (a
shared 2-core box) hits them alike; the figures to read are the medians and their ratios.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_LAUNCHER = """
import os, sys, time
start = time.perf_counter()
pid = os.posix_spawnp(sys.argv[2], sys.argv[2:], os.environ)
_, status, usage = os.wait4(pid, 0)
seconds = time.perf_counter() - start
with open(sys.argv[1], "w") as report:
    report.write(f"{seconds} {usage.ru_maxrss} {os.waitstatus_to_exitcode(status)}")
"""


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
    with tempfile.TemporaryDirectory() as tmp:
        report, errors = Path(tmp) / "report", Path(tmp) / "stderr"
        with errors.open("wb") as stderr:
            subprocess.run(
                [sys.executable, "-S", "-c", _LAUNCHER, str(report), *argv],
                cwd=cwd,
                stdout=subprocess.DEVNULL,
                stderr=stderr,
                check=True,
            )
        seconds, maxrss_kib, status = report.read_text().split()
        if status != "0":
            sys.exit(f"{' '.join(argv)} failed ({status}):\n{errors.read_text()}")
    return Run(float(seconds), int(maxrss_kib) / 1024.0)  # Linux reports KiB


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
