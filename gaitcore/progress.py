"""Progress of long computations, and how they are cancelled.

Every long gaitcore function takes ``progress(done, total) -> bool``: it is called as the
work advances, and returning False (the GUI's Cancel) stops the work with :class:`Cancelled`.
"""

from __future__ import annotations

from collections.abc import Callable

Progress = Callable[[int, int], bool]


class Cancelled(Exception):
    """The work was stopped because its progress callback returned False (Cancel, Ctrl+C)."""


def report(progress: Progress | None, done: int, total: int, cancelled: str) -> None:
    """Tell ``progress`` (if any) how far the work is.

    Raises
    ------
    Cancelled
        With the message ``cancelled`` when ``progress`` returned False.
    """
    if progress is not None and progress(done, total) is False:
        raise Cancelled(cancelled)
