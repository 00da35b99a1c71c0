import threading

import pytest

from gmcpt.runtime.workers import THREADS_ENV, cpu_threads, map_threads


def test_map_threads_keeps_the_order_and_runs_on_the_pool():
    names = []

    def square(item):
        names.append(threading.current_thread().name)
        return item * item

    assert map_threads(square, range(7), 3) == [i * i for i in range(7)]
    assert all(name.startswith("gmcpt-worker") for name in names)
    names.clear()
    assert map_threads(square, [4], 3) == [16] and names == [threading.current_thread().name]


def test_map_threads_called_from_its_own_pool_runs_inline_and_does_not_wait_for_ever():
    """Two tasks that each map over the pool of two threads would wait on each other's queue."""
    done = []

    def outer(item):
        return map_threads(lambda inner: (item, inner), range(3), 2)

    worker = threading.Thread(target=lambda: done.append(map_threads(outer, range(2), 2)), daemon=True)
    worker.start()
    worker.join(timeout=20)
    assert not worker.is_alive()
    assert done == [[[(0, 0), (0, 1), (0, 2)], [(1, 0), (1, 1), (1, 2)]]]


def test_one_setting_caps_the_fills_threads_and_the_generators(monkeypatch):
    from gmcpt.runtime.device import generator_threads
    from gmcpt.errors import GmcptError

    monkeypatch.delenv(THREADS_ENV, raising=False)
    cores = cpu_threads()
    assert cores >= 1
    monkeypatch.setenv(THREADS_ENV, str(cores + 3))
    assert cpu_threads() == generator_threads() == cores + 3
    for bad in ("0", "two", "-1", ""):
        monkeypatch.setenv(THREADS_ENV, bad)
        with pytest.raises(GmcptError, match=THREADS_ENV):
            cpu_threads()
