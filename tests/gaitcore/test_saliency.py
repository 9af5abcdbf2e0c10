"""The salient-object network as a cue of the silhouettes (gaitcore.silhouettes.saliency)."""

from __future__ import annotations

import numpy as np
import pytest

from gaitcore.cli import main
from gaitcore.footage.sources import open_frames
from gaitcore.silhouettes.annotations import Rect
from gaitcore.silhouettes.roto import RotoSegmentation
from gaitcore.silhouettes.saliency import SaliencyTrack, saliency_missing, saliency_model
from tests.gaitcore.test_roto_session import shaded_scene


def test_the_model_is_installed():
    """`make` fetches it (scripts/fetch_saliency_model.py); without it every cut is weaker."""
    assert saliency_missing() is None, saliency_missing()


def test_a_body_faded_by_a_shade_is_kept_where_colour_alone_lost_it(tmp_path):
    """The shaded scene: a brown body fades half-way to the grass on frames 5-7. The key's
    colours alone lose it on frames 6 and 7 (test_roto_session); the network still sees a
    body there, so the mask is kept and stays on it."""
    if saliency_model() is None:
        pytest.skip(saliency_missing())
    folder = tmp_path / "shade"
    box = shaded_scene(folder)
    with open_frames(folder) as source:
        seg = RotoSegmentation(source, box=box)
        seg.run()
        states = [seg.state(t) for t in range(seg.n)]
        assert not any(st.lost for st in states)
        for t in (5, 6, 7):
            mask = seg.mask(t)
            x = 50 + 3 * t  # the body's centre (shaded_scene)
            assert mask[60, x] and not mask[10, x] and not mask[110, x]


def test_a_missing_model_is_said_and_the_cut_goes_on(tmp_path, capsys, without_saliency):
    folder = tmp_path / "shade"
    b = shaded_scene(folder)
    assert main(["segment", str(folder), "--out", str(tmp_path / "out"), "--box",
                 f"{b.x},{b.y},{b.w},{b.h}"]) == 0
    err = capsys.readouterr().err
    assert "saliency model is not installed" in err and "run `make`" in err
    assert len(list((tmp_path / "out" / "masks").glob("*.png"))) == 12


class _Counting:
    """A stand-in network: its log-odds are the number of times it was asked."""

    def __init__(self) -> None:
        self.calls = 0

    def log_odds(self, image: np.ndarray) -> np.ndarray:
        self.calls += 1
        return np.full(image.shape[:2], float(self.calls), np.float32)


def test_the_track_runs_the_network_every_few_frames_and_carries_it_between():
    net = _Counting()
    track = SaliencyTrack(net, every=3)  # type: ignore[arg-type]
    window, shape = (2, 2, 10, 10), (12, 12)
    here = np.zeros((8, 8, 3), np.uint8)
    shifted: list[float] = []

    def carry(values: np.ndarray) -> np.ndarray:  # the flow: a shift by one row
        shifted.append(float(values[2:10, 2:10].mean()))
        return np.roll(values[2:10, 2:10], 1, axis=0)

    seen = [float(track.step(here, window, shape, carry).mean()) for _ in range(7)]
    assert net.calls == 3  # frames 0, 3 and 6
    assert seen == [1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 3.0]
    assert len(shifted) == 4  # carried on the frames between


def test_a_box_around_a_whole_rendered_horse_is_cut_from_the_network():
    """With no background left around the box, GrabCut refuses (test_roto); the network's
    map of the box finds the horse."""
    from gaitcore.bench import generate_gait
    from gaitcore.rig.render import render_clip
    from gaitcore.rig.templates import load_template

    if saliency_model() is None:
        pytest.skip(saliency_missing())
    horse = load_template("horse")
    frames, truth = render_clip(horse, generate_gait(horse, "canter", 4), width=320, height=240)
    seg = RotoSegmentation(list(frames), box=Rect(0, 0, 320, 239))
    first = seg.work.enlarge(seg._first_cut().mask)
    inter = np.logical_and(first, truth[0]).sum()
    assert inter / np.logical_or(first, truth[0]).sum() > 0.8


def test_the_first_frames_map_is_drawn_in_float32():
    """The propagated frames' cue may run in bfloat16 (where the processor has it, twice as
    fast); the box's map, the first cut, is drawn in float32."""
    net = saliency_model()
    if net is None:
        pytest.skip(saliency_missing())
    rng = np.random.default_rng(3)
    image = rng.integers(0, 255, (120, 160, 3)).astype(np.uint8)
    image[40:90, 50:120] = (30, 60, 200)
    box = (50, 40, 70, 50)
    inside = net.in_box(image, box, grow=0.0)[40:90, 50:120]
    assert np.array_equal(inside, net(image[40:90, 50:120], exact=True))
    assert np.abs(net(image[40:90, 50:120]) - inside).mean() < 0.05  # the same map, roughly


def _maps(net, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return net(image), net(image, exact=True)


def test_the_compiled_network_is_kept_for_the_next_run_and_draws_the_same_map(
        tmp_path, monkeypatch):
    """A run keeps OpenVINO's copies of the network (and their compiled forms) in the cache;
    the next one compiles from them, and draws the very same maps as a run without a cache.
    A damaged copy is read again from the model file and written again; an empty
    GAIT_CACHE_DIR keeps nothing."""
    from gaitcore.silhouettes.saliency import Saliency, compiled_cache, model_path

    if saliency_model() is None:
        pytest.skip(saliency_missing())
    image = np.random.default_rng(4).integers(0, 255, (90, 120, 3)).astype(np.uint8)
    image[30:60, 40:90] = (40, 70, 190)
    monkeypatch.setenv("GAIT_CACHE_DIR", "")
    assert compiled_cache() is None
    uncached = _maps(Saliency(model_path()), image)

    monkeypatch.setenv("GAIT_CACHE_DIR", str(tmp_path / "cache"))
    stale = tmp_path / "cache" / "openvino" / "2020.1"  # an older OpenVINO's
    stale.mkdir(parents=True)
    first = Saliency(model_path())
    assert not stale.exists()
    (kept,) = (tmp_path / "cache" / "openvino").iterdir()
    copies = sorted(kept.glob("*.xml"))
    assert len(copies) == 2 and all(c.with_suffix(".bin").is_file() for c in copies)
    for got, want in zip(_maps(first, image), uncached):
        assert np.array_equal(got, want)
    assert list(kept.glob("*.blob"))  # compiled forms kept

    again = Saliency(model_path())
    assert all(isinstance(source, str) for source in again._sources.values())
    for got, want in zip(_maps(again, image), uncached):
        assert np.array_equal(got, want)

    for c in copies:
        c.write_text("<net")
    for blob in kept.glob("*.blob"):
        blob.unlink()
    mended = Saliency(model_path())
    for got, want in zip(_maps(mended, image), uncached):
        assert np.array_equal(got, want)
    assert all(c.stat().st_size > 100_000 for c in copies)
    copies[0].with_suffix(".bin").write_bytes(b"\0" * 64)  # weights cut short
    for got, want in zip(_maps(Saliency(model_path()), image), uncached):
        assert np.array_equal(got, want)
