"""What the user commands by the belief's state, and rotation dwells
(:mod:`drake_disamb.study.measures.commanding`): on a hand-made trial (directly and through
``estimate_behaviour``) and on the authors' logs (skipped where the logs are absent)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from support import study_trial

from drake_disamb.study.data.folder import LoggedTrial
from drake_disamb.study.measures.calibration import estimate_behaviour, format_estimates
from drake_disamb.study.measures.commanding import (
    commanding_by_belief,
    rotation_dwells,
    summarize_commanding,
    summarize_rotation_dwells,
)

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "tnsre2020_human_study"
DT = 0.05


def _trial(task: str = "reaching") -> LoggedTrial:
    """A 10-s head-array trial toward goal 1 of 3. Belief: uniform (unsure) 0-4 s, on goal 1
    (helped) 4-8 s, on goal 0 (neither) 8-10 s. Modes: vx from 0.5 s, wx (rotation) 3.0, wy
    (passed through) 4.0, vx 4.5, wz 6.0, vy 7.5. Commands: translation 1-3 s, rotation 3.1-3.6 s
    (unsure), translation 5-6 s, rotation 6.1-7.1 s (helped), translation 8.5-9 s (neither)."""
    t = np.round(np.arange(0.0, 10.0, DT), 6)
    changes = [(0.5, 0), (3.0, 3), (4.0, 4), (4.5, 0), (6.0, 5), (7.5, 1)]
    mode = np.full(t.size, 6.0)
    for at, index in changes:
        mode[t >= at - 1e-9] = index
    belief = np.full((t.size, 3), 1.0 / 3.0)
    belief[(t >= 4.0) & (t < 8.0)] = [0.2, 0.6, 0.2]
    belief[t >= 8.0] = [0.6, 0.2, 0.2]
    u_h = np.zeros((t.size, 6))
    for lo, hi, dim in ((1.0, 3.0, 0), (3.1, 3.6, 3), (5.0, 6.0, 0), (6.1, 7.1, 5), (8.5, 9.0, 1)):
        u_h[(t >= lo - 1e-9) & (t < hi - 1e-9), dim] = 0.1
    names = ["vx", "vy", "vz", "wx", "wy", "wz"]
    record = dataclasses.replace(
        study_trial(0, "head_array", task, "manual", presses=len(changes)),
        duration=10.0,
        completion_time=10.0,
        intended_goals=[1],
        reached_goals=[1],
        mode_switch_times=[at for at, _ in changes],
        mode_switch_modes=[names[i] for _, i in changes],
    )
    trace = {"t": t, "mode": mode, "u_h": u_h, "u": u_h.copy(), "belief": belief, "alpha": np.zeros(t.size)}
    return LoggedTrial(record, trace, request_switch_times=np.zeros(0))


def test_commanding_by_the_belief_state() -> None:
    seconds = commanding_by_belief(_trial())
    # helped 4-8 s, unsure 0-4 s; translation unsure 2 s, helped 1 s; rotation unsure 0.5, helped 1
    assert seconds == pytest.approx([4.0, 4.0, 1.0, 2.0, 1.0, 0.5])
    c = summarize_commanding([seconds, seconds])
    assert (c.helped, c.unsure, c.n) == (pytest.approx(4.0), pytest.approx(4.0), 2)
    assert (c.translate_helped, c.rotate_helped) == (pytest.approx(0.25), pytest.approx(0.25))
    assert (c.translate_unsure, c.rotate_unsure) == (pytest.approx(0.5), pytest.approx(0.125))
    pouring = _trial("pouring")
    pouring.record.intended_goals.append(0)  # two stages: no one known goal
    assert commanding_by_belief(pouring) is None
    empty = summarize_commanding([np.zeros(6)])
    assert math.isnan(empty.translate_helped) and math.isnan(empty.rotate_unsure)


def test_rotation_dwells() -> None:
    # wx: 0.5 s commanded (3.1-3.6) until the next switch at 4.0; wy: passed through; wz: 1 s
    assert rotation_dwells(_trial()) == pytest.approx([0.5, 0.0, 1.0])
    d = summarize_rotation_dwells([[0.5, 0.0, 1.0], []])
    assert (d.commanded, d.seconds, d.n) == (pytest.approx(2 / 3), pytest.approx(0.75), 3)
    assert math.isnan(summarize_rotation_dwells([[0.0]]).seconds)


def test_study_calibrate_prints_both() -> None:
    est = estimate_behaviour([_trial()])
    assert est.commanding_by_belief["head_array"].translate_unsure == pytest.approx(0.5)
    lines = format_estimates(est).splitlines()
    by_belief = next(x for x in lines if x.startswith("commanding by belief"))
    assert (
        "head array helped 4.0 s (translation 0.25, rotation 0.250), unsure 4.0 s (0.50, 0.125)" in by_belief
    )
    rotations = next(x for x in lines if x.startswith("rotation dwells"))
    assert "head array 0.67 commanded (n=3), median 0.75 s" in rotations


@pytest.mark.skipif(not DATA.is_dir(), reason=f"the authors' logs are not at {DATA}")
def test_people_translate_first_while_the_assistance_cannot_help() -> None:
    # While unsure people command a rotation alone a small share of the time, far less than a
    # translation, with either interface (UserConfig.unsure_rotation_weight models it).
    from drake_disamb.study.data.authors import read_trials

    est = estimate_behaviour(read_trials(DATA))
    for kind in ("joystick", "head_array"):
        c = est.commanding_by_belief[kind]
        assert c.n >= 20 and c.rotate_unsure < 0.04 and c.translate_unsure > 4 * c.rotate_unsure
    # head-array rotations are tapped: commanded in a minority of the changes into them, briefly
    head = est.rotation_dwells["head_array"]
    assert head.commanded < 0.5 and head.seconds < 1.0


def test_mode_kinds() -> None:
    from drake_disamb.core.layout import is_rotation_mode, is_translation_mode
    from drake_disamb.interfaces import INTERFACES

    joystick = INTERFACES["joystick"].modes  # {vx, vy} {vx, vz} {wx, wz} {wy} {gripper}
    assert [is_translation_mode(m) for m in joystick] == [True, True, False, False, False]
    assert [is_rotation_mode(m) for m in joystick] == [False, False, True, True, False]
    assert not is_translation_mode(()) and not is_rotation_mode(()) and not is_rotation_mode((2, 3))
