"""Work on threads of their own beside the caller's: decoding ahead of it
(:func:`prefetched`), writing or outlining behind it (:class:`InOrder`). OpenCV lets go of
the GIL in its calls, so on two cores these overlap the caller's Python."""

from __future__ import annotations

import queue
import threading
from collections import deque
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import Future, ThreadPoolExecutor


def prefetched(items: Iterator, depth: int) -> Generator:
    """Run ``items`` on a daemon thread, ``depth`` items ahead; errors reach the consumer."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    done = object()

    def work() -> None:
        try:
            for item in items:
                while not stop.is_set():
                    try:
                        q.put(item, timeout=0.05)
                        break
                    except queue.Full:
                        pass
                if stop.is_set():
                    break
            else:
                q.put(done)
        except BaseException as exc:  # noqa: BLE001 - re-raised in the consuming thread
            q.put(exc)
        finally:
            items.close()

    thread = threading.Thread(target=work, name="gaitcore-decode", daemon=True)
    thread.start()
    try:
        while (item := q.get()) is not done:
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        while thread.is_alive():  # unblock a producer waiting on a full queue
            try:
                q.get_nowait()
            except queue.Empty:
                thread.join(timeout=0.05)


class InOrder:
    """Calls run one at a time, in the order given, on a thread of their own; at most
    ``ahead`` wait, so the caller goes on with its own work meanwhile.

    Use it as a context manager: leaving it waits for every call, or, on an error, for the
    one running only. An error raised on the thread reaches the caller at its next
    :meth:`submit`, or on leaving.
    """

    def __init__(self, name: str, ahead: int = 8) -> None:
        self._ahead = max(1, ahead)
        self._pending: deque[Future] = deque()
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)

    def submit(self, fn: Callable[..., object], *args) -> None:
        while len(self._pending) >= self._ahead:
            self._pending.popleft().result()
        self._pending.append(self._pool.submit(fn, *args))

    def __enter__(self) -> InOrder:
        return self

    def __exit__(self, kind, *_) -> None:
        try:
            while self._pending and kind is None:
                self._pending.popleft().result()
        finally:
            self._pool.shutdown(wait=True, cancel_futures=True)
