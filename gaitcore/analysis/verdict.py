"""The diagnosis in words: the verdict on a clip and the sentence an artist reads (paper 5.2).

:func:`gaitcore.analysis.spectrum.diagnose` measures; :func:`explain` turns its figures into a
:class:`Verdict` and a sentence that says what to do next.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

MIN_CYCLES = 1.25
"""Fewest cycles of PC1's main rhythm the clip must hold to count as periodic.

The paper asks for about 1.5 cycles; the estimate of the number of cycles scatters by about
+/- 0.1 on clips that short (it depends on the phase at which the clip starts), so the cut is
set a little lower so that a genuine 1.5-cycle clip is not rejected.
"""

PERIODICITY_ALPHA = 0.01
"""PC1 must hold a rhythm at this significance (Fisher's g test) for a clip to be usable."""

FEW_CYCLES = 3.0
HINT_ALPHA = 0.1
"""A rhythm with p between PERIODICITY_ALPHA and HINT_ALPHA on a clip of fewer than
FEW_CYCLES cycles is too short to judge, rather than absent: the text asks for a longer clip."""

QUIET_CORRELATION = 0.3
"""In the paper's good clips r3..r5 stay at or below this; higher values earn a note."""

SHORT_CLIP_FLOOR = 0.45
"""A caution is added when random motion would score r at least this high (short clips)."""


class Verdict(str, Enum):
    """What the artist should do with the clip (paper Section 5.2, last paragraph)."""

    USABLE = "usable"
    TRY_SKETCHING = "try sketching"
    NOT_USABLE = "not usable"


def explain(
    r: np.ndarray,
    f0: float,
    band: tuple[float, float],
    n: int,
    threshold: float,
    sketched: bool,
    p_value: float,
    names: tuple[str, ...] = ("PC1", "PC2"),
) -> tuple[Verdict, str]:
    """The verdict and the sentence an artist reads (paper Section 5.2, last paragraph).

    The band's share of the spectrum ``s`` gives the correlation that random motion
    (white noise) would reach, about ``sqrt(s)``: on short clips the band is wide (about
    3.6 / n) and that floor nears the threshold, which earns a caution in the text.
    """
    period = 1.0 / f0
    cycles = f0 * n
    first, second = names[0], names[1]
    if cycles < MIN_CYCLES:
        return Verdict.NOT_USABLE, (
            f"No gait cycle found: the strongest rhythm of {first} (period about {period:.0f} "
            f"frames) repeats only {cycles:.1f} times in this {n}-frame clip, and at least "
            "1.5 cycles are needed. Use a longer clip of a steady gait; if the animal drifts "
            "(walks towards the camera, the camera pans), cut a part where it stays side-on."
        )
    if PERIODICITY_ALPHA < p_value <= HINT_ALPHA and cycles < FEW_CYCLES:
        return Verdict.NOT_USABLE, (
            f"No rhythm found: {first}'s strongest rhythm (period about {period:.0f} frames) "
            f"repeats only {cycles:.1f} times in this {n}-frame clip, too few for the test to "
            f"tell it from chance (Fisher's test p = {p_value:.2g}; {PERIODICITY_ALPHA:g} "
            f"needed). Use a longer clip of the same gait: at least {FEW_CYCLES:g} cycles "
            f"(about {FEW_CYCLES * period:.0f} frames)."
        )
    if p_value > PERIODICITY_ALPHA:
        return Verdict.NOT_USABLE, (
            f"No rhythm found: the strongest frequency of {first} and {second} is no stronger "
            f"than chance "
            f"(Fisher's test p = {p_value:.2g}), so the silhouettes do not change with a gait "
            "cycle. Check that they show the animal (not noise or the background), or choose a "
            "clip of a steady gait seen from the side."
        )
    verdict, text = _rhythm_verdict(r, period, threshold, sketched, names)
    return verdict, text + _notes(r, verdict, band, n, names)


def _rhythm_verdict(r: np.ndarray, period: float, threshold: float,
                    sketched: bool, names: tuple[str, ...]) -> tuple[Verdict, str]:
    """Usable, try sketching or not usable, by r1 and r2 against ``threshold``."""
    figures = f"r1 = {r[0]:.2f}, r2 = {r[1]:.2f}"
    if r[0] >= threshold and r[1] >= threshold:
        verdict = Verdict.USABLE
        text = (
            f"Usable: {names[0]} and {names[1]} follow the same rhythm, a period of "
            f"{period:.1f} frames ({figures}, both at least {threshold:.2f})."
        )
    else:
        failing = [names[k] for k in range(2) if r[k] < threshold]
        who = " and ".join(failing)
        head = (
            f"{who} {'do' if len(failing) > 1 else 'does'} not follow a single rhythm of "
            f"{period:.1f} frames ({figures}; both should be at least {threshold:.2f})"
        )
        if sketched:
            verdict = Verdict.NOT_USABLE
            text = (
                f"Not usable: {head}, even with sketched silhouettes. This method cannot "
                "animate this clip; try another one showing a steady gait from the side."
            )
        else:
            verdict = Verdict.TRY_SKETCHING
            text = (
                f"Try sketching: {head}. The automatic silhouettes are probably too noisy "
                "(segmentation errors, occlusions, camera motion): sketch the spine, legs "
                "and head on the frames, then diagnose again."
            )
    return verdict, text


def _notes(r: np.ndarray, verdict: Verdict, band: tuple[float, float], n: int,
           names: tuple[str, ...]) -> str:
    """What qualifies the verdict: later components that follow the gait, a short clip."""
    text = ""
    loud = [k for k in range(2, min(len(r), 5)) if r[k] > QUIET_CORRELATION]
    if loud and verdict is Verdict.USABLE:
        figures = ", ".join(f"r{k + 1} = {r[k]:.2f}" for k in loud)
        verb = "is" if len(loud) == 1 else "are"
        text += (
            f" Note: {figures} {verb} above {QUIET_CORRELATION}, the most the paper's good "
            "clips reach beyond their first two components, so some of the gait also shows "
            f"in others; this does not change the verdict, since only {names[0]} and "
            f"{names[1]} drive the animation."
        )
    share = (min(band[1], 0.5) - band[0]) / 0.5
    floor = float(np.sqrt(np.clip(share, 0.0, 1.0)))
    if floor >= SHORT_CLIP_FLOOR:
        text += (
            f" Caution: with only {n} frames the band keeps {100 * share:.0f} % of the "
            f"spectrum, so even random motion would score r of about {floor:.2f}; this "
            "verdict is unreliable, use a longer clip (60 frames or more) if you can."
        )
    return text


def no_repeat(n: int, longest: float, slow_lag: float | None) -> tuple[Verdict, str]:
    """The verdict on a clip whose silhouettes never come back within ``longest`` frames
    (the longest cycle an ``n``-frame clip can show twice,
    :data:`gaitcore.analysis.rhythm.MIN_CYCLES`), whatever its spectrum says; ``slow_lag``:
    the longer lag after which they do come back, if any."""
    if slow_lag is not None:
        return Verdict.NOT_USABLE, (
            f"No gait cycle found: the silhouettes come back only after about {slow_lag:.0f} "
            f"frames, {n / slow_lag:.1f} times in this {n}-frame clip, and twice is needed "
            f"to tell a gait from an animal that turns back. Use a longer clip of the same "
            f"gait: at least {int(np.ceil(2 * slow_lag))} frames.")
    return Verdict.NOT_USABLE, (
        f"No gait cycle found: no silhouette comes back within {longest:.0f} frames, so the "
        f"clip shows no gait cycle twice. Choose a clip of a steady gait seen from the side; "
        "if the animal turns or the camera pans, trim to where it does not.")
