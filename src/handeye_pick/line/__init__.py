"""The cell in the line (docs/line.md): one line state inside ``run`` and its doors.

``state`` holds the line state and its commands (cycle stop, release, stop, resume),
``counters`` the counts since ``run`` started by the shift report's own tally, ``codes`` the
last error's stable numbers, ``io`` the wired PLC handshake, ``opcua`` the OPC UA server (the
only module that imports asyncua), ``users`` its users file, and ``doors`` opens them for ``run``.
"""
