"""The robot boundary: a small Protocol (port.py) and its ur_rtde adapter."""
