"""The live view: the recording's channels served through the Foxglove SDK's WebSocket server
(subprotocol ``foxglove.sdk.v1``), which Foxglove and Lichtblick open as a live connection.
It serves data only: no services, no parameters, no messages taken from clients."""

from __future__ import annotations

import foxglove
from foxglove.websocket import WebSocketServer

from handeye_pick.errors import InputError


def start_live(context: foxglove.Context, host: str, port: int) -> WebSocketServer:
    """Serve ``context``'s channels on ``host:port`` (port 0: any free one, see ``.port``)."""
    try:
        return foxglove.start_server(name="handeye-pick", host=host, port=port, context=context)
    except RuntimeError as exc:  # the SDK's word for an address it cannot bind
        raise InputError(f"run --live {host}:{port}: cannot serve ({exc})") from None
