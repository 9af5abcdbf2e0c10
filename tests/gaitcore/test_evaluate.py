"""The paper's Section 4 experiment (``gaitcore evaluate``) and the issue's acceptance lines.

The figures themselves live in docs/validation.md (scripts/make_validation.py); these tests
hold the claims made there.
"""

from __future__ import annotations

import json

import pytest

from gaitcore.bench.blend_floor import best_blend_floor
from gaitcore.bench.evaluate import BenchSettings, evaluate_gait
from gaitcore.bench.gaits import generate_gait
from gaitcore.cli import main
from gaitcore.errors import GaitInputError
from gaitcore.rig.templates import load_template

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def canter():
    return evaluate_gait(BenchSettings(gait="canter"), pcs=(1, 2, 3), keys=(2, 4))


def test_no_cell_beats_the_floor_of_its_own_keys(canter):
    assert len(canter.grid) == 6
    for cell in canter.grid:
        assert len(cell.key_frames) == cell.keys
        assert 0.0 < cell.floor_deg <= cell.mean_deg + 1e-9, cell


def test_json_summary(canter):
    data = json.loads(json.dumps(canter.to_dict()))
    assert data["gait"] == "canter" and data["n_frames"] == 100 and data["n_angles"] == 38
    assert len(data["correlations"]) >= 5  # one per component kept for the rhythm
    assert {(c["pcs"], c["keys"]) for c in data["grid"]} == {(p, k) for p in (1, 2, 3)
                                                             for k in (2, 4)}
    assert all(c["floor_deg"] <= c["mean_deg"] + 1e-3 for c in data["grid"])


def test_switching_cells_carry_their_alternates():
    ev = evaluate_gait(BenchSettings(gait="walk", n_frames=80), pcs=(2,), keys=(4,),
                       switching=True)
    plain, switched = ev.cell(2, 4), ev.cell(2, 4, switching=True)
    assert switched.floor_deg is None and len(switched.alternate_frames) == 4
    assert not set(switched.alternate_frames) & set(plain.key_frames)
    assert "alternate_frames" in ev.to_dict()["grid"][1]


def test_bad_settings():
    with pytest.raises(GaitInputError, match="positive"):
        evaluate_gait(BenchSettings(gait="walk", n_frames=40), pcs=(0,), keys=(4,))
    with pytest.raises(GaitInputError, match="mask noise"):
        evaluate_gait(BenchSettings(gait="walk", n_frames=40, mask_noise=0.6))


def test_command_json_and_one_line_errors(capsys):
    assert main(["evaluate", "--gait", "trot", "--pcs", "2", "--keys", "3", "--frames", "60",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["grid"][0]["keys"] == 3 and data["grid"][0]["floor_deg"] > 0
    assert main(["evaluate", "--gait", "trot", "--mask-noise", "0.7"]) == 2
    err = capsys.readouterr().err.strip()
    assert "mask noise" in err and len(err.splitlines()) == 1


@pytest.mark.slow
def test_walk_switching_meets_the_target():
    ev = evaluate_gait(BenchSettings(gait="walk"), pcs=(2,), keys=(4,), switching=True)
    plain, switched = ev.cell(2, 4).mean_deg, ev.cell(2, 4, switching=True).mean_deg
    assert switched <= 3.0
    assert switched <= 0.5 * plain


@pytest.mark.slow
@pytest.mark.parametrize("gait", ["walk", "trot", "canter", "gallop"])
def test_diagnosis_of_every_synthetic_gait(gait):
    r = evaluate_gait(BenchSettings(gait=gait), pcs=(2,), keys=(4,)).correlations
    assert r[0] >= 0.6 and r[1] >= 0.6
    if gait == "gallop":
        # known miss, reported in docs/validation.md: PC4 keeps 9 % of its energy at f0
        assert max(r[2:5]) <= 0.35
    else:
        assert max(r[2:5]) <= 0.3


@pytest.mark.slow
@pytest.mark.parametrize(("gait", "bound"), [("canter", 3.0), ("gallop", 4.4)])
def test_four_poses_of_the_fast_gaits_cannot_blend_to_two_degrees(gait, bound):
    """Why the issue's 2.0 deg target for 4 keys is out of reach (docs/validation.md)."""
    horse = load_template("horse")
    truth = generate_gait(horse, gait, 100)[:, horse.sagittal_angle_indices]
    floor = best_blend_floor(truth, 4)
    assert floor.lower_deg >= bound
    ev = evaluate_gait(BenchSettings(gait=gait), pcs=(2,), keys=(4,))
    assert ev.cell(2, 4).mean_deg >= floor.lower_deg
