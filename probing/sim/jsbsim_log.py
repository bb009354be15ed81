"""JSBSim's messages kept in memory (:class:`JSBSimLog`), never printed: the warnings and
errors among them are added to the :class:`~probing.sim.errors.TrimError` a failed trim
raises."""

from __future__ import annotations

import collections

import jsbsim

__all__ = ["JSBSimLog"]


class JSBSimLog(jsbsim.FGLogger):
    """JSBSim's log records, kept instead of printed: nothing of JSBSim reaches stdout.

    Records below ``WARN`` (debug chatter, reports JSBSim would print on stdout) are
    dropped; the latest ``keep`` warnings and errors are kept for error messages.
    """

    def __init__(self, keep: int = 20) -> None:
        super().__init__()
        self._level = jsbsim.LogLevel.BULK
        self._parts: list[str] = []
        self.records: collections.deque[str] = collections.deque(maxlen=keep)

    def set_level(self, level: jsbsim.LogLevel) -> None:
        self._level, self._parts = level, []

    def file_location(self, filename: str, line: int) -> None:
        pass

    def message(self, message: str) -> None:
        self._parts.append(message)

    def format(self, format: jsbsim.LogFormat) -> None:
        pass

    def flush(self) -> None:
        if jsbsim.LogLevel.WARN <= self._level <= jsbsim.LogLevel.FATAL:
            text = " ".join("".join(self._parts).split())
            if text:
                self.records.append(text)
        self._parts = []

    def take(self) -> str:
        """The kept records as one line (``"; "``-joined), and forget them."""
        text = "; ".join(self.records)
        self.records.clear()
        return text
