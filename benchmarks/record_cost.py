"""What a recording costs a cycle: capture/pick/place cycles of one session with and without
``--record`` (the same ``Publisher`` the command uses), side by side in one run, against the
simulated controller (500 Hz, instant motion) on 127.0.0.249; and the cost of one logged
``base -> flange`` frame, which a moving arm adds 100 times a second.

Overhead of a cycle = its wall time minus the controller's time moving (cycle.py's measure).
Run: ``.venv/bin/python benchmarks/record_cost.py [--cycles 40]``.
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # mocks/ and benchmarks/ live beside src/

from benchmarks import cycle  # noqa: E402
from handeye_pick import Cell  # noqa: E402
from handeye_pick.config.hand_eye import calibration_from_config  # noqa: E402
from handeye_pick.config.load import load_config  # noqa: E402
from handeye_pick.config.schema import CellConfig  # noqa: E402
from handeye_pick.detection import detection_from_point_mm  # noqa: E402
from handeye_pick.record.publisher import Publisher  # noqa: E402
from mocks.ur_controller import SimulatedController  # noqa: E402

HOST = "127.0.0.249"

def _cycles(
    config: CellConfig, ctl: SimulatedController, cycles: int, record: Path | None
) -> list[float]:
    overheads = []
    with contextlib.ExitStack() as stack:
        publisher = None
        if record is not None:
            calibration = calibration_from_config(config)
            publisher = stack.enter_context(Publisher(config, calibration, record=record))
        cell = stack.enter_context(Cell(config, observer=publisher))
        count = len(ctl.motions)
        for _ in range(cycles):
            start = time.perf_counter()
            capture = cell.capture()
            assert capture.T_base_flange is not None
            point = cycle._camera_point_mm(config, capture.T_base_flange)
            result = cell.pick([detection_from_point_mm(point, "benchmark")], capture)
            wall_s = time.perf_counter() - start
            if result.status != "placed":
                raise RuntimeError(f"cycle ended {result.status}")
            moving_s, count = cycle._moving_s(ctl, count)
            overheads.append(wall_s - moving_s)
    return overheads

def _per_frame_us(config: CellConfig, record: Path, frames: int = 5000) -> float:
    with Publisher(config, calibration_from_config(config), record=record) as publisher:
        pose = [-0.4, -0.1, 0.4, 3.14159265, 0.0, 0.0]
        start = time.perf_counter()
        for i in range(frames):
            pose[0] += 1e-4  # moving: every call past the period is logged
            publisher.on_sample(pose, 0.011 * i)
        return (time.perf_counter() - start) / frames * 1e6

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=40, help="cycles per variant (default 40)")
    args = parser.parse_args()
    yaml = cycle.CELL_YAML.replace(cycle.HOST, HOST)
    with tempfile.TemporaryDirectory() as tmp, SimulatedController(
        host=HOST, tcp_offset=cycle.TCP_OFFSET, instant=True
    ) as ctl:
        folder = Path(tmp)
        (folder / "cell.yaml").write_text(yaml)
        config = load_config(folder / "cell.yaml")
        _cycles(config, ctl, 3, None)  # warm up: imports, the controller's first program
        plain, recorded = [], []
        for round_ in range(4):  # interleaved, so a busy moment of the machine hits both
            plain += _cycles(config, ctl, args.cycles // 4, None)
            recorded += _cycles(config, ctl, args.cycles // 4, folder / f"r{round_}.mcap")
        frame_us = _per_frame_us(config, folder / "frames.mcap")
        size = sum(p.stat().st_size for p in folder.glob("r*.mcap")) / len(recorded)
    med_plain, med_rec = (statistics.median(v) * 1000.0 for v in (plain, recorded))
    print(f"recording cost per capture/pick/place cycle ({len(plain)} cycles each, simulated "
          f"controller at {HOST}, 500 Hz, instant motion)")
    print(f"  without --record   median overhead {med_plain:7.2f} ms")
    print(f"  with --record      median overhead {med_rec:7.2f} ms")
    print(f"  recording's cost:  {med_rec - med_plain:+.2f} ms per cycle (median; goal <= 2 ms)")
    print(f"  one logged base -> flange frame: {frame_us:.0f} us; at most 100 Hz while the arm "
          f"moves {frame_us * 100 / 1000:.1f} ms per second of motion")
    print(f"  file size: {size / 1024:.1f} KiB per cycle")

if __name__ == "__main__":
    main()
