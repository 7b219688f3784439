"""A UDP receiver that records datagrams with their arrival times: the other end of the
loopback checks (tests/live, perf/live_jitter.py) and of ``--listen``.

:class:`DatagramRecorder` binds a UDP socket (127.0.0.1 unless told) and reads it on
a thread, stamping each datagram with the monotonic clock as it is read.
"""

from __future__ import annotations

import errno
import socket
import threading
import time

from blendvoca.errors import UserError

#: Largest datagram read (an OSC bundle of 52 shapes is about 2 KB).
MAX_DATAGRAM = 65535


class DatagramRecorder:
    """Datagrams arriving at ``host:port`` (port 0: any free one, :attr:`port`), recorded as
    ``(monotonic seconds, bytes)`` in :attr:`datagrams` while the recorder is open (a context manager).

    Raises
    ------
    UserError
        The port is in use or cannot be bound (naming it and what to do).
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 0, *, option: str = "--listen"):
        self.datagrams: list[tuple[float, bytes]] = []
        self._arrived = threading.Condition()
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
            self._sock.bind((host, int(port)))
        except OSError as error:
            self._sock.close()
            if error.errno == errno.EADDRINUSE:
                raise UserError(f"{option}: port {port} on {host} is in use by another program; stop it or choose "
                                "another port") from None
            raise UserError(f"{option}: cannot listen on {host}:{port} ({error.strerror or error})") from None
        self._sock.settimeout(0.05)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, name="blendvoca-live-receiver", daemon=True)

    @property
    def port(self) -> int:
        return self._sock.getsockname()[1]

    def _read(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._sock.recv(MAX_DATAGRAM)
            except socket.timeout:
                continue
            except OSError:
                return
            now = time.monotonic()
            with self._arrived:
                self.datagrams.append((now, data))
                self._arrived.notify_all()

    def wait(self, count: int, timeout: float) -> bool:
        """Wait until ``count`` datagrams have arrived or ``timeout`` seconds have passed; whether they did."""
        with self._arrived:
            return self._arrived.wait_for(lambda: len(self.datagrams) >= count, timeout)

    def __enter__(self) -> DatagramRecorder:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        self._sock.close()
