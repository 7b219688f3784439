"""A UDP receiver that records datagrams with their arrival times: the other end of the
loopback checks (tests/live, perf/live_jitter.py) and of ``--listen``.

:class:`DatagramRecorder` binds a UDP socket (127.0.0.1 unless told) and reads it on
a thread, stamping each datagram with the monotonic clock as it is read;
:func:`record_take` writes the Live Link packets it heard as a Live Link Face take
(``python -m blendvoca.live --listen livelink://HOST:PORT --out take.csv``: what this
command or Epic's app sends, recorded).
"""

from __future__ import annotations

import errno
import socket
import threading
import time

import numpy as np

from blendvoca.errors import DataError, UserError

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


def parse_listen(text: str) -> tuple[str, int]:
    """``(host, port)`` of a ``--listen livelink://HOST:PORT`` address (a UserError for anything else)."""
    from urllib.parse import urlsplit

    parts = urlsplit(str(text))
    expected = "expected livelink://HOST:PORT, e.g. livelink://127.0.0.1:11111 (0.0.0.0 to hear a phone)"
    if parts.scheme != "livelink" or "//" not in str(text):
        raise UserError(f"--listen {text}: {'the scheme ' + repr(parts.scheme) if parts.scheme else 'no scheme'}; "
                        f"{expected} (only Live Link packets are recorded)")
    try:
        port = parts.port
    except ValueError:
        raise UserError(f"--listen {text}: the port is no number in 1..65535; {expected}") from None
    if not parts.hostname or not port or parts.path not in ("", "/") or parts.query or parts.fragment:
        raise UserError(f"--listen {text}: {expected}")
    return parts.hostname, port


def record_take(host: str, port: int, out, *, frames: int | None, seconds: float | None) -> int:
    """Record Live Link Face packets arriving at ``host:port`` until ``frames`` have arrived,
    ``seconds`` have passed or Ctrl-C, and write them as a Live Link Face take ``out`` (the
    packets' rate; malformed datagrams skipped and counted). Returns the frames written.

    Raises
    ------
    UserError
        The port is in use; no packet arrived; packets of several subjects or rates.
    """
    from blendvoca.io.livelink import write_livelink_take
    from blendvoca.live.livelink_udp import decode_packet
    from blendvoca.names import ARKIT_FACE_ORDER

    with DatagramRecorder(host, port, option="--listen") as recorder:
        deadline = None if seconds is None else time.monotonic() + seconds
        try:
            while frames is None or len(recorder.datagrams) < frames:
                if deadline is not None and time.monotonic() >= deadline:
                    break
                recorder.wait(len(recorder.datagrams) + 1, 0.1)
        except KeyboardInterrupt:
            pass
    packets, bad = [], 0
    for _, data in recorder.datagrams[:frames]:
        try:
            packets.append(decode_packet(data))
        except DataError:
            bad += 1
    if not packets:
        raise UserError(f"--listen {host}:{port}: no Live Link packet arrived"
                        + (f" ({bad} malformed datagrams)" if bad else ""))
    kinds = {(p.subject, p.rate) for p in packets}
    if len(kinds) > 1:
        raise UserError(f"--listen {host}:{port}: packets of several subjects or rates arrived ({sorted(kinds)}); "
                        "record one subject at a time")
    packets.sort(key=lambda p: p.frame_number)
    (numerator, denominator), = {p.rate for p in packets}
    values = np.stack([p.values for p in packets]).astype(np.float64)
    write_livelink_take(out, values[:, :52], ARKIT_FACE_ORDER, numerator / denominator, pose=values[:, 52:])
    return len(packets)
