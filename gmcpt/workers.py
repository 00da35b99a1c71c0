"""Coarse-grained CPU parallelism: a few Python threads that each run torch on one thread.

Completion parallelises by splitting its work into fixed parts (tiles of reference patches,
bands of the generator's input) and running them on Python threads, each with torch
single-threaded, instead of letting torch's OpenMP pool split every small operation: the
OpenMP barrier stalls badly when another process holds a core (measured on 2 cores: the
generator 0.13 s on one thread, 0.6-1.8 s on two while another process ran). Results come
back in part order, so the output does not depend on scheduling, and the thread count moves it
by float rounding at most.

The threads live as long as the process: starting two threads for every call cost about
10 ms a frame.
"""
from __future__ import annotations

import contextlib
import functools
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, TypeVar

Item = TypeVar("Item")
Result = TypeVar("Result")


@functools.lru_cache(maxsize=None)
def _pool(threads: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(threads, thread_name_prefix="gmcpt-worker")


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


def map_single_threaded(function: Callable[[Item], Result], items: Iterable[Item], threads: int) -> list[Result]:
    """``[function(item) for item in items]`` on ``threads`` threads, torch on one thread in each.

    With one thread (or one item) it runs in the caller's thread, with torch on one thread
    there too; the caller's torch thread count is restored afterwards.
    """
    import torch

    items = list(items)
    with torch_threads(1):
        if threads <= 1 or len(items) <= 1:
            return [function(item) for item in items]

        def task(item):
            torch.set_num_threads(1)
            return function(item)

        return list(_pool(min(threads, len(items))).map(task, items))
