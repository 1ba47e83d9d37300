"""Controller profiles: which UR controller generation the simulator pretends to be.

- `e-series`: PolyScope 5.15, 500 Hz, dashboard server, programs on the script port (default).
- `cb3`: PolyScope 3.15, 125 Hz, CB3 arms (UR3/UR5/UR10), the fields and dashboard of a CB3.
- `polyscope-x`: PolyScope X 10.7, 500 Hz, RTDE as on e-Series, no dashboard server and no
  script port (ur_rtde 1.6.5 neither opens 29999 nor uploads its script on 10.x, so the control
  script must already run, as an operator starts it from the pendant; the simulator starts
  with it running).
"""

from __future__ import annotations

from dataclasses import dataclass

from mocks.ur_controller import fields
from mocks.ur_controller.kinematics import CB3_MODELS, MODELS

CB3_START_S_PER_LINE = 0.002
"""Time a CB3 takes to stop a program and start a received one, per line of the new program
(s): a public field measurement on a CB3, 344 lines about 0.7 s and 204 lines about 0.4 s,
about 2 ms a line either way (README.md, "Program start cost")."""
E_SERIES_START_S_PER_LINE = 0.001
"""The same on e-Series and PolyScope X: no public figure was found; an estimate, half the
CB3's, for a newer control box. Measure it on the robot (benchmarks/path_start.py)."""


@dataclass(frozen=True)
class Profile:
    """What one controller generation serves. `version` is (major, minor, bugfix, build)."""

    name: str
    version: tuple[int, int, int, int]
    cycle_hz: float  # control loop (and maximum RTDE output) frequency
    models: tuple[str, ...]
    default_model: str
    dashboard: bool  # dashboard server on 29999
    script_port: bool  # programs accepted on 30003
    control_script_running: bool  # ur_rtde's control script runs from the start
    remote_control_mode: bool  # local/remote control exists (e-Series 5.6+)
    program_start_s_per_line: float  # start cost of a received program, per line (README.md)
    output_types: dict[str, str]
    input_types: dict[str, str]

    @property
    def version_text(self) -> str:
        return ".".join(str(n) for n in self.version)


def _profile(name: str, version: tuple[int, int, int, int], cycle_hz: float,
             models: tuple[str, ...], default_model: str, *, dashboard: bool,
             control_script_running: bool) -> Profile:
    cb3 = version[0] == 3
    short = version[:3]
    return Profile(
        name=name, version=version, cycle_hz=cycle_hz, models=models,
        default_model=default_model, dashboard=dashboard, script_port=dashboard,
        control_script_running=control_script_running,
        remote_control_mode=dashboard and short >= (5, 6, 0),
        program_start_s_per_line=CB3_START_S_PER_LINE if cb3 else E_SERIES_START_S_PER_LINE,
        output_types=fields.types_for(fields.OUTPUTS, short),
        input_types=fields.types_for(fields.INPUTS, short),
    )


PROFILES: dict[str, Profile] = {
    "e-series": _profile("e-series", (5, 15, 0, 1234), 500.0, tuple(MODELS), "ur5e",
                         dashboard=True, control_script_running=False),
    "cb3": _profile("cb3", (3, 15, 8, 106339), 125.0, tuple(CB3_MODELS), "ur5",
                    dashboard=True, control_script_running=False),
    # An older e-Series for clients that only read: no Remote Control (5.6) and no tcp_offset
    # output (5.5.1); ur_rtde 1.6.5's control interface is not meant to run against it.
    "e-series-5.4": _profile("e-series-5.4", (5, 4, 3, 77771), 500.0, tuple(MODELS), "ur5e",
                             dashboard=True, control_script_running=False),
    "polyscope-x": _profile("polyscope-x", (10, 7, 0, 1234), 500.0, tuple(MODELS), "ur5e",
                            dashboard=False, control_script_running=True),
}
DEFAULT_PROFILE = "e-series"
