"""Play the clip at its frame rate, and step through it."""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer

from app.state import AppState

DEFAULT_FPS = 25.0
"""Playback rate of a clip whose frame rate nobody knows (an image folder, unless set)."""


class Player(QObject):
    """Advance ``state.frame`` on a timer, looping at the end of the clip."""

    def __init__(self, state: AppState, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self._state = state
        self._timer = QTimer(self)
        self._timer.timeout.connect(self._tick)
        state.sourceChanged.connect(self.stop)

    @property
    def playing(self) -> bool:
        return self._timer.isActive()

    def toggle(self) -> None:
        """Play or pause."""
        if self.playing:
            self.stop()
        elif self._state.n_frames > 1:
            fps = self._state.fps or DEFAULT_FPS
            self._timer.start(max(1, round(1000 / fps)))

    def stop(self, *_changed) -> None:
        self._timer.stop()

    def step(self, delta: int) -> None:
        """Move ``delta`` frames (clamped), pausing playback."""
        self.stop()
        self._state.set_frame(self._state.frame + delta)

    def go_to(self, frame: int) -> None:
        """Jump to ``frame`` (-1: the last), pausing playback."""
        self.stop()
        self._state.set_frame(frame if frame >= 0 else self._state.n_frames - 1)

    def _tick(self) -> None:
        n = self._state.n_frames
        if n:
            self._state.set_frame((self._state.frame + 1) % n)
