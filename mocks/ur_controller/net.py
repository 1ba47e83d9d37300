"""A TCP listener that serves each client in its own thread and can drop every client at once.

Used for every port the simulated controller serves (RTDE 30004, dashboard 29999, script 30003,
Robotiq 63352, admin 30999). A connection drop (fault `drop-connection`) closes every client
socket while the listening socket stays open, like a network blip. A port that cannot be bound
raises `CannotListen`, which says which address, port and server.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from collections.abc import Callable

log = logging.getLogger("mocks.ur_controller")


class CannotListen(OSError):
    """A port that cannot be bound; ``errno`` is the bind's (EADDRINUSE: taken, EADDRNOTAVAIL:
    not an address of this computer) and ``strerror`` says which address, port and server."""


class Listener:
    """Listens on (host, port); calls `serve(sock)` in a new thread for each accepted client."""

    def __init__(self, host: str, port: int, name: str, serve: Callable[[socket.socket], None]):
        self.host = host
        self.port = port
        self.name = name
        self._serve = serve
        self._sock: socket.socket | None = None
        self._clients: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        self._closing = False

    def start(self) -> None:
        """Bind and listen; returns once the port accepts connections."""
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            where = f"{self.host}:{self.port} ({self.name})"
            raise CannotListen(exc.errno, f"cannot listen on {where}: {exc.strerror or exc}"
                               ) from exc
        sock.listen(8)
        self._sock = sock
        thread = threading.Thread(
            target=self._accept_loop, args=(sock,), name=f"{self.name}-accept", daemon=True
        )
        thread.start()
        self._threads.append(thread)

    def _accept_loop(self, sock: socket.socket) -> None:
        while True:
            try:
                client, _ = sock.accept()
            except OSError:
                return  # listening socket closed by close()
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._lock:
                if self._closing:
                    client.close()
                    return
                self._clients.add(client)
                thread = threading.Thread(
                    target=self._run_client, args=(client,), name=f"{self.name}-client", daemon=True
                )
                self._threads = [t for t in self._threads if t.is_alive()]
                self._threads.append(thread)
            thread.start()

    def _run_client(self, client: socket.socket) -> None:
        try:
            self._serve(client)
        except OSError:
            pass  # the peer went away or drop_clients() closed the socket: nothing to report
        except Exception:
            log.exception("%s: client handler failed", self.name)
        finally:
            with self._lock:
                self._clients.discard(client)
            client.close()

    def drop_clients(self) -> None:
        """Close every client connection; keep listening."""
        with self._lock:
            clients = list(self._clients)
        for client in clients:
            with contextlib.suppress(OSError):  # already closed by the peer
                client.shutdown(socket.SHUT_RDWR)

    def close(self) -> None:
        """Stop listening, close every client and wait for the handler threads."""
        with self._lock:
            self._closing = True
        if self._sock is not None:
            with contextlib.suppress(OSError):  # not every platform shuts down a listener
                self._sock.shutdown(socket.SHUT_RDWR)
            self._sock.close()
        self.drop_clients()
        for thread in list(self._threads):
            thread.join(timeout=2.0)


def recv_exactly(sock: socket.socket, size: int) -> bytes:
    """Read exactly `size` bytes; raises ConnectionError when the peer closes first."""
    chunks = bytearray()
    while len(chunks) < size:
        chunk = sock.recv(size - len(chunks))
        if not chunk:
            raise ConnectionError("peer closed the connection")
        chunks += chunk
    return bytes(chunks)
