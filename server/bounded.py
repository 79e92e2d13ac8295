"""Shot validation in bounded processes: parsing a submission and loading its assets (meshes,
animation arrays) runs in a small pool of worker processes, each with an address-space limit,
and every call has a time limit, so a hostile upload (a compressed archive or an HDF5 fill value
that expands to gigabytes, a document that takes minutes to parse) costs a child process, not
the API: the API's event loop and memory stay free for every other request. A child over its
memory limit fails the submission with 422; a call over its time limit kills the pool's
processes (a fresh pool serves the next submission)."""

from __future__ import annotations

import asyncio
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

from server.errors import ApiError

T = TypeVar("T")


def _limit_child(memory_bytes: int, parent: int) -> None:
    """Runs first in each child, before numpy or the solver are imported there."""
    import resource

    _exit_with_parent(parent)
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[name] = "1"  # thread pools reserve address space the limit would count
    if memory_bytes > 0:
        resource.setrlimit(resource.RLIMIT_AS, (memory_bytes, memory_bytes))


def _exit_with_parent(parent: int) -> None:
    """A child whose API process died (killed, or stopped without closing the pool) would wait
    on its task queue forever: the kernel kills it with its parent (Linux PR_SET_PDEATHSIG), and
    a watchdog thread ends it if it was re-parented anyway."""
    import ctypes
    import signal
    import threading
    import time

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (AttributeError, OSError):
        pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(0)

    if os.getppid() != parent:
        os._exit(0)
    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


class BoundedValidator:
    def __init__(self, processes: int, memory_bytes: int, timeout_seconds: float) -> None:
        self.processes = max(1, processes)
        self.memory_bytes = memory_bytes
        self.timeout_seconds = timeout_seconds
        self._pool: ProcessPoolExecutor | None = None

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(
                max_workers=self.processes, mp_context=multiprocessing.get_context("spawn"),
                initializer=_limit_child, initargs=(self.memory_bytes, os.getpid()),
            )
        return self._pool

    def _discard(self, kill: bool) -> None:
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if kill:  # a runaway call: its process will not return by itself
            for process in list(getattr(pool, "_processes", {}).values()):
                process.kill()
        pool.shutdown(wait=False, cancel_futures=True)

    async def run(self, fn: Callable[..., T], *args: Any) -> T:
        """fn(*args) in a bounded child; ApiError (422) when the child runs out of memory, dies
        or takes longer than the time limit. fn's own exceptions (ApiError for a bad shot)
        propagate unchanged."""
        loop = asyncio.get_running_loop()
        future = loop.run_in_executor(self._executor(), fn, *args)
        try:
            return await asyncio.wait_for(future, self.timeout_seconds)
        except TimeoutError:
            self._discard(kill=True)
            raise ApiError(422, f"validating the shot and its assets took longer than {self.timeout_seconds:g} s, "
                                "this service's limit", [{"field": "shot", "problem": "validation time limit"}]) from None
        except MemoryError:
            raise ApiError(422, f"validating the shot and its assets needs more than this service's memory limit "
                                f"of {self.memory_bytes / 2**20:.0f} MiB (assets expand to too much data)",
                           [{"field": "assets", "problem": "validation memory limit"}]) from None
        except BrokenProcessPool:
            self._discard(kill=True)
            raise ApiError(422, "validating the shot and its assets stopped its process (beyond this service's "
                                f"memory limit of {self.memory_bytes / 2**20:.0f} MiB?)",
                           [{"field": "assets", "problem": "validation process died"}]) from None

    def close(self) -> None:
        """Stop the children now (they hold nothing worth waiting for)."""
        self._discard(kill=True)
