"""Event streams' share of an API process: each open stream holds a connection of the streams'
own Redis pool while it waits for events, so streams are counted per API key and in all, and a
key over its share gets 429 instead of starving the others (or the process's other requests,
which use another pool)."""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable


class StreamLimits:
    def __init__(self, per_key: int, total: int) -> None:
        self.per_key = per_key
        self.total = total
        self._open: Counter[str] = Counter()
        self._lock = threading.Lock()

    def open_count(self, owner: str | None = None) -> int:
        with self._lock:
            return self._open[owner] if owner is not None else sum(self._open.values())

    def acquire(self, owner: str) -> tuple[Callable[[], None] | None, str]:
        """A release function (idempotent) for one more stream of `owner`, or None and why not."""
        with self._lock:
            if self._open[owner] >= self.per_key:
                return None, (f"this API key has {self._open[owner]} event streams open, the limit is "
                              f"{self.per_key}: close one, or poll GET /v1/jobs/{{id}}")
            if sum(self._open.values()) >= self.total:
                return None, f"the server has {self.total} event streams open, its limit: retry later"
            self._open[owner] += 1
        released = False

        def release() -> None:
            nonlocal released
            with self._lock:
                if not released:
                    released = True
                    self._open[owner] -= 1
                    if self._open[owner] <= 0:
                        del self._open[owner]

        return release, ""
