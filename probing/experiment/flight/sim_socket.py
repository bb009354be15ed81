"""The flight computer's side of JSBSim's input socket: a text client over TCP.

A JSBSim whose aircraft has ``<input type="SOCKET" port="P" protocol="TCP"/>`` answers
lines ending in ``\\r\\n``: ``set <property> <value>`` (``set successful``), ``get
<property>`` (``<property> = <value>``, printed with 6 significant digits), ``hold``
(``Holding``), ``resume`` (``Resuming``), ``iterate <n>``, ``quit`` (closes the connection
only: the simulator goes on, held or flying, and a held one polls its socket on a core for
ever).  It has no command that ends the simulator; ``set simulation/terminate 1`` does
(``FGFDMExec::Run`` returns false and JSBSim's loop ends, held or not), and the client sends
it before ``quit`` when it closes (:meth:`SimSocket.close`).  With
``action="BLOCKING_INPUT"`` a running simulator waits in every frame, after integrating the
state and before the flight-control system, until a message comes, and answers every
command in it: one message is one frame.  A ``hold`` in that message stops the frame there
(the held simulator integrates nothing and runs no flight-control system) until a later
message resumes it: :meth:`SimSocket.held_get` then :meth:`SimSocket.resume_with` read a
frame's values before its commands are written.  Each reply line is followed by the
prompt ``JSBSim> `` in a segment of its own; the client reads reply *lines* and never waits
for a prompt, and acknowledges every segment at once (:data:`QUICKACK`).
"""

from __future__ import annotations

import ipaddress
import socket
import time

from probing.core.errors import ProbingError

__all__ = [
    "PORTS",
    "SimConnectionError",
    "SimConnectionLost",
    "SimSocket",
    "is_loopback",
    "is_port",
    "parse_address",
]

PROMPT = "JSBSim> "

#: The property that ends JSBSim's run (``FGFDMExec``'s ``Terminate``).
TERMINATE = "simulation/terminate"

#: Acknowledge each segment at once (Linux): JSBSim sends a reply and its prompt in separate
#: small segments, and with Nagle's algorithm on its side each one after the first waits for
#: the acknowledgement of the one before, which a delayed ACK holds back 40 ms.
QUICKACK = getattr(socket, "TCP_QUICKACK", None)


#: The TCP ports a simulator's input socket can take (JSBSim reads 0 as no port given).
PORTS = range(1, 65536)

#: How :data:`PORTS` reads in a message.
PORTS_TEXT = f"a port {PORTS.start}..{PORTS.stop - 1}"


def is_port(port: int) -> bool:
    """True if ``port`` is one of :data:`PORTS`."""
    return port in PORTS


class SimConnectionError(ProbingError, ConnectionError):
    """The simulator cannot be reached or answered something else; the message says which."""


class SimConnectionLost(SimConnectionError):
    """The simulator closed the connection: it ended, or was killed, or its socket was reset.

    Attributes
    ----------
    where : str
        The simulator's ``host:port``.
    reason : str or None
        The system's word for it (``"Connection reset by peer"``); None for an orderly close.
    """

    def __init__(self, where: str, reason: str | None = None) -> None:
        self.where, self.reason = where, reason
        super().__init__(f"{where} closed the connection" + (f" ({reason})" if reason else ""))


#: What the system says when the other end of a connection has gone.
_GONE = (ConnectionResetError, ConnectionAbortedError, BrokenPipeError)


