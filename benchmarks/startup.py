"""How long do the commands that need no robot take, next to ``python -c 'import numpy'``?

Usage: ``.venv/bin/python benchmarks/startup.py [--repeats 15]``

Runs, interleaved in one run (see measure.py), each in a fresh process:

- ``python -c 'import numpy'``: the yardstick, what any numpy tool pays to start;
- ``handeye-pick --help``;
- ``handeye-pick convert`` (a UR pose to roll-pitch-yaw in degrees);
- ``handeye-pick point`` (eye-to-hand, ``--xyz``, the example calibration file).

It prints median, fastest and slowest wall time, median peak memory (RSS) and the ratios to the
yardstick. The requirement: each command at most 2 x the yardstick's time and under 50 MiB.
"""

from __future__ import annotations

import argparse
import sys

from measure import console_script, machine, print_table, side_by_side

TIME_RATIO_TARGET = 2.0
PEAK_MIB_TARGET = 50.0
YARDSTICK = "python -c 'import numpy'"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    args = parser.parse_args()

    cli = console_script("handeye-pick")
    convert = "convert --from ur --to euler --sequence xyz --angle-unit deg 0.4 0.1 0.3 0 3.14159 0"
    point = (
        "point --mode eye-to-hand --calibration config/calibration/EyeToHandTransform.yaml "
        "--xyz 37.77 -145.92 1227.1"
    )
    cases = {
        YARDSTICK: [sys.executable, "-c", "import numpy"],
        "handeye-pick --help": [cli, "--help"],
        "handeye-pick convert": [cli, *convert.split()],
        "handeye-pick point": [cli, *point.split()],
    }
    print(machine())
    print(f"{args.repeats} interleaved runs of each, after one warm-up round\n")
    summaries = side_by_side(cases, args.repeats)
    print_table(summaries, YARDSTICK)
    print()
    base = summaries[YARDSTICK]
    for name, s in summaries.items():
        if name == YARDSTICK:
            continue
        ratio = s.median_s / base.median_s
        ok = ratio <= TIME_RATIO_TARGET and s.peak_mib < PEAK_MIB_TARGET
        print(
            f"{name}: {ratio:.2f} x the yardstick's time, {s.peak_mib:.0f} MiB: "
            f"{'meets' if ok else 'MISSES'} the target (at most {TIME_RATIO_TARGET} x, "
            f"under {PEAK_MIB_TARGET:.0f} MiB)"
        )


if __name__ == "__main__":
    main()
