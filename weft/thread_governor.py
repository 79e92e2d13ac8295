"""Solver threads that give way when other processes want the cores.

weft's OpenMP threads meet at barriers hundreds of times per substep (the drape: about 360
parallel regions per substep). A thread that reaches one first spins a while
(`GOMP_SPINCOUNT`, set in `weft/__init__.py`) before it sleeps in the kernel: on an idle
machine a spin that outlasts the serial gaps between regions saves a futex wake-up per region,
but beside a process that keeps a core busy a spinning thread takes the core from the very
thread it waits for, and every region then waits for a time slice (docs/linear-system.md,
"The thread governor"). No spin count is right for both.

The governor watches each frame's CPU wait: how long the process's threads were runnable but
not running (the kernel's run delay, the second field of `/proc/self/task/*/schedstat`), per
solver thread and second of the frame. On an idle 2-core machine that share is mostly below
0.05, but a frame in a hundred or so reaches 0.1-0.3 as the machine's own services wake;
beside one busy process it is about 0.4 in every frame. When it passes `CONTENDED_SHARE` in
`CONTENDED_FRAMES` frames in a row, the next frames run on half the threads (at least one,
which waits for nothing). Fewer threads cannot tell whether the cores are free again, so after
`FIRST_PROBE` frames the governor tries twice the threads (up to the requested count) for a
frame; a try that finds the cores still taken (one frame above the share is enough there) goes
back and doubles the wait before the next one (at most `LONGEST_PROBE` frames). The solver's
results are bitwise the same for any thread count, so these changes never change a trajectory
(`tests/weft/test_thread_governor.py`).

Without `/proc/self/task/*/schedstat` (not Linux, a kernel without schedstats) or with
`WEFT_THREAD_GOVERNOR=off` in the environment, the threads stay as requested.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

CONTENDED_SHARE = 0.25  # CPU wait per solver thread and wall second above which threads give way
CONTENDED_FRAMES = 2  # ...in this many frames in a row (a try at more threads: one)
FIRST_PROBE = 8  # frames on fewer threads before the governor tries more
LONGEST_PROBE = 128  # the longest wait between probes
ENVIRONMENT_SWITCH = "WEFT_THREAD_GOVERNOR"  # "off": threads stay as requested

_TASKS = Path("/proc/self/task")


def cpu_wait_seconds() -> float | None:
    """Seconds the threads of this process have spent runnable but waiting for a CPU, summed
    (threads that ended are not counted); None where the kernel does not report it."""
    total = 0
    found = False
    try:
        tasks = list(_TASKS.iterdir())
    except OSError:
        return None
    for task in tasks:
        try:
            fields = (task / "schedstat").read_text().split()
        except OSError:  # the thread ended meanwhile, or no schedstats
            continue
        if len(fields) >= 2:
            total += int(fields[1])
            found = True
    return total * 1e-9 if found else None


def governor_enabled() -> bool:
    """False when `WEFT_THREAD_GOVERNOR=off` (or 0, false, no) is in the environment."""
    return os.environ.get(ENVIRONMENT_SWITCH, "on").strip().lower() not in {"off", "0", "false", "no"}


class ThreadGovernor:
    """Chooses the solver threads frame by frame for a Simulation (`sim.threads`) asked to run on
    `requested` threads. Wrap each frame's solver call in `frame()`; `last_cpu_wait_share` is
    that frame's CPU wait per thread and wall second (0 where not measured; None before a frame;
    the threads it ran on are in the solver's own frame telemetry).
    The CPU wait is measured wherever the kernel reports it; the threads change only when
    `adapting` (more than one requested, not switched off, and a solver build whose Simulation
    has `threads`: `bench.module_ab` loads older ones)."""

    def __init__(self, sim: Any, requested: int, enabled: bool | None = None) -> None:
        if requested < 1:
            raise ValueError(f"threads: must be at least 1, got {requested}")
        self.sim = sim
        self.requested = requested
        self.measuring = cpu_wait_seconds() is not None
        self.settable = hasattr(type(sim), "threads")
        self.adapting = (self.measuring and self.settable and requested > 1
                         and (governor_enabled() if enabled is None else enabled))
        self.probe_interval = FIRST_PROBE
        self.frames_since_change = 0
        self.contended_frames = 0  # frames in a row above CONTENDED_SHARE
        self.probing = False
        self.last_cpu_wait_share: float | None = None
        if self.settable and sim.threads != requested:
            sim.threads = requested

    @contextmanager
    def frame(self) -> Iterator[None]:
        """Measures the frame run inside the block and chooses the next frame's threads."""
        threads = self.sim.threads if self.settable else self.requested
        wait_before = cpu_wait_seconds() if self.measuring else None
        start = time.perf_counter()
        yield
        wall = time.perf_counter() - start
        wait_after = cpu_wait_seconds() if wait_before is not None else None
        if wait_before is None or wait_after is None or wall <= 0.0:
            self.last_cpu_wait_share = 0.0
            return
        share = max(0.0, wait_after - wait_before) / (wall * threads)
        self.last_cpu_wait_share = share
        if self.adapting:
            self.choose(threads, share)

    def choose(self, threads: int, share: float) -> None:
        """The next frame's threads after a frame on `threads` with CPU wait `share`."""
        self.frames_since_change += 1
        self.contended_frames = self.contended_frames + 1 if share > CONTENDED_SHARE else 0
        if threads > 1 and self.contended_frames >= (1 if self.probing else CONTENDED_FRAMES):
            if self.probing:  # the cores were still taken: wait longer before the next try
                self.probe_interval = min(2 * self.probe_interval, LONGEST_PROBE)
            self._set(max(1, threads // 2), probing=False)
        elif self.probing:  # the try ran uncontended: stay, and try again soon if still short
            self.probe_interval = FIRST_PROBE
            self.probing = False
        elif threads < self.requested and self.frames_since_change >= self.probe_interval:
            self._set(min(self.requested, 2 * threads), probing=True)

    def _set(self, threads: int, probing: bool) -> None:
        self.sim.threads = threads
        self.frames_since_change = 0
        self.contended_frames = 0
        self.probing = probing
