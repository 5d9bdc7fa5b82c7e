"""One thread pool for the bake's heavy blocks: NumPy and Embree both release the GIL on large
arrays, so whole blocks (form factors, then their rays) run side by side on every core."""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Callable, Iterable, Iterator, TypeVar

from .progress import REPORT_INTERVAL, heartbeat

Item = TypeVar("Item")
Result = TypeVar("Result")

THREADS = max(1, min(os.cpu_count() or 1, 16))
_pool = ThreadPoolExecutor(max_workers=THREADS, thread_name_prefix="radiosity")


def map_ordered(function: Callable[[Item], Result], items: Iterable[Item]) -> Iterator[Result]:
    """Results of ``function`` over ``items`` in order, computed THREADS at a time ahead of the
    consumer (so a slow consumer, or one that stops early, does not queue unbounded work); while
    it waits, the running bake's caller hears that it goes on (``progress.heartbeat``)."""
    pending = []
    try:
        for item in items:
            pending.append(_pool.submit(function, item))
            if len(pending) > THREADS:
                yield waited(pending.pop(0))
        while pending:
            yield waited(pending.pop(0))
    finally:  # the consumer stopped early (a cancel, an error): drop the work not yet started
        for future in pending:
            future.cancel()


def waited(future: Future) -> Result:
    """``future``'s result, the caller told every REPORT_INTERVAL that the bake goes on."""
    while True:
        try:
            result = future.result(timeout=REPORT_INTERVAL)
        except TimeoutError:
            heartbeat()
            continue
        heartbeat()
        return result


def submit(function: Callable[..., Result], *args) -> Future:
    """Start ``function(*args)`` on the pool, beside the blocks of ``map_ordered``."""
    return _pool.submit(function, *args)
