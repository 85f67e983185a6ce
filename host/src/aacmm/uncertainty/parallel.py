"""Ordered work on a thread pool with a bounded number of tasks in flight.

The analysis loops (Monte Carlo coefficients, uncertainty) cut their work into
many small tasks whose results must be combined in task order (so a result
never depends on the number of threads) and whose number may be huge (so
they must not all be created at once). :func:`in_order` gives both.
"""

from __future__ import annotations

import collections
import itertools
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: Tasks in flight per thread: enough to keep every thread busy, few enough
#: that memory does not depend on the number of tasks.
IN_FLIGHT_PER_THREAD = 2


@contextmanager
def pool(threads: int) -> Iterator[ThreadPoolExecutor | None]:
    """A thread pool of ``threads`` workers, or None for one thread (work inline)."""
    if threads == 1:
        yield None
    else:
        with ThreadPoolExecutor(max_workers=threads) as ex:
            yield ex


def in_order(
    ex: ThreadPoolExecutor | None, fn: Callable[[T], R], items: Iterable[T], threads: int
) -> Iterator[R]:
    """fn(item) for every item, in the items' order, computed on ``ex``.

    Items are taken from the iterable as they are needed, at most
    ``IN_FLIGHT_PER_THREAD * threads`` ahead of the one being yielded. On an
    exception (Ctrl-C included) or when the consumer stops early, the tasks
    not started are cancelled.
    """
    it = iter(items)
    if ex is None:
        yield from (fn(x) for x in it)
        return
    pending: collections.deque[Future[R]] = collections.deque()
    try:
        for x in itertools.islice(it, IN_FLIGHT_PER_THREAD * threads):
            pending.append(ex.submit(fn, x))
        while pending:
            yield pending.popleft().result()
            for x in itertools.islice(it, 1):
                pending.append(ex.submit(fn, x))
    finally:
        for f in pending:
            f.cancel()
