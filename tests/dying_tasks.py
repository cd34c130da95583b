"""Tasks that end their worker process, for the executor's fault tests (a module of its own, light to import:
a spawned worker imports it by name before it runs one)."""

from __future__ import annotations

import os
import time


def dies_on_two(x: int) -> int:
    """End the worker process at once on ``x == 2`` (as a crash in compiled code or the system's out-of-memory
    killer would, exit code 3); otherwise return ``x`` after 0.2 s."""
    if x == 2:
        os._exit(3)
    time.sleep(0.2)
    return x


def dies(task: object) -> object:
    """End the worker process at once (exit code 3), whatever the task."""
    os._exit(3)
