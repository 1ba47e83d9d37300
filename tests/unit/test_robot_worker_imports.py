"""The ur_rtde child process starts light: robot/ur/worker.py, run by file path, imports only
the standard library at start (ur_rtde once it connects), never the package, which would load
numpy and more on every connection. What it needs from the package (the Remote Control rule of
robot/ur/dashboard.py) the parent applies."""

from __future__ import annotations

import json
import subprocess
import sys

from handeye_pick.robot.ur.child import WORKER_SCRIPT

_PROBE = """
import json, runpy, sys
before = set(sys.modules)
runpy.run_path(sys.argv[1], run_name="worker")  # its definitions, not its main()
print(json.dumps(sorted(set(sys.modules) - before)))
"""


def test_the_worker_imports_neither_the_package_nor_numpy() -> None:
    result = subprocess.run(
        [sys.executable, "-c", _PROBE, str(WORKER_SCRIPT)],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    loaded = json.loads(result.stdout)
    # __mp_main__: multiprocessing's alias of the main module, no import
    top_level = {name.split(".")[0] for name in loaded if name != "__mp_main__"}
    assert top_level.isdisjoint({"handeye_pick", "numpy", "rtde_control", "rtde_receive"}), loaded
    assert top_level <= set(sys.stdlib_module_names), top_level - set(sys.stdlib_module_names)
