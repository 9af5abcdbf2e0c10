"""Tests of the spectral diagnosis (paper Section 5.2, equation (20))."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from gaitcore.analysis.spectrum import Diagnosis, band_pass, diagnose, fisher_periodicity_p
from gaitcore.analysis.verdict import Verdict
from gaitcore.errors import GaitInputError


def two_phase(n: int, period: float, *, phase: float = 0.3, extra: int = 3, seed: int = 0):
    """PC1 = cos, PC2 = sin of one rhythm, then ``extra`` columns of independent noise."""
    t = np.arange(n)
    w = 2 * np.pi * t / period + phase
    noise = np.random.default_rng(seed).standard_normal((n, extra))
    return np.column_stack([np.cos(w), np.sin(w), noise])


def gallop(n: int, period: float, *, seed: int = 0) -> np.ndarray:
    """Non-sinusoidal periodic PCs; PC2 (and PC3) carry more second harmonic than fundamental."""
    t = np.arange(n)
    w = 2 * np.pi * t / period
    rng = np.random.default_rng(seed)
    pc1 = np.cos(w) + 0.6 * np.cos(2 * w + 0.5) + 0.3 * np.cos(3 * w + 1.0)
    pc2 = 0.5 * np.sin(w) + 1.0 * np.sin(2 * w + 0.2)
    pc3 = 0.2 * np.cos(w) + 0.8 * np.cos(2 * w + 1.3) + 0.3 * rng.standard_normal(n)
    return np.column_stack([pc1, pc2, pc3]) + 0.05 * rng.standard_normal((n, 3))


# --- clean periodic clips -------------------------------------------------------------------


def test_two_phase_sinusoid_whole_cycles_is_usable():
    diag = diagnose(two_phase(144, 24.0))  # 6 whole cycles
    assert isinstance(diag, Diagnosis)
    assert diag.verdict is Verdict.USABLE
    assert diag.correlations.shape == (5,)
    assert diag.correlations[0] >= 0.99 and diag.correlations[1] >= 0.99
    assert np.all(np.abs(diag.correlations[2:]) <= 0.35)
    assert abs(diag.period_frames - 24.0) <= 1.0
    assert "Usable" in diag.reason and f"{diag.period_frames:.1f} frames" in diag.reason


@pytest.mark.parametrize(("n", "period"), [(137, 24.0), (100, 28.0), (100, 40.0), (54, 36.0)])
def test_two_phase_sinusoid_fractional_cycles_is_usable(n, period):
    # 137 frames = 5.7 cycles: a circular FFT band-pass would leak here (r about 0.97).
    diag = diagnose(two_phase(n, period))
    assert diag.verdict is Verdict.USABLE
    assert diag.correlations[0] >= 0.99 and diag.correlations[1] >= 0.99
    assert abs(diag.period_frames - period) <= 0.07 * period


@pytest.mark.parametrize(("n", "period"), [(540, 36.0), (300, 27.3), (200, 13.7), (90, 9.5)])
@pytest.mark.parametrize("phase", [0.0, 1.1, 2.5])
def test_period_is_accurate_to_a_frame(n, period, phase):
    x = two_phase(n, period, phase=phase)
    x[:, :2] += 0.1 * np.random.default_rng(1).standard_normal((n, 2))
    diag = diagnose(x)
    assert abs(diag.period_frames - period) <= 1.0
    assert diag.period_frames == pytest.approx(1 / diag.f0)


def test_period_of_long_clip_is_much_better_than_a_frame():
    diag = diagnose(two_phase(540, 36.0))
    assert abs(diag.period_frames - 36.0) <= 0.1


@pytest.mark.parametrize("phase", [0.0, 0.7, 1.9, 3.0, 4.4])
def test_short_clip_of_one_and_a_half_cycles_gives_a_sensible_period(phase):
    diag = diagnose(two_phase(54, 36.0, phase=phase))
    assert abs(diag.period_frames - 36.0) <= 4.0
    assert "No gait cycle" not in diag.reason


def test_harmonics_still_give_the_fundamental():
    x = gallop(200, 30.0)
    diag = diagnose(x)
    # The trap: PC2's largest amplitude is at the second harmonic, PC1's at the fundamental.
    assert diag.frequencies[np.argmax(diag.amplitudes[:, 1])] == pytest.approx(2 / 30, abs=0.003)
    assert abs(diag.period_frames - 30.0) <= 1.0


def test_fitted_peak_is_one_at_f0_half_at_fb_and_a_tenth_at_band_edges():
    diag = diagnose(two_phase(137, 24.0))
    assert diag.peak(diag.f0) == 1.0
    assert diag.peak(diag.fb) == 0.5
    assert diag.peak(np.array(diag.band)) == pytest.approx([0.1, 0.1])
    width = abs(diag.fb - diag.f0)
    assert diag.band == pytest.approx((diag.f0 - 3 * width, diag.f0 + 3 * width))
    # The half-width of a clean peak is set by the clip length: about 0.6 / n.
    assert width * 137 == pytest.approx(0.6, abs=0.1)


def test_fb_is_where_pc1_amplitude_halves():
    diag = diagnose(two_phase(137, 24.0))
    amp = np.interp(diag.fb, diag.frequencies, diag.amplitudes[:, 0])
    assert amp == pytest.approx(0.5 * diag.amplitudes[:, 0].max(), rel=0.01)


def test_spectrum_arrays_have_documented_shapes():
    x = two_phase(100, 20.0)
    diag = diagnose(x)
    m = diag.frequencies.shape[0]
    assert diag.amplitudes.shape == (m, 5)
    assert diag.filtered.shape == x.shape
    assert diag.frequencies[0] == 0.0 and diag.frequencies[-1] == 0.5
    assert np.all(np.diff(diag.frequencies) > 0)
    # A unit sinusoid shows a peak of height about 1.
    assert diag.amplitudes[:, 0].max() == pytest.approx(1.0, abs=0.1)


def test_scaling_the_input_scales_outputs_but_not_the_verdict():
    x = two_phase(137, 24.0)
    a, b = diagnose(x), diagnose(x * 1e-200)
    assert b.verdict is a.verdict and b.f0 == pytest.approx(a.f0)
    np.testing.assert_allclose(b.correlations, a.correlations, atol=1e-9)
    np.testing.assert_allclose(b.filtered, a.filtered * 1e-200, rtol=1e-9, atol=1e-215)


def test_high_r3_is_a_note_not_a_verdict_change():
    x = two_phase(144, 24.0)
    x[:, 2] = x[:, 0] + 0.1 * x[:, 2]  # PC3 follows the same rhythm
    diag = diagnose(x)
    assert diag.correlations[2] > 0.9
    assert diag.verdict is Verdict.USABLE
    assert "Note: r3 = " in diag.reason


def test_two_components_are_enough():
    diag = diagnose(two_phase(96, 16.0, extra=0))
    assert diag.verdict is Verdict.USABLE
    assert diag.correlations.shape == (2,)
    assert "Note" not in diag.reason


# --- clips that fail the criterion ----------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4, 5])
def test_white_noise_is_not_usable(seed):
    x = np.random.default_rng(seed).standard_normal((137, 5))
    diag = diagnose(x)
    assert diag.verdict is Verdict.NOT_USABLE
    assert diag.periodicity_p > 0.01
    assert diag.correlations[0] < 0.6
    assert "No rhythm" in diag.reason
    assert diagnose(x, sketched=True).verdict is Verdict.NOT_USABLE


def test_fisher_test_separates_a_noisy_rhythm_from_noise():
    rng = np.random.default_rng(5)
    t = np.arange(137)
    assert fisher_periodicity_p(np.cos(2 * np.pi * t / 24) + rng.standard_normal(137)) < 1e-6
    p_values = [fisher_periodicity_p(np.random.default_rng(s).standard_normal(137))
                for s in range(200)]
    # Under the null hypothesis p is uniform: about 1 % of noise clips fall below 0.01.
    assert 0 <= sum(p < 0.01 for p in p_values) <= 6


def test_pc2_without_the_rhythm_suggests_sketching():
    x = two_phase(144, 24.0)
    x[:, 1] = np.random.default_rng(7).standard_normal(144)
    diag = diagnose(x)
    assert diag.correlations[0] >= 0.99 and diag.correlations[1] < 0.6
    assert diag.verdict is Verdict.TRY_SKETCHING
    assert "PC2 does not" in diag.reason


def test_threshold_is_honoured():
    x = two_phase(137, 24.0)
    x[:, :2] += 0.3 * np.random.default_rng(3).standard_normal((137, 2))
    r = diagnose(x).correlations[:2].min()
    assert 0.6 < r < 0.99
    assert diagnose(x, threshold=r + 0.01).verdict is Verdict.TRY_SKETCHING
    assert diagnose(x, threshold=r - 0.01).verdict is Verdict.USABLE


def test_short_clip_earns_a_caution():
    # The band is about 3.6 / n wide: on 24 frames it keeps ~30 % of the spectrum, so even
    # random motion would reach r ~ 0.55 and the verdict deserves a caution.
    assert "Caution" in diagnose(two_phase(24, 8.0)).reason
    assert "Caution" not in diagnose(two_phase(137, 24.0)).reason


@pytest.mark.parametrize("sketched", [False, True])
def test_less_than_a_cycle_and_a_half_is_not_usable(sketched):
    diag = diagnose(two_phase(40, 36.0), sketched=sketched)
    assert diag.verdict is Verdict.NOT_USABLE
    assert "No gait cycle" in diag.reason and "1.5 cycles" in diag.reason


def test_a_slow_drift_is_not_a_gait():
    t = np.arange(120, dtype=float)
    x = np.column_stack([t, t**2]) + 0.01 * np.random.default_rng(3).standard_normal((120, 2))
    diag = diagnose(x)
    assert diag.verdict is Verdict.NOT_USABLE
    assert "No gait cycle" in diag.reason


# --- band_pass ------------------------------------------------------------------------------


def test_band_pass_keeps_in_band_and_removes_out_of_band_sinusoids():
    n = 120
    t = np.arange(n)
    slow = np.sin(2 * np.pi * t / 11.3 + 0.4)  # f = 0.088, not on an FFT bin
    fast = np.cos(2 * np.pi * t / 4.1)  # f = 0.244
    out = band_pass(np.column_stack([slow + fast + 3.0, fast]), (0.07, 0.1), centre=1 / 11.3)
    np.testing.assert_allclose(out[:, 0], slow, atol=0.06)  # mean and fast part gone
    np.testing.assert_allclose(out[:, 1], 0.0, atol=0.06)
    assert np.corrcoef(out[:, 0], slow)[0, 1] > 0.998


def test_band_pass_does_not_pull_the_ends_together():
    n = 137
    t = np.arange(n)
    x = np.cos(2 * np.pi * t / 24.0)  # 5.7 cycles: first and last frames differ a lot
    out = band_pass(x, (1 / 30, 1 / 20), centre=1 / 24.0)
    np.testing.assert_allclose(out[[0, -1]], x[[0, -1]], atol=0.05)


def test_band_pass_keeps_dc_only_from_zero():
    n = 60
    t = np.arange(n)
    x = 2.0 + np.cos(2 * np.pi * 5 * t / n)
    assert abs(band_pass(x, (4 / n, 6 / n)).mean()) < 1e-9
    np.testing.assert_allclose(band_pass(x, (0.0, 1 / n), centre=0.0), np.full(n, 2.0), atol=1e-9)
    np.testing.assert_allclose(band_pass(x, (0.0, 0.5)), x, atol=1e-9)


@pytest.mark.parametrize(
    "band", [(0.2, 0.1), (-0.1, 0.2), (0.0, float("nan")), (0.1,), "ab", None]
)
def test_band_pass_rejects_bad_bands(band):
    with pytest.raises(GaitInputError, match="band"):
        band_pass(np.zeros(10), band)


def test_band_pass_rejects_bad_trajectories():
    with pytest.raises(GaitInputError, match="shape"):
        band_pass(np.zeros((4, 2, 2)), (0.0, 0.1))
    with pytest.raises(GaitInputError, match="NaN"):
        band_pass(np.array([0.0, np.nan, 1.0]), (0.0, 0.1))


# --- bad input to diagnose ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("projections", "message"),
    [
        (np.zeros(50), "2-D"),
        (np.zeros((50, 2, 1)), "2-D"),
        (np.random.default_rng(0).standard_normal((50, 1)), "at least 2 components"),
        (np.random.default_rng(0).standard_normal((7, 3)), "at least 8 frames"),
        (np.where(np.eye(20, 3) > 0, np.nan, 1.0) + np.arange(20)[:, None], "NaN"),
        (np.full((20, 3), np.inf), "NaN or infinite"),
        (np.column_stack([np.full(30, 4.2), np.arange(30.0)]), "no motion"),
        ([["a", "b"]] * 10, "numbers"),
    ],
)
def test_bad_input_raises_gait_input_error(projections, message):
    with pytest.raises(GaitInputError, match=message):
        diagnose(projections)


@pytest.mark.parametrize("threshold", [-0.1, 1.5, float("nan"), "high"])
def test_bad_threshold_raises(threshold):
    with pytest.raises(GaitInputError, match="threshold"):
        diagnose(two_phase(50, 10.0), threshold=threshold)


# --- property -------------------------------------------------------------------------------


@settings(max_examples=150, deadline=None)
@given(
    st.integers(8, 80).flatmap(
        lambda n: st.integers(2, 5).flatmap(
            lambda c: arrays(
                np.float64,
                (n, c),
                elements=st.floats(-1e300, 1e300, allow_nan=False, allow_infinity=False),
            )
        )
    )
)
def test_diagnose_never_crashes_on_finite_input(x):
    try:
        diag = diagnose(x)
    except GaitInputError as exc:
        assert "no motion" in str(exc)  # the only refusal of a finite (n >= 8, c >= 2) array
        return
    assert diag.correlations.shape == (x.shape[1],)
    assert np.all((diag.correlations >= -1.0) & (diag.correlations <= 1.0))
    assert 0.0 < diag.f0 <= 0.5 and np.isfinite(diag.period_frames)
    assert 0.0 <= diag.band[0] <= diag.f0 <= diag.band[1]
    assert diag.filtered.shape == x.shape and np.all(np.isfinite(diag.filtered))
    assert isinstance(diag.verdict, Verdict) and diag.reason


def test_a_rhythm_too_short_to_judge_asks_for_a_longer_clip():
    """Two cycles of a noisy rhythm: Fisher's test cannot be sure (p above 0.01), and the
    sentence says the clip is too short rather than that the silhouettes hold no rhythm."""
    from gaitcore.analysis.verdict import explain

    verdict, text = explain(np.array([0.9, 0.8, 0.2, 0.1, 0.1]), 1 / 10, (0.08, 0.12), 20,
                            0.6, False, 0.02)
    assert verdict is Verdict.NOT_USABLE
    assert "repeats only 2.0 times in this 20-frame clip" in text and "at least 3 cycles" in text
    _, noise = explain(np.array([0.3, 0.2, 0.2, 0.1, 0.1]), 1 / 10, (0.08, 0.12), 20, 0.6,
                       False, 0.4)
    assert "no stronger than chance" in noise
