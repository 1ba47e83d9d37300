"""How long does ``open_audit`` take on a long-lived audit file, next to reading it all?

Usage: ``.venv/bin/python benchmarks/audit_open.py [--records 100000] [--repeats 7]``

Writes a temporary audit file of ``--records`` records (plan and outcome pairs of realistic size:
a plan with its matrices and checks is about 2 kB) ending with one plan whose process died, then
times, interleaved in one run so that machine noise hits both alike:

- ``open_audit``: the check, the lock and the backward scan for unfinished plans (the one plan
  found is closed as abandoned on the first run, so later runs find a clean end at once);
- ``read_audit`` over the whole file: what a forward scan for unfinished plans would cost.

It prints median, p10 and p90 in ms and the ratio of the medians, and the time of one
``append`` (with its fsync) for scale. The requirement is: opening does not grow with the file.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handeye_pick.audit import AuditLog, open_audit, read_audit


def _plan(n: int) -> dict[str, object]:
    return {
        "event": "plan",
        "dry_run": False,
        "config": "/cell/cell.yaml",
        "host": "10.0.0.5",
        "T_base_cam": np.eye(4),
        "T_base_obj": np.eye(4) * (1 + n % 7),
        "targets": {name: [0.1 * n, 0.2, 0.3, 0.0, 3.14, 0.0] for name in ("a", "g", "r")},
        "checks": [
            {"name": f"check-{i}", "target": "grasp", "passed": True, "detail": "ok " * 5}
            for i in range(12)
        ],
    }


def _write_file(path: Path, records: int) -> None:
    log = AuditLog(path, pick_id="template")
    log.append(_plan(0))
    log.append({"event": "outcome", "status": "done", "reached": {"grasp": [0.0] * 6}})
    plan_line, outcome_line = path.read_text().splitlines()
    pairs = []
    for n in range(records // 2 - 1):
        pick_id = f'"pick_id": "{n:032x}"'
        pairs.append(plan_line.replace('"pick_id": "template"', pick_id))
        pairs.append(outcome_line.replace('"pick_id": "template"', pick_id))
    path.write_text("\n".join(pairs) + "\n")
    AuditLog(path).append(_plan(1))  # its process died: no outcome


def _time_ms(action: Callable[[], object]) -> float:
    start = time.perf_counter()
    action()
    return (time.perf_counter() - start) * 1000.0


def _open_and_close(path: Path) -> None:
    audit, _ = open_audit(path)
    audit.close()


def _read_all(path: Path) -> None:
    for _ in read_audit(path):
        pass


def _summary(name: str, times: list[float]) -> float:
    ordered = sorted(times)
    p10 = ordered[len(ordered) // 10]
    p90 = ordered[min(len(ordered) - 1, (len(ordered) * 9) // 10)]
    median = statistics.median(times)
    print(f"{name:<22} median {median:9.2f} ms   p10 {p10:9.2f}   p90 {p90:9.2f}")
    return median


parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--records", type=int, default=100_000)
parser.add_argument("--repeats", type=int, default=7)
args = parser.parse_args()

with tempfile.TemporaryDirectory() as folder:
    path = Path(folder) / "picks.jsonl"
    _write_file(path, args.records)
    size_mb = path.stat().st_size / 1e6
    first_open_ms = _time_ms(lambda: _open_and_close(path))  # closes the one unfinished plan
    opens, reads = [], []
    for _ in range(args.repeats):
        opens.append(_time_ms(lambda: _open_and_close(path)))
        reads.append(_time_ms(lambda: _read_all(path)))
    appends = [_time_ms(lambda: AuditLog(path).append({"event": "x"})) for _ in range(20)]
    print(f"audit file: {args.records} records, {size_mb:.0f} MB")
    print(f"first open_audit (closes one abandoned plan): {first_open_ms:.2f} ms")
    open_ms = _summary("open_audit", opens)
    read_ms = _summary("read_audit, whole file", reads)
    _summary("append (fsync)", appends)
    print(f"whole read / open_audit: {read_ms / open_ms:.0f} x")
