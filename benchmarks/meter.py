"""CPU seconds and calls of wrapped functions, for the benchmarks that split an answer's CPU (many_answers,
later_answers): each wraps the package's functions it times or counts in a :class:`Meter`."""

from __future__ import annotations

import time
from typing import Any


class Meter:
    """CPU seconds and calls of wrapped functions, by name (nested calls of one name counted once)."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = {}
        self.calls: dict[str, int] = {}
        self._depth: dict[str, int] = {}

    def wrap(self, owner: Any, attr: str, name: str) -> None:
        inner = getattr(owner, attr)

        def timed(*args: Any, **kwargs: Any) -> Any:
            self.calls[name] = self.calls.get(name, 0) + 1
            self._depth[name] = self._depth.get(name, 0) + 1
            t0 = time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                self._depth[name] -= 1
                if self._depth[name] == 0:
                    self.cpu[name] = self.cpu.get(name, 0.0) + time.process_time() - t0

        setattr(owner, attr, timed)

    def take(self) -> tuple[dict[str, float], dict[str, int]]:
        """The CPU and calls since the last take."""
        cpu, calls = dict(self.cpu), dict(self.calls)
        self.cpu.clear()
        self.calls.clear()
        return cpu, calls
