"""The UR controller through ur_rtde (in a child process) and read from outside."""
