"""How fast is ``transform_points`` next to a plain memory copy of the same cloud, and when does
loading numba pay?

Usage: ``.venv/bin/python benchmarks/cloud_transform.py [--repeats 30] [--rows 2048 --cols 2448]``

Builds a Zivid 2+ sized organized cloud (2448 x 2048 by default, 20 % NaN points, mm), then
times, interleaved in one run so that machine noise hits every method alike:

- ``np.copyto``: copy the cloud into another array, the memory-bandwidth yardstick;
- the two kernels of ``transform_points`` in place: numpy in blocks (what a process runs first)
  and numba (what it runs once it has transformed ``JIT_AFTER_POINTS`` points);
- ``transform_points`` with numba loaded: in place (``out=pts``), into a preallocated array
  (``out=dst``: a copy, then in place) and into a new array;
- plain numpy: ``pts @ R.T + t``.

It prints median, p10 and p90 in ms and the median ratio to the copy, for float32 and float64.
Then, in fresh processes, what loading the numba kernel costs (import, cached machine code, first
call; compiled on the machine's very first run) in time and peak memory, and the break-even: the
number of points after which the time the kernel saves has paid for its load, next to
``JIT_AFTER_POINTS``. Requirements: in place at most 1.5 x the copy for float32 and 1.1 x for
float64.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np
from measure import run_once
from numpy.typing import NDArray

from handeye_pick.cloud import transform as cloud
from handeye_pick.cloud.transform import transform_points
from handeye_pick.geometry import invert, make_transform, rotation_from_rotvec

TARGET_RATIO = {np.dtype(np.float32): 1.5, np.dtype(np.float64): 1.1}

_IMPORT_ONLY = "import numpy as np; from handeye_pick.cloud import transform as cloud"
_LOAD_KERNEL = (
    _IMPORT_ONLY + "; cloud._compile_kernel()(np.zeros(3, np.float32), "
    "np.eye(3, dtype=np.float32), np.zeros(3, np.float32))"
)


def make_cloud(rows: int, cols: int, nan_fraction: float, dtype: type) -> NDArray[np.floating]:
    """A camera-frame cloud in mm: points 0.5 to 2 m in front of the camera, some missing."""
    rng = np.random.default_rng(0)
    xyz = np.empty((rows, cols, 3), dtype=dtype)
    xyz[..., 0] = rng.uniform(-800.0, 800.0, (rows, cols))
    xyz[..., 1] = rng.uniform(-600.0, 600.0, (rows, cols))
    xyz[..., 2] = rng.uniform(500.0, 2000.0, (rows, cols))
    xyz[rng.random((rows, cols)) < nan_fraction] = np.nan
    return xyz


def summarize(samples_s: list[float]) -> tuple[float, float, float]:
    """Median, p10 and p90 in ms."""
    ms = np.array(samples_s) * 1e3
    return float(np.median(ms)), float(np.percentile(ms, 10)), float(np.percentile(ms, 90))


def bench_dtype(args: argparse.Namespace, dtype: type) -> dict[str, float]:
    """Print the table for one dtype; return the median ms of every method."""
    pts = make_cloud(args.rows, args.cols, args.nan_fraction, dtype)
    flat = pts.reshape(-1)
    dst = np.empty_like(pts)
    T = make_transform(rotation_from_rotvec([0.4, -2.9, 0.2]), [512.4, -38.7, 1245.3])
    # In place alternates T and its inverse so the data stays in the same range.
    transforms = [T, invert(T)]
    Rt = [(M[:3, :3].astype(dtype), M[:3, 3].astype(dtype)) for M in transforms]
    R, t = Rt[0]
    numba_kernel = cloud._compile_kernel()
    cloud.JIT_AFTER_POINTS = 0  # transform_points as in a process past the threshold: numba

    methods: dict[str, Callable[[int], object]] = {
        "np.copyto (yardstick)": lambda i: np.copyto(dst, pts),
        "numpy kernel, in place": lambda i: cloud._transform_numpy(flat, *Rt[i % 2]),
        "numba kernel, in place": lambda i: numba_kernel(flat, *Rt[i % 2]),
        "transform_points, in place": lambda i: transform_points(pts, transforms[i % 2], out=pts),
        "transform_points, out=dst": lambda i: transform_points(pts, T, out=dst),
        "transform_points, new array": lambda i: transform_points(pts, T),
        "numpy pts @ R.T + t": lambda i: pts @ R.T + t,
    }
    samples: dict[str, list[float]] = {name: [] for name in methods}
    for i in range(args.repeats + 1):
        for name, method in methods.items():
            start = time.perf_counter()
            method(i)
            elapsed = time.perf_counter() - start
            if i > 0:  # the first round warms caches and page tables
                samples[name].append(elapsed)

    print(
        f"\n{np.dtype(dtype).name}: {args.cols} x {args.rows} x 3 ({pts.nbytes / 1e6:.0f} MB), "
        f"{args.nan_fraction:.0%} NaN, {args.repeats} repeats; transform_points with numba loaded"
    )
    print(f"  {'method':<28} {'median ms':>9} {'p10 ms':>8} {'p90 ms':>8} {'x copy':>7}")
    medians = {name: summarize(times)[0] for name, times in samples.items()}
    copy_median = medians["np.copyto (yardstick)"]
    for name, times in samples.items():
        median, p10, p90 = summarize(times)
        print(f"  {name:<28} {median:9.2f} {p10:8.2f} {p90:8.2f} {median / copy_median:7.2f}")
    return medians


def jit_load_cost(repeats: int) -> tuple[float, float]:
    """Median extra seconds and MiB of a process that loads the numba kernel (fresh processes)."""
    extra_s, extra_mib = [], []
    for _ in range(repeats):
        base = run_once([sys.executable, "-c", _IMPORT_ONLY])
        loaded = run_once([sys.executable, "-c", _LOAD_KERNEL])
        extra_s.append(loaded.seconds - base.seconds)
        extra_mib.append(loaded.peak_mib - base.peak_mib)
    return statistics.median(extra_s), statistics.median(extra_mib)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--rows", type=int, default=2048)
    parser.add_argument("--cols", type=int, default=2448)
    parser.add_argument("--nan-fraction", type=float, default=0.2)
    parser.add_argument("--load-repeats", type=int, default=5, help="fresh processes timed")
    args = parser.parse_args()

    import numba

    load = os.getloadavg()[0]
    print(
        f"numpy {np.__version__}, numba {numba.__version__}, {os.cpu_count()} CPUs, load {load:.1f}"
    )
    threshold = cloud.JIT_AFTER_POINTS  # bench_dtype sets it to 0
    results = {np.dtype(d): bench_dtype(args, d) for d in (np.float32, np.float64)}
    load_s, load_mib = jit_load_cost(args.load_repeats)
    points = args.rows * args.cols

    print()
    for dtype, medians in results.items():
        ratio = medians["transform_points, in place"] / medians["np.copyto (yardstick)"]
        target = TARGET_RATIO[dtype]
        verdict = "meets" if ratio <= target else "MISSES"
        print(f"{dtype.name} in place: {ratio:.2f} x copy, {verdict} the target of {target} x")
    print(
        f"loading the numba kernel costs a process {load_s * 1e3:.0f} ms and {load_mib:.0f} MiB "
        f"(median of {args.load_repeats} fresh processes)"
    )
    for dtype, medians in results.items():
        saved_s = (medians["numpy kernel, in place"] - medians["numba kernel, in place"]) / 1e3
        per_point_ns = saved_s / points * 1e9
        break_even = load_s / saved_s * points if saved_s > 0 else float("inf")
        print(
            f"{dtype.name}: numba saves {per_point_ns:.1f} ns a point over numpy, so its load "
            f"pays after {break_even / 1e6:.0f} M points (JIT_AFTER_POINTS: "
            f"{threshold / 1e6:.0f} M)"
        )


if __name__ == "__main__":
    main()
