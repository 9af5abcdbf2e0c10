"""``gaitcore batch`` end to end on Dask: a local cluster, a scheduler and workers started as
separate processes, and a batch interrupted with SIGINT then resumed."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gaitcore.bench.clip_library import make_library, write_manifest
from gaitcore.cli import main
from gaitcore.project.batch import RESULT_NAME, read_summary
from tests.gaitcore.walker import walker_clip, write_mask_folder

ROOT = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).parent / "dask"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
pytestmark = pytest.mark.slow


def _gaitcore(*args: str, cwd: Path = ROOT, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "gaitcore.cli", *args], env=ENV, cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kwargs)


def _walker_library(folder: Path, n_clips: int, n_frames: int) -> Path:
    rows = ["path"]
    for k in range(n_clips):
        write_mask_folder(folder / f"w{k}", walker_clip(n_frames, period=16.0 + 2 * k))
        rows.append(f"w{k}")
    (folder / "manifest.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    return folder / "manifest.csv"


def _stop(procs: list[subprocess.Popen]) -> None:
    for p in procs:
        if p.poll() is None:
            p.terminate()
    for p in procs:
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait(timeout=5)


def test_thirty_clips_periods_verdicts_and_errors(tmp_path, capsys):
    lib = tmp_path / "lib"
    lib.mkdir()
    clips = make_library(
        lib, gaits={"walk": (32, 44), "trot": (20, 28), "canter": (16, 22), "gallop": (12, 18)},
        speeds=(0.0, 0.5, 1.0), n_frames=80, videos_every=6, still=2, jitter=3, corrupt=1)
    assert len(clips) == 30 and sum(c.path.endswith(".avi") for c in clips) == 4
    manifest = write_manifest(lib / "manifest.csv", clips)
    assert main(["batch", str(manifest), "--out", str(tmp_path / "out"), "--workers", "2"]) == 0
    rows = {r.clip: r for r in read_summary(tmp_path / "out" / "summary.json")}
    assert len(rows) == 30
    for c in clips:
        row = rows[c.clip]
        if c.corrupt:
            assert row.status == "failed" and row.error, c.clip
        elif c.period_frames is None:
            assert row.status == "done" and row.verdict == "not usable", (c.clip, row)
        else:
            assert row.status == "done" and row.usable, (c.clip, row)
            assert abs(row.period_frames - c.period_frames) <= 1.0, (c.clip, row.period_frames)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_batch_on_a_scheduler_and_two_workers_started_apart(tmp_path):
    """Workers in folders of their own; the batch's --out relative to where it was started:
    every clip lands under --out all the same."""
    from distributed import Client

    manifest = _walker_library(tmp_path, n_clips=4, n_frames=80)
    homes = [tmp_path / f"worker{k}" for k in range(2)]
    for home in homes:
        home.mkdir()
    address = f"tcp://127.0.0.1:{_free_port()}"
    procs = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port",
                               address.rsplit(":", 1)[1], "--no-dashboard"], env=ENV,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        procs += [subprocess.Popen([str(DASK), "worker", address, "--nworkers", "1", "--nthreads",
                                    "1", "--no-dashboard", "--name", f"w{k}"], env=ENV,
                                   cwd=homes[k], stdout=subprocess.DEVNULL,
                                   stderr=subprocess.DEVNULL)
                  for k in range(2)]
        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        run = _gaitcore("batch", manifest.name, "--out", "out", "--scheduler", address,
                        cwd=tmp_path)
        out, err = run.communicate(timeout=180)
        assert run.returncode == 0, err
        assert f"scheduler {address}: 2 worker(s)" in err
        rows = read_summary(tmp_path / "out" / "summary.csv")
        assert [r.status for r in rows] == ["done"] * 4
        assert all((tmp_path / "out" / r.clip / "result.json").is_file() for r in rows)
        assert not any(any(home.iterdir()) for home in homes), "a clip left --out"
        assert "4 analysed, 0 skipped" in out
    finally:
        _stop(procs[::-1])


def test_interrupted_batch_resumes_without_computing_a_finished_clip_twice(tmp_path):
    manifest = _walker_library(tmp_path, n_clips=10, n_frames=240)
    out = tmp_path / "out"
    # Ctrl+C's default in the command, whatever this process inherited: a shell that starts
    # a job in the background (xvfb-run under `make test &`) hands it SIGINT ignored.
    run = _gaitcore("batch", str(manifest), "--out", str(out), "--workers", "1",
                    preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list(out.glob(f"*/{RESULT_NAME}"))) < 2:
            time.sleep(0.2)
        run.send_signal(signal.SIGINT)
        _, err = run.communicate(timeout=60)
    finally:
        _stop([run])
    assert run.returncode == 130, err
    assert err.strip().splitlines()[-1] == "gaitcore: interrupted"
    first = read_summary(out / "summary.json")
    done = {r.clip for r in first if r.status == "done"}
    assert 2 <= len(done) < 10  # stopped mid-way
    assert {r.status for r in first} <= {"done", "pending"}
    on_disk = {p.parent.name for p in out.glob(f"*/{RESULT_NAME}")}
    assert done == on_disk  # the summary says what the folders hold
    stamps = {c: (out / c / RESULT_NAME).stat().st_mtime_ns for c in on_disk}

    rerun = _gaitcore("batch", str(manifest), "--out", str(out), "--workers", "1")
    stdout, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    assert f"{len(on_disk)} clip(s) already done, skipped" in err
    assert f"{10 - len(on_disk)} analysed, {len(on_disk)} skipped" in stdout
    for clip, stamp in stamps.items():  # never written again
        assert (out / clip / RESULT_NAME).stat().st_mtime_ns == stamp, clip
    final = read_summary(out / "summary.json")
    assert [r.status for r in final] == ["done"] * 10
    assert not list(out.glob(".*partial*"))
    data = json.loads((out / "summary.json").read_text())
    assert [c["clip"] for c in data["clips"]] == [f"w{k}" for k in range(10)]
