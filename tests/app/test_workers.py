"""Background jobs (progress, cancel, errors) and the latest-wins frame loader."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from app.workers import FrameLoader, Job, JobRunner
from gaitcore.errors import GaitInputError
from gaitcore.progress import Cancelled


@pytest.fixture
def runner(qapp):
    r = JobRunner()
    yield r
    r.shutdown()


def test_a_job_reports_progress_and_its_result(qtbot, runner):
    def work(progress):
        for i in range(5):
            progress(i + 1, 5)
        return 42

    job = Job(work, "Counting")
    with qtbot.waitSignal(job.succeeded, timeout=5000) as result:
        runner.start(job)
    assert result.args == [42]
    qtbot.waitUntil(lambda: not runner.busy)


def test_cancel_stops_a_job_at_its_next_progress_report(qtbot, runner):
    started = threading.Event()

    def work(progress):
        for i in range(1000):
            started.set()
            if progress(i, 1000) is False:
                raise Cancelled("stopped")
            time.sleep(0.005)
        return "finished"

    job = Job(work, "Slow")
    runner.start(job)
    assert started.wait(5)
    with qtbot.waitSignal(job.cancelled, timeout=5000):
        job.cancel()


def test_input_errors_arrive_as_one_line(qtbot, runner):
    def work(progress):
        raise GaitInputError("the clip is empty: choose another file")

    job = Job(work, "Failing")
    with qtbot.waitSignal(job.failed, timeout=5000) as message:
        runner.start(job)
    assert message.args == ["the clip is empty: choose another file"]


class SlowSource:
    """A fake FrameSource whose frames take 30 ms to decode and that counts decodes."""

    def __init__(self):
        self.decoded = []

    def frame(self, i):
        time.sleep(0.03)
        self.decoded.append(i)
        return np.full((4, 4, 3), i, np.uint8)


def test_the_frame_loader_decodes_only_the_latest_request(qtbot, qapp):
    loader = FrameLoader()
    source = SlowSource()
    loader.set_source(source)
    shown = []
    loader.frameLoaded.connect(lambda i, img: shown.append(i))
    for i in range(30):
        loader.request(i)
    qtbot.waitUntil(lambda: bool(shown) and shown[-1] == 29, timeout=5000)
    loader.stop()
    assert len(source.decoded) < 5, source.decoded


def test_shutdown_delivers_the_last_signals_of_its_jobs_before_it_returns(qtbot, runner):
    """A job's ``finished`` arrives before shutdown returns, while its receivers still live.

    Delivered later, it would reach a window the caller has deleted meanwhile (a teardown
    error in CI: "Signal source has been deleted").
    """
    release = threading.Event()
    heard: list[str] = []

    def work(progress):
        release.wait(5)
        return "done"

    job = Job(work, "Closing")
    job.finished.connect(lambda: heard.append("finished"))
    runner.start(job)
    threading.Timer(0.1, release.set).start()
    runner.shutdown()
    assert heard == ["finished"] and not runner.busy