def _failed(where: str, exc: OSError) -> SimConnectionError:
    """The error of a send or receive that raised ``exc``: :class:`SimConnectionLost` when
    the simulator has gone."""
    if isinstance(exc, _GONE):
        return SimConnectionLost(where, exc.strerror or exc.__class__.__name__)
    return SimConnectionError(f"{where}: {exc}")


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` -> (host, port).

    Raises
    ------
    ValueError
        If it is not ``HOST:PORT`` with a port in :data:`PORTS`.
    """
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not is_port(int(port)):
        raise ValueError(f"--connect {text!r}: give HOST:PORT ({PORTS_TEXT})")
    return host.strip("[]"), int(port)


def is_loopback(host: str) -> bool:
    """True if ``host`` names this machine's loopback (``localhost``, 127.0.0.0/8, ``::1``);
    a name is not resolved: any other is treated as remote."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class SimSocket:
    """A connection to a JSBSim input socket.

    Parameters
    ----------
    host, port
        Where the simulator listens.
    timeout_s : float
        The longest wait for a connection or a reply, s.

    Attributes
    ----------
    wait_s : float
        Time spent waiting for the simulator's replies since the connection, s.
    """

    def __init__(self, host: str, port: int, timeout_s: float = 10.0) -> None:
        self.where = f"{host}:{port}"
        try:
            self.sock = socket.create_connection((host, port), timeout=timeout_s)
        except OSError as exc:
            reason = exc.strerror or exc.__class__.__name__
            raise SimConnectionError(f"no simulator at {self.where} ({reason})") from None
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.buffer = ""
        self.wait_s = 0.0
        greeting = self._lines(1)[0]
        if "JSBSim" not in greeting:
            self.sock.close()
            raise SimConnectionError(f"{self.where} is not a JSBSim input socket: {greeting!r}")

    def _lines(self, count: int) -> list[str]:
        """The next ``count`` reply lines (prompts removed)."""
        lines: list[str] = []
        start = time.perf_counter()
        while len(lines) < count:
            while "\r\n" not in self.buffer:
                try:
                    if QUICKACK is not None:  # every time: the kernel turns it off again
                        self.sock.setsockopt(socket.IPPROTO_TCP, QUICKACK, 1)
                    data = self.sock.recv(65536)
                except OSError as exc:
                    raise _failed(self.where, exc) from None
                if not data:
                    raise SimConnectionLost(self.where)
                self.buffer += data.decode("ascii", "replace")
            line, self.buffer = self.buffer.split("\r\n", 1)
            line = line.replace(PROMPT, "").strip()
            if line:
                lines.append(line)
        self.wait_s += time.perf_counter() - start
        return lines

    def _send(self, commands: list[str]) -> list[str]:
        """Send ``commands`` together; their replies, one line each."""
        try:
            self.sock.sendall("".join(f"{c}\r\n" for c in commands).encode("ascii"))
        except OSError as exc:
            raise _failed(self.where, exc) from None
        return self._lines(len(commands))

    def hold(self) -> None:
        """Stop the simulator's clock (``hold``)."""
        self._expect(["hold"], ["Holding"])

    def resume(self) -> None:
        """Start the simulator's clock (``resume``)."""
        self._expect(["resume"], ["Resuming"])

    def exchange(self, values: dict[str, float], names: list[str]) -> list[float]:
        """Write ``values`` (full precision) and read the properties ``names`` in one message:
        with a blocking input socket, one frame of the simulator."""
        commands = [f"set {name} {value!r}" for name, value in values.items()]
        replies = self._send([*commands, *(f"get {n}" for n in names)])
        for command, reply in zip(commands, replies, strict=False):
            if reply != "set successful":
                raise SimConnectionError(f"{self.where}: {command}: {reply!r}")
        return [
            _value(self.where, n, line)
            for n, line in zip(names, replies[len(commands) :], strict=True)
        ]

    def held_get(self, names: list[str]) -> list[float]:
        """Hold the simulator in the frame it waits in and read ``names`` (one message): the
        rest of that frame waits for :meth:`resume_with`."""
        replies = self._send(["hold", *(f"get {n}" for n in names)])
        if replies[0] != "Holding":
            raise SimConnectionError(f"{self.where}: hold: {replies[0]!r}")
        return [_value(self.where, n, line) for n, line in zip(names, replies[1:], strict=True)]

    def resume_with(self, values: dict[str, float]) -> None:
        """Write ``values`` (full precision) and resume (one message): the held frame goes on
        with them."""
        commands = [*(f"set {name} {value!r}" for name, value in values.items()), "resume"]
        wanted = [*(["set successful"] * len(values)), "Resuming"]
        self._expect(commands, wanted)

    def get(self, names: list[str]) -> list[float]:
        """The properties ``names`` (6 significant digits: JSBSim's reply)."""
        return self.exchange({}, names)

    def _expect(self, commands: list[str], wanted: list[str]) -> None:
        """Send ``commands``; their replies must be ``wanted``."""
        for command, reply, ok in zip(commands, self._send(commands), wanted, strict=True):
            if reply != ok:
                raise SimConnectionError(f"{self.where}: {command}: {reply!r}")

    def close(self) -> None:
        """End the simulator's run (``set simulation/terminate 1``: a simulator that has flown
        cannot fly again, and held it would poll its socket on a core), say ``quit`` and
        close; a simulator that is gone already is let be."""
        try:
            self._expect([f"set {TERMINATE} 1"], ["set successful"])
            self.sock.sendall(b"quit\r\n")
        except (OSError, SimConnectionError):
            pass
        self.sock.close()


def _value(where: str, name: str, line: str) -> float:
    """The value in a ``get`` reply ``<name> = <value>``."""
    key, sep, value = line.partition(" = ")
    if not sep or key.strip() != name:
        raise SimConnectionError(f"{where}: get {name}: {line!r}")
    return float(value)
