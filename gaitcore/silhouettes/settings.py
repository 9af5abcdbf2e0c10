"""The segmentation's settings, grouped by cue, and their JSON profile.

One line per setting says what it does and its unit; why each value is what it is, and on
which clips it was measured, is in ``docs/segmentation.md`` (section "Settings"), once.

A profile is a JSON file holding some or all of the settings; what it leaves out keeps its
default::

    {"format": "gaitstudio-segmentation", "version": 1,
     "method": "propagate",
     "propagation": {"saliency_every": 1, "motion_weight": 0.5}}

``gaitcore segment --settings FILE.json`` (and ``analyze``) read one, ``--save-settings``
writes the one used; a project keeps the profile it was segmented with.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from gaitcore.errors import GaitInputError
from gaitcore.schema import JsonValue, MiB, dump_json, read_json

FLOW_PRESETS = ("ultrafast", "fast", "medium")
"""DIS optical flow presets (OpenCV's), fastest first."""
METHODS = ("gmm", "propagate")
"""``gmm``: the paper's colour mixture from rectangles; ``propagate``: flow and graph cut."""
PROFILE_FORMAT = "gaitstudio-segmentation"
PROFILE_VERSION = 1
MAX_PROFILE_BYTES = MiB


@dataclass(frozen=True)
class PropagationSettings:
    """Options of the flow-and-graph-cut segmentation (``method="propagate"``).

    Attributes
    ----------
    subject_side_px : int
        Working size: the subject's longer side at most this, pixels (never enlarged).
    flow_preset : {"ultrafast", "fast", "medium"}
        DIS optical flow preset of the frame-to-frame warp.
    margin_frac : float
        Flow and cut within the warped mask's box grown by this, share of the subject's side.
    first_scale : float
        Frame 0 is cut at this many times the working size, then shrunk to it.
    first_iters : int
        Graph-cut iterations on a key frame.
    motion_offsets : tuple of int
        Frames after the first whose motion seeds the first cut's candidates.
    band_frac : float
        Half-width of the band where the cut decides, share of the subject's side.
    core_frac : float
        The warped mask eroded by this share of the subject's side is sure subject.
    prior_weight : float
        Weight of the warped mask against colour where the flow is not trusted.
    prior_blur_frac : float
        Blur of the warped mask there, share of the subject's side.
    trusted_prior_weight : float
        Weight of the warped mask, unblurred, where the flow is trusted.
    trust_grey : float
        Grey-level difference (0-255) at which the flow's trust falls to 1/e.
    smooth_frac : float
        Radius of the edge-aware (guided) smoothing, share of the subject's side.
    part_gap_frac : float
        A part farther than this from the largest, share of the subject's side, is dropped.
    max_growth : float
        A cut larger than this many times the warped mask's area is refused.
    max_shrink : float
        A cut smaller than this many times the warped mask's area is refused.
    lost_frac : float
        A mask under this share of its key frame's area counts as lost.
    lost_gap : float
        A mask standing out from its surroundings less than this share of its key's is lost.
    motion_weight : float
        Motion cue: weight of how unlike the ground a pixel moves, against colour.
    still_weight : float
        Still-background cue (tripod shots): weight against colour; 0 leaves it out.
    nearby_weight : float
        Nearby-ground cue (moving camera): weight against colour; 0 leaves it out.
    nearby_reach : int
        Nearby-ground cue: frames looked at either way, at most.
    nearby_step : int
        Nearby-ground cue: one frame in this many within the reach.
    match_exposure : bool
        Exposure cue: bring each frame to its key frame's exposure and colour balance.
    exposure_pull : float
        Exposure cue: pull per frame towards the background's level, in log.
    exposure_slack : float
        Exposure cue: exposure changes up to this, in log, are left to the colour models.
    balance_slack : float
        Exposure cue: the same for each channel's gain less their mean, in log.
    saliency_weight : float
        Salient-object network: weight of its log-odds; 0 leaves the network out.
    saliency_every : int
        Salient-object network: run every this many frames, its map carried between.
    stroke_reach : float
        Corrections: a band this many stroke widths around a stroke takes its side.
    stroke_zone_frac : float
        Corrections: the stroked frame changes within this share of the subject's side.
    stroke_teaching : int
        Corrections: weight of a background stroke's pixels in the passes' colours.
    correction_weight : float
        Carried correction: log-odds added where a correction turned the mask to subject.
    correction_fade : float
        Carried correction: share of that term left after each frame (0 to under 1).
    """

    # working size and flow
    subject_side_px: int = 200
    flow_preset: str = "fast"
    margin_frac: float = 0.3
    # the key frame's cut
    first_scale: float = 1.5
    first_iters: int = 5
    motion_offsets: tuple[int, ...] = (1, 3, 6)
    # the propagated frame's cut: the carried mask as a prior
    band_frac: float = 0.08
    core_frac: float = 0.04
    prior_weight: float = 1.0
    prior_blur_frac: float = 0.03
    trusted_prior_weight: float = 2.0
    trust_grey: float = 12.0
    smooth_frac: float = 0.02
    part_gap_frac: float = 0.04
    # refusing a cut, losing the subject
    max_growth: float = 1.6
    max_shrink: float = 0.5
    lost_frac: float = 0.1
    lost_gap: float = 0.6
    # cues beside colour
    motion_weight: float = 0.3
    still_weight: float = 2.0
    nearby_weight: float = 2.0
    nearby_reach: int = 8
    nearby_step: int = 2
    match_exposure: bool = True
    exposure_pull: float = 0.05
    exposure_slack: float = 0.05
    balance_slack: float = 0.01
    saliency_weight: float = 1.0
    saliency_every: int = 4
    # corrections
    stroke_reach: float = 2.0
    stroke_zone_frac: float = 0.2
    stroke_teaching: int = 16
    correction_weight: float = 1.0
    correction_fade: float = 0.9

    def __post_init__(self) -> None:
        if self.flow_preset not in FLOW_PRESETS:
            raise GaitInputError(f"unknown flow preset {self.flow_preset!r}: use one of "
                                 f"{FLOW_PRESETS}")
        if self.subject_side_px < 32 or self.first_iters < 1:
            raise GaitInputError(
                f"propagation settings out of range (subject_side_px={self.subject_side_px}, "
                f"first_iters={self.first_iters}): use subject_side_px >= 32 and at least "
                "one graph-cut iteration"
            )
        if not 0 < self.max_shrink < 1 < self.max_growth:
            raise GaitInputError("need 0 < max_shrink < 1 < max_growth")
        if self.saliency_every < 1:
            raise GaitInputError(f"saliency_every={self.saliency_every}: use 1 or more (the "
                                 "network runs every this many frames)")
        if self.stroke_teaching < 0:
            raise GaitInputError(f"stroke_teaching={self.stroke_teaching}: use 0 or more (how "
                                 "many times more a background stroke's pixels count)")
        if not 0 <= self.correction_fade < 1:
            raise GaitInputError(f"correction_fade={self.correction_fade}: use 0 or more and "
                                 "under 1 (the share of a carried correction left each frame)")
        if self.nearby_step < 1 or self.nearby_reach < 0 or any(
                k < 1 for k in self.motion_offsets):
            raise GaitInputError("nearby_step and each motion offset must be 1 or more, "
                                 "nearby_reach 0 or more")


@dataclass(frozen=True)
class SegmentationSettings:
    """Options of :func:`~gaitcore.silhouettes.segmentation.segment_clip`.

    Attributes
    ----------
    method : {"propagate", "gmm"}
        Flow and graph cut from a box, or the paper's colour mixture from rectangles.
    n_components : int
        ``gmm``: Gaussians per colour model.
    lut_bits : int
        ``gmm``: bits per BGR channel of the posterior table (4 to 7).
    min_area_frac : float
        ``gmm``: components under this share of the frame are noise.
    propagation : PropagationSettings
        ``propagate``: its options.
    """

    method: str = "propagate"
    n_components: int = 5
    lut_bits: int = 5
    min_area_frac: float = 1e-3
    propagation: PropagationSettings = field(default_factory=PropagationSettings)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise GaitInputError(
                f"unknown segmentation method {self.method!r}: use one of {METHODS}"
            )
        if not 4 <= self.lut_bits <= 7 or self.n_components < 1:
            raise GaitInputError(f"segmentation settings out of range (lut_bits={self.lut_bits}, "
                                 f"n_components={self.n_components}): use lut_bits 4..7 and "
                                 "n_components >= 1")


# -- the profile ---------------------------------------------------------------------------
def settings_to_dict(settings: SegmentationSettings) -> dict[str, Any]:
    """The profile of ``settings`` (every value), JSON-ready."""
    doc = asdict(settings)
    doc["propagation"]["motion_offsets"] = list(settings.propagation.motion_offsets)
    return {"format": PROFILE_FORMAT, "version": PROFILE_VERSION, **doc}


def settings_from_dict(doc: JsonValue) -> SegmentationSettings:
    """The settings of a profile: what it leaves out keeps its default.

    Raises
    ------
    GaitInputError
        Not a profile, a newer one, an unknown setting, or a value of the wrong type or
        out of range (naming it).
    """
    if doc.key("format", None).value != PROFILE_FORMAT:
        raise doc.fail(f"a segmentation profile (format {PROFILE_FORMAT!r})")
    version = doc.key("version").integer(lo=1, hi=1 << 20)
    if version > PROFILE_VERSION:
        raise GaitInputError(f"{doc.what}: profile version {version} is newer than this "
                             "Gait Studio reads; update Gait Studio")
    top = _fields_of(doc, SegmentationSettings(), skip=("format", "version", "propagation"))
    propagation = PropagationSettings()
    if doc.has("propagation"):
        propagation = replace(propagation, **_fields_of(doc.key("propagation"), propagation))
    try:
        return replace(SegmentationSettings(), propagation=propagation, **top)
    except GaitInputError as exc:
        raise GaitInputError(f"{doc.what}: {exc}") from None


def read_settings(path: str | Path) -> SegmentationSettings:
    """Read a profile (see the module docstring)."""
    doc = read_json(path, what="segmentation profile", max_bytes=MAX_PROFILE_BYTES,
                    advice="write one with 'gaitcore segment --save-settings FILE.json'")
    return settings_from_dict(doc)


def write_settings(path: str | Path, settings: SegmentationSettings) -> None:
    """Write the profile of ``settings`` (every value)."""
    Path(path).write_text(dump_json(settings_to_dict(settings), indent=1,
                                    what=f"segmentation profile {path}") + "\n",
                          encoding="utf-8")


def _fields_of(doc: JsonValue, defaults: Any, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """The values ``doc`` gives for the fields of the dataclass ``defaults``, typed alike."""
    known = {f.name: getattr(defaults, f.name) for f in fields(defaults)}
    out: dict[str, Any] = {}
    for name, value in doc.entries(max_len=256):
        if name in skip:
            continue
        if name not in known:
            raise GaitInputError(f"{doc.what}: unknown setting {name!r}; the settings are "
                                 f"{', '.join(k for k in known if k not in skip)}")
        default = known[name]
        if isinstance(default, bool):
            out[name] = value.boolean()
        elif isinstance(default, int):
            out[name] = value.integer(lo=0, hi=1 << 20)
        elif isinstance(default, float):
            out[name] = value.number(lo=0, hi=1e6)
        elif isinstance(default, str):
            out[name] = value.text(max_len=64)
        else:
            out[name] = value.integers(max_len=64)
    return out


__all__ = [
    "FLOW_PRESETS", "METHODS", "PropagationSettings", "SegmentationSettings", "read_settings",
    "settings_from_dict", "settings_to_dict", "write_settings",
]
