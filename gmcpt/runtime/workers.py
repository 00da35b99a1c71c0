"""Coarse-grained CPU parallelism: a few Python threads, for torch on one thread each or for numpy work.

Completion parallelises by splitting its work into fixed parts (tiles of reference patches,
bands of the generator's input) and running them on Python threads, each with torch
single-threaded, instead of letting torch's OpenMP pool split every small operation: the
OpenMP barrier stalls badly when another process holds a core (measured on 2 cores: the
generator 0.13 s on one thread, 0.6-1.8 s on two while another process ran). Results come
back in part order, so the output does not depend on scheduling, and the thread count moves it
by float rounding at most. Numpy releases the GIL in its loops, so the guided fill's bands of rows
run on the same threads (:func:`map_threads`).

The threads live as long as the process: starting two threads for every call cost about
10 ms a frame.
"""
from __future__ import annotations

import contextlib
import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, TypeVar

from ..errors import BadValue

Item = TypeVar("Item")
Result = TypeVar("Result")


_THREAD_PREFIX = "gmcpt-worker"
#: Caps completion's threads: the generator's torch (:func:`gmcpt.runtime.device.generator_threads`) and the numpy work
#: here (:func:`cpu_threads`), so that one setting caps both.
THREADS_ENV = "GMCPT_TORCH_THREADS"


@functools.lru_cache(maxsize=None)
def _pool(threads: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(threads, thread_name_prefix=_THREAD_PREFIX)


@contextlib.contextmanager
def torch_threads(threads: int):
    """Run the block with torch on ``threads`` threads, restoring the caller's count afterwards."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(previous)


def threads_setting() -> int | None:
    """``$GMCPT_TORCH_THREADS`` as a count of threads, None where unset; else a one-line :class:`BadValue`."""
    value = os.environ.get(THREADS_ENV)
    if value is None:
        return None
    if not value.strip().isdigit() or int(value) < 1:
        raise BadValue(f"${THREADS_ENV} must be a whole number of threads, at least 1, not {value!r}")
    return int(value)


def cpu_threads() -> int:
    """The threads completion's numpy work runs on: :func:`threads_setting` where set, else the cores this
    process may run on."""
    setting = threads_setting()
    if setting is not None:
        return setting
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def map_threads(function: Callable[[Item], Result], items: Iterable[Item], threads: int) -> list[Result]:
    """``[function(item) for item in items]`` on up to ``threads`` of the process's threads (in the caller's
    where one thread or one item, or when called from one of them: a task that waited on tasks of its own pool
    could wait for ever): for work that releases the GIL, as numpy's loops do."""
    items = list(items)
    if threads <= 1 or len(items) <= 1 or threading.current_thread().name.startswith(_THREAD_PREFIX):
        return [function(item) for item in items]
    return list(_pool(min(threads, len(items))).map(function, items))


def map_single_threaded(function: Callable[[Item], Result], items: Iterable[Item], threads: int) -> list[Result]:
    """``[function(item) for item in items]`` on ``threads`` threads, torch on one thread in each.

    With one thread (or one item) it runs in the caller's thread, with torch on one thread
    there too; the caller's torch thread count is restored afterwards.
    """
    import torch

    def task(item):
        torch.set_num_threads(1)
        return function(item)

    with torch_threads(1):
        return map_threads(task, items, threads)
