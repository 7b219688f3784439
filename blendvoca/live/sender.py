"""Where frames go (``--to livelink://HOST:PORT`` or ``osc://HOST:PORT``) and when.

:func:`parse_target` reads and resolves the address; :func:`open_socket` opens a UDP
socket connected to it; :func:`send_frames` sends datagram ``k`` at ``start + k / fps``
on the monotonic clock. Each deadline is computed from the start, never from the
previous send, so lateness never accumulates (a frame sent late does not move the
next one); a frame whose deadline has passed is sent at once, none is skipped.

UDP has no connection: a receiver that is not running yet is no error (Unreal or a
VTuber tool may be started later). The kernel reports the "port unreachable" answers
of the local host as refused sends; they are counted (:attr:`SendReport.refused`) and
the frame is sent again once. An address that does not resolve, a network that
cannot be reached, a datagram too large for the path are errors.
"""

from __future__ import annotations

import errno
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass
from urllib.parse import urlsplit

import numpy as np

from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar

#: ``--to`` schemes.
SCHEMES = ("livelink", "osc")
#: Seconds before a deadline below which :func:`wait_until` stops sleeping and polls the clock
#: (``time.sleep`` overshoots by tens of microseconds to a millisecond on a loaded machine).
SPIN_SECONDS = 0.0005

_EXPECTED = "expected livelink://HOST:PORT (Unreal's Live Link Face source, port 11111 by default) or osc://HOST:PORT"


@dataclass(frozen=True)
class Target:
    """A resolved ``--to`` address."""

    scheme: str
    host: str
    port: int
    family: int
    address: tuple

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{self.scheme}://{host}:{self.port}"


def parse_target(text: str) -> Target:
    """The ``--to`` address ``text``, its host resolved.

    Raises
    ------
    UserError
        Another scheme, no host, no port or one outside 1..65535, a path or query after
        the port, a host that does not resolve.
    """
    raw = str(text)
    parts = urlsplit(raw)
    if parts.scheme not in SCHEMES or "//" not in raw:
        got = f"the scheme {parts.scheme!r}" if parts.scheme else "no scheme"
        raise UserError(f"--to {raw}: {got}; {_EXPECTED}")
    try:
        port = parts.port
    except ValueError:
        raise UserError(f"--to {raw}: the port is no number in 1..65535; {_EXPECTED}") from None
    if not parts.hostname:
        raise UserError(f"--to {raw}: no host; {_EXPECTED}")
    if port is None or port == 0:
        raise UserError(f"--to {raw}: no port; {_EXPECTED}")
    if parts.path not in ("", "/") or parts.query or parts.fragment or parts.username:
        raise UserError(f"--to {raw}: unexpected text around HOST:PORT; {_EXPECTED}")
    try:
        family, _, _, _, address = socket.getaddrinfo(parts.hostname, port, type=socket.SOCK_DGRAM)[0]
    except (socket.gaierror, UnicodeError) as error:
        raise UserError(f"--to {raw}: the host {parts.hostname!r} does not resolve ({error})") from None
    return Target(parts.scheme, parts.hostname, port, family, address)


def open_socket(target: Target) -> socket.socket:
    """A UDP socket connected to ``target`` (a UserError when no route leads there)."""
    sock = socket.socket(target.family, socket.SOCK_DGRAM)
    try:
        sock.connect(target.address)
    except OSError as error:
        sock.close()
        raise UserError(f"--to {target}: unreachable ({error.strerror or error})") from None
    return sock


@dataclass(frozen=True)
class SendReport:
    """What :func:`send_frames` did: seconds from the start at which each frame was due and sent."""

    fps: float
    due: np.ndarray
    sent: np.ndarray
    refused: int = 0

    @property
    def frames(self) -> int:
        return len(self.sent)

    @property
    def lateness(self) -> np.ndarray:
        """Seconds each frame left after its deadline (>= 0)."""
        return self.sent - self.due

    def summary(self) -> str:
        """One line: frames, rate, duration, p50 / p99 / max lateness in milliseconds."""
        if not self.frames:
            return "sent no frame"
        late = 1000 * self.lateness
        return (f"sent {self.frames} frames at {self.fps:g} fps in {self.sent[-1]:.2f} s; lateness p50 "
                f"{np.percentile(late, 50):.3f} ms, p99 {np.percentile(late, 99):.3f} ms, max {late.max():.3f} ms")


def wait_until(deadline: float, clock: Callable[[], float] = time.monotonic) -> None:
    """Return at ``deadline`` on ``clock``: sleep until :data:`SPIN_SECONDS` before it, then poll."""
    while True:
        remaining = deadline - clock()
        if remaining <= 0:
            return
        if remaining > SPIN_SECONDS:
            time.sleep(remaining - SPIN_SECONDS)


def _send(sock: socket.socket, datagram: bytes, target) -> int:
    """Send one datagram; 1 when a refusal had to be retried, else 0."""
    for attempt in (0, 1):
        try:
            sock.send(datagram)
            return attempt
        except ConnectionRefusedError:
            continue  # the ICMP answer to an earlier datagram: reported once, then cleared
        except OSError as error:
            if error.errno == errno.EMSGSIZE:
                raise UserError(f"--to {target}: a datagram of {len(datagram)} bytes is too large for the path "
                                f"({error.strerror})") from None
            raise UserError(f"--to {target}: cannot send ({error.strerror or error})") from None
    return 1


def send_frames(sock: socket.socket, datagram: Callable[[int], bytes], count: int | None, fps: float, *,
                target=None, clock: Callable[[], float] = time.monotonic, on_start: Callable[[], None] | None = None,
                desc: str = "sending") -> SendReport:
    """Send ``datagram(k)`` for ``k = 0 .. count - 1`` (forever with ``count`` None, until Ctrl-C) at
    ``start + k / fps`` on ``clock``; ``on_start`` runs just before the start is read (audio playback).

    Returns
    -------
    SendReport
        The deadlines and send times of every frame sent (kept for the last hour at most when
        ``count`` is None).
    """
    if not fps > 0:
        raise UserError(f"frame rate must be positive, got {fps}")
    period = 1.0 / float(fps)
    keep = int(3600 * fps) if count is None else int(count)
    due, sent = np.zeros(keep), np.zeros(keep)
    refused = 0
    k = 0
    with bar(total=count, desc=desc, unit="frame") as progress:
        if on_start is not None:
            on_start()
        start = clock()
        try:
            while count is None or k < count:
                payload = datagram(k)
                deadline = start + k * period
                wait_until(deadline, clock)
                refused += _send(sock, payload, target)
                now = clock()
                due[k % keep], sent[k % keep] = deadline - start, now - start
                k += 1
                progress.update(1)
        except KeyboardInterrupt:
            if count is not None:
                raise
    n = min(k, keep)
    order = np.arange(k - n, k) % keep
    return SendReport(fps=float(fps), due=due[order], sent=sent[order], refused=refused)
