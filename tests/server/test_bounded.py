"""Submissions are validated in bounded child processes (server/bounded.py, issue 15): a 765 KiB
.npz that expanded to 822 MB, or a 53 MB JSON that stalled the API for 3.3 s, cost the API
process itself. Real spawned processes with real limits."""

from __future__ import annotations

import asyncio
import time

import pytest

from server.bounded import BoundedValidator
from server.errors import ApiError


def allocate(megabytes: int) -> int:
    block = bytearray(megabytes * 2**20)
    return len(block)


def sleep_then(seconds: float, value: str) -> str:
    time.sleep(seconds)
    return value


def refuse(field: str) -> None:
    raise ApiError(422, f"invalid shot: {field}: bad", [{"field": field, "problem": "bad"}])


def test_a_child_over_its_memory_limit_is_a_422_and_the_next_call_works() -> None:
    validator = BoundedValidator(processes=1, memory_bytes=512 * 2**20, timeout_seconds=60)
    try:
        with pytest.raises(ApiError) as info:
            asyncio.run(validator.run(allocate, 1024))
        assert info.value.status == 422 and "memory limit of 512 MiB" in info.value.detail
        assert asyncio.run(validator.run(allocate, 16)) == 16 * 2**20
    finally:
        validator.close()


def test_a_call_over_its_time_limit_is_killed_and_the_next_call_works() -> None:
    validator = BoundedValidator(processes=1, memory_bytes=0, timeout_seconds=5)
    try:
        assert asyncio.run(validator.run(sleep_then, 0.0, "warm")) == "warm"  # the child is up
        validator.timeout_seconds = 0.5
        start = time.monotonic()
        with pytest.raises(ApiError) as info:
            asyncio.run(validator.run(sleep_then, 30.0, "never"))
        assert time.monotonic() - start < 5, "the caller does not wait for the runaway child"
        assert info.value.status == 422 and "longer than 0.5 s" in info.value.detail
        validator.timeout_seconds = 60
        assert asyncio.run(validator.run(sleep_then, 0.0, "fresh pool")) == "fresh pool"
    finally:
        validator.close()


def test_the_shots_own_errors_come_back_unchanged() -> None:
    validator = BoundedValidator(processes=1, memory_bytes=0, timeout_seconds=60)
    try:
        with pytest.raises(ApiError) as info:
            asyncio.run(validator.run(refuse, "cloth[0].mesh"))
        assert (info.value.status, info.value.errors) == (422, [{"field": "cloth[0].mesh", "problem": "bad"}])
    finally:
        validator.close()


def child_pid() -> int:
    import os

    return os.getpid()


def test_children_end_with_their_api_process(tmp_path) -> None:
    """An API process killed outright must not leave validation children behind (they waited on
    their task queue forever, one set per stopped stack)."""
    import os
    import signal
    import subprocess
    import sys

    script = tmp_path / "parent.py"
    script.write_text(
        "import asyncio, sys\n"
        "from server.bounded import BoundedValidator\n"
        "from tests.server.test_bounded import child_pid\n"
        "if __name__ == '__main__':\n"
        "    v = BoundedValidator(processes=1, memory_bytes=0, timeout_seconds=60)\n"
        "    print(asyncio.run(v.run(child_pid)), flush=True)\n"
        "    sys.stdin.read()\n"
    )
    parent = subprocess.Popen([sys.executable, str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                              cwd=os.getcwd(), env={**os.environ, "PYTHONPATH": os.getcwd()})
    child = int(parent.stdout.readline())
    os.kill(child, 0)  # alive while its parent lives
    parent.send_signal(signal.SIGKILL)
    parent.wait()

    def gone() -> bool:
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            return True
        with open(f"/proc/{child}/stat") as stat:
            return stat.read().split()[2] == "Z"  # a zombie waiting for its reaper is gone too

    deadline = time.monotonic() + 10
    while not gone() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert gone(), "the validation child outlived its API process"
