"""A whole ``cloud`` job next to the same job done plainly, each in its own process.

Usage: ``.venv/bin/python benchmarks/cloud_job.py [--repeats 7] [--rows 2048 --cols 2448]``

Writes a Zivid 2+ sized camera cloud (2448 x 2048 float32 points in mm, 20 % NaN, uchar colours)
to a temporary directory as ``.npy`` and as binary PLY, then runs, interleaved in one run (see
measure.py), each job transforming it with the example eye-to-hand calibration:

- ``.npy`` -> ``.npy``: ``handeye-pick cloud`` next to a plain numpy script (``np.load``,
  ``p @ R.T + t`` in the cloud's dtype, ``np.save``). Requirement: at most 1.5 x its time.
- PLY -> PLY: ``handeye-pick cloud`` next to Open3D's tensor API (``o3d.t.io.read_point_cloud``,
  ``transform``, ``o3d.t.io.write_point_cloud``). Requirement: faster, and at most 1.2 x its peak
  memory. Open3D is not a dependency of handeye-pick: ``pip install open3d`` to compare (it needs
  the system's libusb-1.0); without it the PLY jobs are compared with plyfile's instead.
- plyfile (``PlyData.read``, the same product, ``write``), when installed, as a second
  reference for PLY.

It prints median, fastest and slowest wall time and median peak memory (RSS) of each job, and
the ratios to the plain job.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
from pathlib import Path

import numpy as np
from measure import ROOT, console_script, machine, print_table, side_by_side
from numpy.typing import NDArray

from handeye_pick.cloud.files import PointCloud, write_cloud
from handeye_pick.geometry import scale_translation
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye

CALIBRATION = ROOT / "config" / "calibration" / "EyeToHandTransform.yaml"
NUMPY = "numpy script: .npy -> .npy"
OURS_NPY = "handeye-pick cloud: .npy -> .npy"
OURS_PLY = "handeye-pick cloud: PLY -> PLY"
OPEN3D = "Open3D tensor API: PLY -> PLY"
PLYFILE = "plyfile: PLY -> PLY"
NPY_TIME_TARGET = 1.5
PLY_PEAK_TARGET = 1.2

# The plain jobs get T_base_cam (mm) as JSON: they pay for no YAML or calibration checks.
NUMPY_JOB = """
import json, sys
import numpy as np
T = np.array(json.loads(sys.argv[3]))
p = np.load(sys.argv[1])
np.save(sys.argv[2], p @ T[:3, :3].T.astype(p.dtype) + T[:3, 3].astype(p.dtype))
"""
OPEN3D_JOB = """
import json, sys
import numpy as np
import open3d as o3d
cloud = o3d.t.io.read_point_cloud(sys.argv[1])
cloud.transform(o3d.core.Tensor(np.array(json.loads(sys.argv[3]))))
o3d.t.io.write_point_cloud(sys.argv[2], cloud)
"""
PLYFILE_JOB = """
import json, sys
import numpy as np
from plyfile import PlyData
T = np.array(json.loads(sys.argv[3]))
ply = PlyData.read(sys.argv[1])
v = ply["vertex"].data
xyz = np.stack([v["x"], v["y"], v["z"]], axis=-1)
out = xyz @ T[:3, :3].T.astype(xyz.dtype) + T[:3, 3].astype(xyz.dtype)
v["x"], v["y"], v["z"] = out[:, 0], out[:, 1], out[:, 2]
ply.write(sys.argv[2])
"""


def camera_cloud(rows: int, cols: int) -> tuple[NDArray[np.float32], NDArray[np.uint8]]:
    """Points 0.5 to 2 m in front of the camera (mm), 20 % without data; random colours."""
    rng = np.random.default_rng(0)
    xyz = np.empty((rows, cols, 3), dtype=np.float32)
    xyz[..., 0] = rng.uniform(-800.0, 800.0, (rows, cols))
    xyz[..., 1] = rng.uniform(-600.0, 600.0, (rows, cols))
    xyz[..., 2] = rng.uniform(500.0, 2000.0, (rows, cols))
    xyz[rng.random((rows, cols)) < 0.2] = np.nan
    return xyz, rng.integers(0, 256, (rows, cols, 3), dtype=np.uint8)


def installed(module: str) -> bool:
    return importlib.util.find_spec(module) is not None


def verdict(ok: bool) -> str:
    return "meets" if ok else "MISSES"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--rows", type=int, default=2048)
    parser.add_argument("--cols", type=int, default=2448)
    args = parser.parse_args()

    T_base_cam_m = load_hand_eye(CALIBRATION, HandEyeMode.EYE_TO_HAND).T_base_cam(None)
    T_mm = json.dumps(scale_translation(T_base_cam_m, 1000.0).tolist())
    cli = console_script("handeye-pick")
    print(machine())
    with tempfile.TemporaryDirectory(prefix="cloud-job-") as tmp:
        d = Path(tmp)
        xyz, rgb = camera_cloud(args.rows, args.cols)
        write_cloud(d / "cam.npy", PointCloud(xyz=xyz))
        write_cloud(d / "cam.ply", PointCloud(xyz=xyz.reshape(-1, 3), rgb=rgb.reshape(-1, 3)))
        print(
            f"{args.cols} x {args.rows} points, float32 mm, 20 % NaN, uchar colours: .npy "
            f"{(d / 'cam.npy').stat().st_size / 1e6:.0f} MB, PLY "
            f"{(d / 'cam.ply').stat().st_size / 1e6:.0f} MB; {args.repeats} interleaved runs of "
            "each, after one warm-up round"
        )

        def plain(script: str, source: str, target: str) -> list[str]:
            return [sys.executable, "-c", script, str(d / source), str(d / target), T_mm]

        def ours(source: str, target: str) -> list[str]:
            hand_eye = ["--mode", "eye-to-hand", "--calibration", str(CALIBRATION)]
            return [cli, "cloud", *hand_eye, str(d / source), str(d / target)]

        npy_jobs = {
            NUMPY: plain(NUMPY_JOB, "cam.npy", "np.npy"),
            OURS_NPY: ours("cam.npy", "o.npy"),
        }
        ply_jobs = {OURS_PLY: ours("cam.ply", "o.ply")}
        if installed("open3d"):
            ply_jobs[OPEN3D] = plain(OPEN3D_JOB, "cam.ply", "open3d.ply")
        if installed("plyfile"):
            ply_jobs[PLYFILE] = plain(PLYFILE_JOB, "cam.ply", "plyfile.ply")
        summaries = side_by_side(npy_jobs | ply_jobs, args.repeats)

    ply_yardstick = OPEN3D if OPEN3D in ply_jobs else PLYFILE
    if ply_yardstick != OPEN3D:
        print("open3d is not installed here: the PLY job is compared with plyfile's")
    print("\n.npy -> .npy")
    print_table({name: summaries[name] for name in npy_jobs}, NUMPY)
    print("\nPLY -> PLY")
    print_table({name: summaries[name] for name in ply_jobs}, ply_yardstick)
    print()
    npy_ratio = summaries[OURS_NPY].median_s / summaries[NUMPY].median_s
    print(
        f".npy -> .npy: {npy_ratio:.2f} x the numpy script's time: "
        f"{verdict(npy_ratio <= NPY_TIME_TARGET)} the target of at most {NPY_TIME_TARGET} x"
    )
    time_ratio = summaries[OURS_PLY].median_s / summaries[ply_yardstick].median_s
    peak_ratio = summaries[OURS_PLY].peak_mib / summaries[ply_yardstick].peak_mib
    ok = time_ratio < 1.0 and peak_ratio <= PLY_PEAK_TARGET
    print(
        f"PLY -> PLY: {time_ratio:.2f} x the time and {peak_ratio:.2f} x the peak memory of "
        f"{ply_yardstick}: {verdict(ok)} the target (faster, at most {PLY_PEAK_TARGET} x the peak)"
    )


if __name__ == "__main__":
    main()
