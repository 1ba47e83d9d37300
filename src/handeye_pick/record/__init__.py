"""Recording and live view of a cell session (MCAP files and a WebSocket server through the
Foxglove SDK): ``publisher.Publisher`` is the session's observer; docs/recording.md."""
