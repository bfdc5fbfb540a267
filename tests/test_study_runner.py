"""The study protocol and runner: protocol files and their errors, the trials' expansion, records
identical whatever the executor (1 or 2 processes, a Dask LocalCluster), resume after SIGKILL,
``study run --quick`` end to end, ``study ablate``, bad input failing before any trial, an
unreachable scheduler failing fast, and a person's trial recorded by ``demo --live --record``.

The paper's protocol needs the Automatic paradigm and the request latency (the methods worker's
scenario fields); on a build whose schema lacks them the tests run the protocol without them
(:func:`compatible_protocol_data`), and the default protocol's error is itself tested.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.stats import mannwhitneyu
from support import SRC, cli_process, interrupt, wait_for_line

from drake_disamb.ik import IkStatus
from drake_disamb.study.data.records import read_records
from drake_disamb.study.design import protocol as P
from drake_disamb.study.run.outcome import TRACE_ARRAYS, ik_held_share, stage_onsets
from drake_disamb.study.run.runner import plan_study, records_by_id, run_study


def compatible_protocol_data() -> dict:
    """The paper's protocol as plain data."""
    return yaml.safe_load(P.default_protocol_text())


def tiny_protocol_data(duration: float = 2.5) -> dict:
    """1 subject, both interfaces, reaching, one trial per paradigm, trials cut at ``duration`` s."""
    data = compatible_protocol_data()
    data.update(subjects=1, duration=duration)
    data["tasks"] = [t for t in data["tasks"] if t["task"] == "reaching"]
    for p in data["paradigms"]:
        p["trials"] = 1
    return data


def write_yaml(path: Path, data: dict) -> Path:
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def cli(*argv: str, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run(
        [sys.executable, "-m", "drake_disamb.cli", *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
    )


def run_local(out: Path, data: dict, workers: int, seed: int = 3) -> list:
    plan = plan_study(out, P.protocol_from_dict(data), seed)
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        result = run_study(plan, pool)
    assert not result.errors
    return read_records(out / "trials.jsonl")


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """The tiny protocol run with 1 worker process: the records every other run must equal."""
    out = tmp_path_factory.mktemp("reference")
    return out, records_by_id(run_local(out, tiny_protocol_data(), workers=1))


# -- protocol ---------------------------------------------------------------------------------------


def test_default_protocol_is_the_papers() -> None:
    protocol = P.default_protocol()
    assert protocol.n_trials == 416 and protocol.request_latency == [2.49, 3.38]  # the logged range
    assert protocol.system == "tnsre2020_study"  # the system the study's people used
    data = yaml.safe_load(P.default_protocol_text())
    assert data["subjects"] == 8 and data["interfaces"] == ["joystick", "head_array"]
    assert {p["name"]: p["trials"] for p in data["paradigms"]} == {
        "manual": 3,
        "disambiguation": 5,
        "automatic": 5,
    }
    assert [len(t["start_poses"]) for t in data["tasks"]] == [3, 3]
    assert data["request_latency"] == [2.49, 3.38] and data["disambiguation_method"] == "algorithm1"
    assert protocol.interface_mode_selection == "direct"  # the study's joystick: one press per change
    assert protocol.initial_modes == "all"  # the study drew the initial mode over every mode


def test_the_protocols_mode_selection_reaches_the_joysticks_trials_only() -> None:
    from drake_disamb.config import resolve_scenario
    from drake_disamb.study.run.runner import StudyContext, trial_scenario

    protocol = P.quick_protocol()
    context = StudyContext(protocol=P.protocol_to_dict(protocol))
    seen = {}
    for spec in P.expand_trials(protocol, 0):
        interface = resolve_scenario(trial_scenario(spec, context)).interface
        seen[spec.interface] = interface.mode_selection
    assert seen == {"joystick": "direct", "head_array": "cycle"}
    data = P.protocol_to_dict(protocol)
    data["interface_mode_selection"] = "cycle"
    context = StudyContext(protocol=data)
    spec = next(s for s in P.expand_trials(protocol, 0) if s.interface == "joystick")
    assert resolve_scenario(trial_scenario(spec, context)).interface.mode_selection == "cycle"


def test_the_protocols_named_targets_end_the_reaches_only() -> None:
    """The experimenter named the reaching target: the reach ends only at the subject's goal; the
    pouring task's pour and place end at whatever goal they are done at."""
    from drake_disamb.study.run.runner import StudyContext, trial_scenario

    protocol = P.default_protocol()
    assert {t.task: t.target_stages for t in protocol.tasks} == {"reaching": ["reach"], "pouring": []}
    context = StudyContext(protocol=P.protocol_to_dict(protocol))
    seen = {}
    for spec in P.expand_trials(protocol, 0)[:60]:
        scenario = trial_scenario(spec, context)
        seen[spec.task] = [stage.ends_at_target for stage in scenario.stages]
    assert seen == {"reaching": [True], "pouring": [False, False]}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"interfaces": ["joystick", "sip_puff"]},
            r"protocol\.interfaces\[1\]: expected one of .*'sip_puff'",
        ),
        (
            {"paradigms": [{"name": "telepathy", "trials": 1}]},
            r"protocol\.paradigms\[0\]\.name: .*'telepathy'",
        ),
        (
            {"paradigms": [{"name": "manual", "trials": "five"}]},
            r"protocol\.paradigms\[0\]\.trials: .*'five'",
        ),
        ({"tasks": [{"task": "juggling"}]}, r"protocol\.tasks\[0\]\.task: expected one of .*'juggling'"),
        ({"disambiguation_method": "coin_flip"}, r"protocol\.disambiguation_method: .*'coin_flip'"),
        ({"subjects": 0}, r"protocol\.subjects: .*0"),
        ({"colour": "red"}, r"protocol\.colour: unknown key"),
        ({"request_latency": [2.5, 2.0]}, r"protocol\.request_latency"),
        ({"interface_mode_selection": "sector"}, r"protocol\.interface_mode_selection: .*'sector'"),
        ({"initial_modes": "gripper"}, r"protocol\.initial_modes: expected one of all, arm, got .gripper."),
        (
            {"tasks": [{"task": "pouring", "target_stages": ["reach"]}]},
            r"protocol\.tasks\[0\]\.target_stages\[0\]: expected a stage of the pouring task "
            r"\(pour, place\), got .reach.",
        ),
    ],
)
def test_bad_protocol_names_the_field(change: dict, message: str) -> None:
    data = compatible_protocol_data()
    data.update(change)
    with pytest.raises(ValueError, match=message):
        P.protocol_from_dict(data)


def test_malformed_protocol_file_names_the_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text("subjects: 8\ninterfaces: [joystick\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"p\.yaml.*line"):
        P.load_protocol(path)
    with pytest.raises(ValueError, match=r"protocol file .*: no such file"):
        P.load_protocol(tmp_path / "missing.yaml")


def test_expansion_is_deterministic_counterbalanced_and_independent_per_trial() -> None:
    protocol = P.protocol_from_dict(compatible_protocol_data())
    a, b = P.expand_trials(protocol, 7), P.expand_trials(protocol, 7)
    assert a == b and len(a) == protocol.n_trials
    assert len({s.trial_id for s in a}) == len(a)
    assert P.expand_trials(protocol, 8) != a
    # a trial's draws depend on its seed alone: the same trial in a protocol with fewer subjects is equal
    small = P.expand_trials(P.protocol_from_dict({**compatible_protocol_data(), "subjects": 1}), 7)
    by_id = {s.trial_id: s for s in a}
    assert all(by_id[s.trial_id].seed == s.seed and by_id[s.trial_id].goals == s.goals for s in small)
    # every draw in range; the draws vary
    assert {s.start_pose for s in a} == {0, 1, 2}
    assert len({s.goals for s in a if s.task == "reaching"}) == 5
    # the initial mode over all the interface's modes, the gripper mode (the last) included, as
    # the study drew it; or over the arm modes only
    assert {s.initial_mode for s in a if s.interface == "head_array"} == set(range(7))
    assert {s.initial_mode for s in a if s.interface == "joystick"} == set(range(5))
    arm = P.expand_trials(P.protocol_from_dict({**compatible_protocol_data(), "initial_modes": "arm"}), 7)
    assert {s.initial_mode for s in arm if s.interface == "head_array"} == set(range(6))
    assert {s.initial_mode for s in arm if s.interface == "joystick"} == set(range(4))
    # counterbalanced: the first block differs between subjects, orders are 0..n-1 per subject
    firsts = {(s.interface, s.paradigm) for s in a if s.order == 0}
    assert len(firsts) > 1
    for subject in {s.subject for s in a}:
        assert sorted(s.order for s in a if s.subject == subject) == list(range(len(a) // protocol.subjects))


def test_williams_square_balances_first_order_carry_over() -> None:
    for n in (2, 3, 4):
        rows = P.williams_rows(n)
        pairs = [(r[i], r[i + 1]) for r in rows for i in range(n - 1)]
        counts = {p: pairs.count(p) for p in set(pairs)}
        assert len(counts) == n * (n - 1) and len(set(counts.values())) == 1
        assert all(sorted(r) == list(range(n)) for r in rows)


def test_assistance_onset_on_a_hand_made_trace() -> None:
    t = np.arange(8) * 0.5
    belief = np.array(
        [[0.6, 0.4], [0.3, 0.7], [0.6, 0.4], [0.6, 0.4], [0.6, 0.4], [0.6, 0.4], [0.7, 0.3], [0.8, 0.2]]
    )
    alpha = np.array([0.1, 0.1, 0.0, 0.2, 0.0, 0.3, 0.3, 0.4])
    u_h = np.zeros((8, 6))
    u_h[[0, 1, 2, 3, 5, 6], 0] = 0.1  # not commanding at samples 4 and 7 (alpha 0 there is no lapse)
    trace = {"t": t, "belief": belief, "alpha": alpha, "u_h": u_h, "stage": np.zeros(8)}
    assert stage_onsets(trace, [0], [2]) == [1.5]  # sample 2 had alpha 0 while commanding
    assert stage_onsets(trace, [1], [2]) == [None]
    # two stages, a task-wide belief of 2 + 2 goals: stage 1's intended goal 1 is belief index 3
    trace2 = {
        **trace,
        "belief": np.tile([0.1, 0.1, 0.2, 0.6], (8, 1)),
        "stage": np.r_[np.zeros(4), np.ones(4)],
    }
    assert stage_onsets(trace2, [0, 1], [2, 2]) == [None, 2.5]


def test_ik_held_share_counts_the_commanding_samples_the_ik_held_in_the_last_window() -> None:
    t = np.arange(10.0)
    u_h = np.zeros((10, 6))
    u_h[[1, 6, 7, 8], 0] = 0.1  # commanding at t = 1, 6, 7, 8
    status = np.zeros(10)
    status[1] = IkStatus.STOPPED  # outside the window
    status[6] = IkStatus.SINGULAR
    status[7] = IkStatus.LIMITED  # slowed by a joint limit: not held
    status[9] = IkStatus.STOPPED  # not commanding: the arm is still anyway
    trace = {"t": t, "u_h": u_h, "ik_status": status}
    assert ik_held_share(trace, window=4.0) == pytest.approx(1 / 3)
    assert ik_held_share(trace, window=100.0) == pytest.approx(2 / 4)
    assert ik_held_share({"t": t, "u_h": u_h}) is None  # not logged (a station on a wire)
    assert ik_held_share({**trace, "u_h": np.zeros((10, 6))}) is None  # no commanding


# -- running ----------------------------------------------------------------------------------------


def test_two_workers_give_the_records_of_one(reference: tuple[Path, dict], tmp_path: Path) -> None:
    ref_dir, ref = reference
    assert len(ref) == 2 * len(compatible_protocol_data()["paradigms"])
    assert records_by_id(run_local(tmp_path, tiny_protocol_data(), workers=2)) == ref
    for trial_id in ref:
        a = np.load(ref_dir / "traces" / f"{trial_id}.npz")
        b = np.load(tmp_path / "traces" / f"{trial_id}.npz")
        assert set(a.files) == {*TRACE_ARRAYS, "ik_status"}  # the in-process station logs its IK
        for name in a.files:
            np.testing.assert_array_equal(a[name], b[name])
    record = next(iter(ref.values()))
    T = len(a["t"])
    assert a["belief"].shape == (T, 5) and a["u_h"].shape == (T, 6) and a["ee_pose"].shape == (T, 7)
    assert a["alpha"].shape == a["mode"].shape == a["ik_status"].shape == (T,)
    assert set(np.unique(a["ik_status"])) <= {float(s) for s in IkStatus}
    assert record["source"] == "simulated" and record["extra"]["start_pose_name"]
    for trial_id, r in ref.items():  # a share where the user commanded (these trials are short)
        commanded = np.any(np.load(ref_dir / "traces" / f"{trial_id}.npz")["u_h"] != 0)
        held = r["extra"]["ik_held"]
        assert (held is None) if not commanded else (0.0 <= held <= 1.0)


def test_dask_local_cluster_gives_the_records_of_a_local_run(
    reference: tuple[Path, dict], tmp_path: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        data = write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())
        res = cli(
            "study", "run", "--out", str(tmp_path / "dask"), "--protocol", str(data), "--seed", "3",
            "--scheduler", cluster.scheduler_address, "--quiet",
        )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "Dask scheduler" in res.stdout
    assert records_by_id(read_records(tmp_path / "dask" / "trials.jsonl")) == reference[1]


def test_sigkill_then_rerun_completes_without_repeating_a_trial(
    reference: tuple[Path, dict], tmp_path: Path
) -> None:
    out = tmp_path / "killed"
    protocol = write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())
    argv = ["study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3", "--workers", "1"]
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen(
        [sys.executable, "-m", "drake_disamb.cli", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
        start_new_session=True,  # its worker processes too
    )
    records = out / "trials.jsonl"
    try:
        end = time.monotonic() + 180
        while time.monotonic() < end and not (records.exists() and records.read_bytes().count(b"\n") >= 1):
            time.sleep(0.05)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    before = read_records(records, repair=False)
    assert 1 <= len(before) < len(reference[1])
    with open(records, "ab") as f:  # what a kill during a write leaves
        f.write(b'{"trial_id":"S01-head_array-reaching-manual-r0","subj')
    res = cli(*argv)
    assert res.returncode == 0, res.stderr
    assert f"({len(before)} already done)" in res.stdout
    after = read_records(records)
    assert records_by_id(after) == reference[1]
    # the finished trials were not run again: their records (wall_time included) are unchanged
    by_id = {r.trial_id: r for r in after}
    assert all(by_id[r.trial_id] == r for r in before)


def test_a_trial_reruns_from_its_record_alone(
    reference: tuple[Path, dict], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Each record keeps its trial's scenario (the YAML ``demo --dump-scenario`` writes): ``study
    rerun`` runs the trial again from that record alone (a folder with nothing else) to the same
    record and trace; what the record keeps is what runs; an older record without it still reads."""
    import shutil

    from drake_disamb.cli import main
    from drake_disamb.config import dump_scenario
    from drake_disamb.study.run.runner import (
        StudyContext,
        draw_study_subjects,
        rerun_trial,
        trial_scenario,
    )

    out, by_id = reference
    protocol = P.protocol_from_dict(tiny_protocol_data())
    subjects, _ = draw_study_subjects(protocol.subjects, 3)
    context = StudyContext(P.protocol_to_dict(protocol), subject_users=dict(subjects))
    for spec in P.expand_trials(protocol, 3, [n for n, _ in subjects]):
        assert by_id[spec.trial_id]["extra"]["scenario"] == dump_scenario(trial_scenario(spec, context))
    trial_id = next(t for t in by_id if "disambiguation" in t)
    lines = (out / "trials.jsonl").read_text().splitlines()
    row = next(json.loads(line) for line in lines if json.loads(line)["trial_id"] == trial_id)

    def alone(name: str, record: dict) -> Path:
        folder = tmp_path / name
        (folder / "traces").mkdir(parents=True)
        (folder / "trials.jsonl").write_text(json.dumps(record) + "\n")
        shutil.copy(out / "traces" / f"{trial_id}.npz", folder / "traces")
        return folder

    folder = alone("alone", row)
    assert main(["study", "rerun", str(folder), trial_id, "--quiet"]) == 0
    assert "the same record and trace" in capsys.readouterr().out
    record = read_records(folder / "trials.jsonl")[0]
    again, trace = rerun_trial(record)
    assert records_by_id([again]) == records_by_id([record]) and set(trace) >= set(TRACE_ARRAYS)
    # What the record keeps is what runs: a shorter duration there, a shorter trial.
    cut = dict(
        row,
        extra=dict(row["extra"], scenario=row["extra"]["scenario"].replace("duration: 2.5", "duration: 1.5")),
    )
    assert main(["study", "rerun", str(alone("cut", cut)), trial_id, "--quiet"]) == 1
    text = capsys.readouterr().out
    assert "the rerun differs from the record" in text and "duration: 2.5 -> 1.5" in text
    # An older record (no extra.scenario) still reads; it cannot be rerun, and says why in one line.
    old = dict(row, extra={k: v for k, v in row["extra"].items() if k != "scenario"})
    assert read_records(alone("old", old) / "trials.jsonl")[0].trial_id == trial_id
    assert main(["study", "rerun", str(tmp_path / "old"), trial_id]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{trial_id}: keeps no scenario (extra.scenario" in err
    assert main(["study", "rerun", str(folder), "S09-nobody"]) == 2
    assert "no trial 'S09-nobody'" in capsys.readouterr().err
    assert main(["study", "rerun", str(alone("human", dict(row, source="human"))), trial_id]) == 2
    assert "a human trial (source human) cannot be rerun" in capsys.readouterr().err


def test_quick_study_end_to_end(tmp_path: Path) -> None:
    """``study run --quick`` on the paper's protocol, then ``study report`` on its records (its wall
    time is printed by ``python benchmarks/bench_study.py --quick``, not asserted here)."""
    protocol = write_yaml(tmp_path / "protocol.yaml", compatible_protocol_data())
    res = cli(
        "study", "run", "--quick", "--out", str(tmp_path / "q"), "--protocol", str(protocol), "--workers", "2"
    )
    assert res.returncode == 0, res.stderr
    records = read_records(tmp_path / "q" / "trials.jsonl")
    n_paradigms = len(compatible_protocol_data()["paradigms"])
    assert len(records) == 2 * 2 * n_paradigms
    assert {r.subject for r in records} == {"S01", "S02"} and {r.task for r in records} == {"reaching"}
    assert {(r.interface, r.paradigm) for r in records} == {
        (i, p["name"]) for i in ("joystick", "head_array") for p in compatible_protocol_data()["paradigms"]
    }
    for r in records:
        assert (tmp_path / "q" / "traces" / f"{r.trial_id}.npz").is_file()
        assert r.button_presses == r.mode_switches + r.requests
        assert r.disambiguation_method == (None if r.paradigm == "manual" else "algorithm1")
    study = yaml.safe_load((tmp_path / "q" / "study.yaml").read_text())
    assert study["seed"] == 0 and study["protocol"]["subjects"] == 2 and study["version"]
    assert "trials 8/8" in res.stdout or f"trials {len(records)}/{len(records)}" in res.stdout
    # the report on these records: the page, its figures and a p-value recomputed with scipy
    res = cli("study", "report", str(tmp_path / "q"), "--no-mixed-model")
    assert res.returncode == 0, res.stderr
    report = tmp_path / "q" / "report"
    assert (report / "index.html").is_file() and len(list(report.glob("*.png"))) >= 5
    stats = json.loads((report / "stats.json").read_text())
    row = next(
        r
        for r in stats
        if (r["test"], r["metric"], r["interface"], r["task"], r["a"], r["b"])
        == ("ranksum", "button_presses_raw", "head_array", "reaching", "manual", "disambiguation")
    )
    head = [r for r in records if r.interface == "head_array" and r.success]  # failed trials are left out
    by = {p: [r.button_presses for r in head if r.paradigm == p] for p in ("manual", "disambiguation")}
    expected = mannwhitneyu(by["manual"], by["disambiguation"], alternative="two-sided")
    assert (row["n_a"], row["n_b"]) == (len(by["manual"]), len(by["disambiguation"]))
    assert row["p_value"] == pytest.approx(expected.pvalue, rel=1e-12)
    # the behaviour estimates measure the simulated trials as they measure people's logs
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.measures.calibration import estimate_behaviour

    trials = StudyFolder(tmp_path / "q").read_trials()
    assert [t.record for t in trials] == records
    for t in trials:
        assert len(t.request_switch_times) <= len(t.record.request_times)
    est = estimate_behaviour(trials)
    assert est.n_trials == sum(r.success is not False and r.paradigm != "automatic" for r in records)
    assert 0.0 < est.confident_share["joystick"] < 1.0
    # rerunning a finished study runs nothing; another seed in the same folder is refused
    res = cli(
        "study", "run", "--quick", "--out", str(tmp_path / "q"), "--protocol", str(protocol), "--workers", "1"
    )
    assert res.returncode == 0 and "0 trials to run" in res.stdout, res.stderr
    res = cli(
        "study", "run", "--quick", "--out", str(tmp_path / "q"), "--protocol", str(protocol), "--seed", "1"
    )
    assert res.returncode == 2 and "another study (seed differs" in res.stderr


def test_ablate_runs_one_study_per_setting(tmp_path: Path) -> None:
    data = tiny_protocol_data(duration=1.0)
    data["interfaces"] = ["head_array"]
    data["paradigms"] = [{"name": "manual", "trials": 1}]
    protocol = write_yaml(tmp_path / "protocol.yaml", data)
    out = tmp_path / "abl"
    res = cli(
        "study", "ablate", "--out", str(out), "--protocol", str(protocol), "--workers", "1",
        "--switch", "user.config.reaction_time=0.3,0.5",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    manifest = json.loads((out / "ablation.json").read_text())
    assert manifest == {
        "format": 1,
        "settings": [
            {"name": f"user.config.reaction_time={v}", "dir": f"user.config.reaction_time={v}",
             "overrides": {"user.config.reaction_time": float(v)}}
            for v in ("0.3", "0.5")
        ],
    }  # fmt: skip
    for s in manifest["settings"]:
        (record,) = read_records(out / s["dir"] / "trials.jsonl")
        assert record.extra["overrides"] == s["overrides"]
        assert yaml.safe_load((out / s["dir"] / "study.yaml").read_text())["overrides"] == s["overrides"]


def test_ablate_prints_its_totals_before_planning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """4 settings of the quick protocol's 12 trials, at 30 and 60 s (the switched durations)."""
    from drake_disamb.cli import main
    from drake_disamb.study.run import runner

    def plan_study(*args: object, **kwargs: object) -> None:
        raise ValueError("planning stopped here")

    monkeypatch.setattr(runner, "plan_study", plan_study)
    out = tmp_path / "abl"
    argv = ["study", "ablate", "--quick", "--out", str(out), "--switch", "inference.agreement=dot,cosine"]
    assert main([*argv, "--switch", "duration=30,60"]) == 2
    printed, err = capsys.readouterr()
    assert (
        f"ablation in {out}: 4 settings x 12 trials = 48 trials (at most 0.6 h simulated) "
        "(inference.agreement=dot+duration=30, inference.agreement=dot+duration=60, " in printed
    )
    assert "error: planning stopped here" in err


CONDITION_SWITCHES = {
    "task": "task=pouring",
    "goals": "goals=[]",
    "stages": "stages=[]",
    "interface": "interface=joystick",
    "paradigm": "paradigm=manual,automatic",
    "seed": "seed=1,2",
    "initial_mode": "initial_mode=0",
    "start_joint_positions": "start_joint_positions=null",
    "user.goals": "user.goals=[0]",
    "user": "user={goals: [0]}",
}


@pytest.mark.parametrize("name", list(CONDITION_SWITCHES))
def test_ablate_refuses_a_switch_of_a_trials_condition(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Its records would name a condition that did not run (task=pouring ran the reaching trials
    labelled pouring; seed=1,2 changed every outcome, each record keeping its seed). The scheduler
    cannot be reached: were the switch taken, the command would stop there, not run a study."""
    from drake_disamb.cli import main

    out = tmp_path / "abl"
    argv = ["study", "ablate", "--quick", "--out", str(out), "--switch", CONDITION_SWITCHES[name]]
    assert main([*argv, "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    what = "" if name != "user" else " (it holds user.goals)"
    assert f"error: --switch {name}: not switchable{what}: " in err and "record" in err, err
    assert not out.exists()


def test_the_refused_switches_are_the_ones_ablates_help_names(capsys: pytest.CaptureFixture[str]) -> None:
    from drake_disamb.cli import main
    from drake_disamb.study.run.runner import CONDITION_FIELDS

    assert set(CONDITION_FIELDS) == set(CONDITION_SWITCHES) - {"user"}
    with pytest.raises(SystemExit):
        main(["study", "ablate", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    assert all(name in help_text.split("not a trial's condition")[1] for name in CONDITION_FIELDS)


def test_a_switched_request_latency_is_the_one_its_records_keep() -> None:
    import dataclasses

    from drake_disamb.study.run.runner import StudyContext, run_trial_job

    protocol = dataclasses.replace(P.quick_protocol(), subjects=1, duration=0.5)
    spec = next(s for s in P.expand_trials(protocol, 0) if s.paradigm == "disambiguation")
    for overrides, latency in (({}, spec.request_latency), ({"disambiguation.request_latency": 2.0}, 2.0)):
        output = run_trial_job(spec, StudyContext(protocol=P.protocol_to_dict(protocol), overrides=overrides))
        assert output.error is None and output.record.extra["request_latency"] == latency
    assert spec.request_latency != 2.0


# -- bad input ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("paradigm", r"protocol\.paradigms\[0\]\.name: .*'telepathy'"),
        ("interface", r"protocol\.interfaces\[0\]: .*'sip_puff'"),
        ("task", r"protocol\.tasks\[0\]\.task: .*'juggling'"),
        ("method", r"protocol\.disambiguation_method: .*'coin_flip'"),
        ("malformed", r"protocol\.yaml.*line"),
        ("out_is_a_file", r"--out: .* is a file"),
        ("switch_path", r"--switch inference\.agreemnt='dot': scenario\.inference\.agreemnt: unknown key"),
        ("switch_value", r"--switch user\.config\.reaction_time='slow'"),
    ],
)
def test_bad_input_fails_before_any_trial(case: str, message: str, tmp_path: Path) -> None:
    data = tiny_protocol_data()
    change = {
        "paradigm": {"paradigms": [{"name": "telepathy", "trials": 1}]},
        "interface": {"interfaces": ["sip_puff"]},
        "task": {"tasks": [{"task": "juggling"}]},
        "method": {"disambiguation_method": "coin_flip"},
    }.get(case, {})
    data.update(change)
    protocol = write_yaml(tmp_path / "protocol.yaml", data)
    if case == "malformed":
        protocol.write_text("subjects: [1\n", encoding="utf-8")
    out = tmp_path / "out"
    if case == "out_is_a_file":
        out.write_text("not a folder")
    argv = ["study", "run", "--out", str(out), "--protocol", str(protocol)]
    if case.startswith("switch"):
        switch = "inference.agreemnt=dot" if case == "switch_path" else "user.config.reaction_time=slow"
        argv = ["study", "ablate", "--out", str(out), "--protocol", str(protocol), "--switch", switch]
    res = cli(*argv)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert __import__("re").search(message, res.stderr), res.stderr
    assert not list(tmp_path.rglob("trials.jsonl"))


def test_unreachable_scheduler_fails_fast(tmp_path: Path) -> None:
    protocol = write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())
    start = time.monotonic()
    res = cli(
        "study", "run", "--out", str(tmp_path / "o"), "--protocol", str(protocol),
        "--scheduler", "tcp://127.0.0.1:9",
    )  # fmt: skip
    elapsed = time.monotonic() - start
    assert (
        res.returncode == 2
        and "--scheduler: cannot reach a Dask scheduler at 'tcp://127.0.0.1:9'" in res.stderr
    )
    assert elapsed < 20, f"took {elapsed:.0f} s"  # the 5 s timeout plus the interpreter's start
    assert not (tmp_path / "o" / "trials.jsonl").exists()


@pytest.mark.parametrize(
    "address", ["garbage", "tcp://127.0.0.1", "foo://127.0.0.1:8786", "tcp://127.0.0.1:99999"]
)
def test_a_malformed_scheduler_address_fails_at_once_in_one_line(address: str, tmp_path: Path) -> None:
    """Before the folder is made and without Dask's client: no 10 s wait for a half-made client and
    its ``Exception ignored ... TimeoutError`` traceback at exit."""
    start = time.monotonic()
    res = cli("study", "run", "--quick", "--out", str(tmp_path / "o"), "--scheduler", address, timeout=60)
    elapsed = time.monotonic() - start
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.count("\n") == 1 and res.stderr.startswith(
        f"drake-disamb study run: error: --scheduler: {address!r} is not a Dask scheduler's address ("
    )
    assert "expected one like tcp://HOST:8786" in res.stderr
    assert elapsed < 5, f"took {elapsed:.1f} s"
    assert not (tmp_path / "o").exists()


def _dask_scheduler(workdir: Path) -> tuple[subprocess.Popen, str]:
    """A ``dask scheduler`` process on localhost (a free port, no dashboard) and its address."""
    argv = ["--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "distributed.cli.dask_scheduler", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ, DASK_TEMPORARY_DIRECTORY=str(workdir)),  # its scratch space
    )
    end = time.monotonic() + 60
    while time.monotonic() < end:
        line = proc.stderr.readline()
        if "Scheduler at:" in line:
            return proc, line.split("Scheduler at:", 1)[1].strip()
        if not line and proc.poll() is not None:
            break
    proc.kill()
    raise AssertionError("the dask scheduler did not start")


def test_a_lost_scheduler_ends_the_run_in_one_line_without_dask_tracebacks(tmp_path: Path) -> None:
    scheduler, address = _dask_scheduler(tmp_path)
    proc = cli_process(
        "study", "run", "--quick", "--out", str(tmp_path / "o"), "--scheduler", address, "--quiet"
    )
    try:
        try:
            wait_for_line(proc, "trials to run", timeout=120)  # connected; no worker: the trials wait
        finally:
            scheduler.kill()
            scheduler.communicate()
        lost = time.monotonic()
        out, err = proc.communicate(timeout=30)
        elapsed = time.monotonic() - lost
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 3, err
    assert err.splitlines() == [
        f"warning: the scheduler at {address} has no workers yet: the trials wait for "
        f"`dask worker {address}`",
        "drake-disamb study run: error: the executor cancelled the trials (the Dask scheduler was lost?); "
        f"0 records in {tmp_path / 'o' / 'trials.jsonl'} (0 written now); rerun the same command to resume",
    ]
    assert out == ""
    assert elapsed < 5, f"took {elapsed:.1f} s"


# -- a person's trial --------------------------------------------------------------------------------


def test_demo_live_record_appends_a_human_record(tmp_path: Path) -> None:
    rec = tmp_path / "people"
    for _ in range(2):
        proc = cli_process(
            "demo", "--quiet", "--live", "--record", str(rec), "--subject", "P01",
            "--out", str(tmp_path / "demo"),
        )  # fmt: skip
        interrupt(proc, signal.SIGINT, after=1.5)
    records = read_records(rec / "trials.jsonl")
    assert [r.trial_id for r in records] == [
        "P01-head_array-reaching-disambiguation-h0",
        "P01-head_array-reaching-disambiguation-h1",
    ]
    for r in records:
        assert r.source == "human" and r.subject == "P01" and r.wall_time == 0.0 and r.seed is None
        assert r.extra["interrupted"] is True and r.done is False and r.duration > 0.5
        trace = np.load(rec / "traces" / f"{r.trial_id}.npz")
        assert set(trace.files) == {*TRACE_ARRAYS, "ik_status"} and len(trace["t"]) > 10


def test_demo_record_needs_live_and_a_subject(tmp_path: Path) -> None:
    res = cli(
        "demo", "--no-meshcat", "--record", str(tmp_path), "--subject", "P01", "--out", str(tmp_path / "d")
    )
    assert res.returncode == 2 and "--record records a person's trial: it needs --live" in res.stderr
    res = cli("demo", "--live", "--record", str(tmp_path), "--subject", "a/b", "--out", str(tmp_path / "d"))
    assert res.returncode == 2 and "field subject: expected" in res.stderr
    res = cli("demo", "--live", "--record", str(tmp_path), "--out", str(tmp_path / "d"))
    assert res.returncode == 2 and "--record needs --subject NAME" in res.stderr


@pytest.mark.parametrize(
    ("subject", "task_name", "field"),
    [("Ünïcødé", None, "subject"), ("٣٣", None, "subject"), ("P01", "r" * 100, "task")],
    ids=["unicode-subject", "arabic-indic-digits", "100-character-task"],
)
def test_demo_record_refuses_what_the_record_would_before_the_trial(
    subject: str, task_name: str | None, field: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A name the record would refuse stops ``demo --live --record`` at the start, by the record's
    own check: one line, status 2, no trial run, nothing recorded (the trial is not lost at the end)."""
    from drake_disamb.cli import main
    from drake_disamb.config import embedded_scenario_text

    task = "reaching"
    if task_name is not None:
        text = embedded_scenario_text("reaching").replace("task: reaching", f"task: {task_name}", 1)
        (tmp_path / "long.yaml").write_text(text, encoding="utf-8")
        task = str(tmp_path / "long.yaml")
    out, rec = tmp_path / "demo", tmp_path / "people"
    code = main(
        ["demo", "--quiet", "--live", "--no-wait", "--duration", "1", "--task", task,
         "--record", str(rec), "--subject", subject, "--out", str(out)]
    )  # fmt: skip
    captured = capsys.readouterr()
    assert code == 2
    (line,) = captured.err.strip().splitlines()
    assert line.startswith(
        f"drake-disamb demo: error: --record: the trial's record would be refused: field {field}: expected"
    )
    assert repr(subject if field == "subject" else task_name)[:40] in line
    assert "running the trial" not in captured.out and not list(out.iterdir())
    assert not (rec / "trials.jsonl").exists() and not list((rec / "traces").iterdir())


def test_demo_record_refuses_goals_the_record_would_before_the_trial(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A reaching scenario with a sixth goal: the trial could reach goal 5, which the reaching
    task's record refuses; ``demo --live --record`` says so at the start (status 2, nothing run)."""
    import copy

    import yaml

    from drake_disamb.cli import main
    from drake_disamb.config import embedded_scenario_text

    data = yaml.safe_load(embedded_scenario_text("reaching"))
    extra = copy.deepcopy(dict(data["goals"][-1], name="extra_goal"))
    extra["position"] = [p + 0.05 for p in extra["position"]]
    data["goals"].append(extra)
    path = tmp_path / "six.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    out, rec = tmp_path / "demo", tmp_path / "people"
    code = main(
        ["demo", "--quiet", "--live", "--no-wait", "--duration", "1", "--task", str(path),
         "--record", str(rec), "--subject", "P01", "--out", str(out)]
    )  # fmt: skip
    captured = capsys.readouterr()
    assert code == 2
    (line,) = captured.err.strip().splitlines()
    assert "--record: the trial's record would be refused: field reached_goals: expected" in line
    assert "running the trial" not in captured.out and not list(out.iterdir())
    assert not (rec / "trials.jsonl").exists()


@pytest.mark.parametrize("failure", ["full-disk", "became-a-study"])
def test_a_trial_the_folder_does_not_take_is_kept_beside_it(
    failure: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """When the folder does not take a person's trial at the end (a full disk; a simulated study's
    description written into it while the trial ran), the record and its trace are kept in a new
    file beside the folder, which the one line names; exit status 4; nothing is overwritten."""
    import errno

    import drake_disamb.study.data.folder as F
    import drake_disamb.trial
    from drake_disamb.cli import main

    rec, trial_id = tmp_path / "people", "P01-head_array-reaching-disambiguation-h0"
    planted = tmp_path / f"people.unsaved-{trial_id}.npz"
    planted.write_bytes(b"someone else's file")
    if failure == "full-disk":

        def full(*args: object, **kwargs: object) -> None:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        monkeypatch.setattr(F, "append_record", full)
        reason = f"cannot write {rec / 'trials.jsonl'}: No space left on device"
    else:
        real_run_trial = drake_disamb.trial.run_trial

        def racing_run_trial(*args: object, **kwargs: object) -> object:
            result = real_run_trial(*args, **kwargs)
            if "stop_requested" in kwargs:  # the person's trial, not the warm-up
                (rec / "study.yaml").write_text("format: 1\n")
            return result

        monkeypatch.setattr(drake_disamb.trial, "run_trial", racing_run_trial)
        reason = f"study folder {rec} holds a simulated study ({rec / 'study.yaml'})"
    code = main(
        ["demo", "--quiet", "--live", "--no-wait", "--duration", "1", "--record", str(rec),
         "--subject", "P01", "--out", str(tmp_path / "demo")]
    )  # fmt: skip
    captured = capsys.readouterr()
    kept = tmp_path / f"people.unsaved-{trial_id}.1.npz"
    assert code == 4
    (line,) = captured.err.strip().splitlines()
    assert line.startswith(f"drake-disamb demo: error: --record: {rec} did not take the trial ({reason}")
    assert line.endswith(f"; it is kept in {kept}")
    assert planted.read_bytes() == b"someone else's file"
    record, trace = F.read_unsaved(kept)
    assert (record.trial_id, record.subject, record.source) == (trial_id, "P01", "human")
    assert record.duration > 0.5 and set(trace) == {*TRACE_ARRAYS, "ik_status"} and len(trace["t"]) > 10
    assert json.loads((tmp_path / "demo" / "metrics.json").read_text())["time"] == record.duration
    assert not (rec / "trials.jsonl").exists()
    monkeypatch.undo()
    (rec / "study.yaml").unlink(missing_ok=True)
    F.StudyFolder(rec).append(record, trace)  # what the docs say to do once the folder can be written
    assert [t.record.trial_id for t in F.StudyFolder(rec).read_trials()] == [trial_id]
    F.StudyFolder(rec).release()


@pytest.mark.slow
@pytest.mark.parametrize("task", ["reaching", "pouring"])
def test_every_start_pose_is_valid_and_its_trials_succeed(task: str) -> None:
    """The protocol's start poses pass the scenario's start-posture checks (building the scenario)
    and a trial from each succeeds (head array, disambiguation, the first goal of every stage)."""
    import dataclasses

    from drake_disamb.study.run.runner import StudyContext, trial_scenario
    from drake_disamb.trial import run_trial

    data = compatible_protocol_data()
    data["paradigms"] = [{"name": "disambiguation", "trials": 1}]
    protocol = P.protocol_from_dict(data)
    context = StudyContext(protocol=P.protocol_to_dict(protocol))
    spec = next(s for s in P.expand_trials(protocol, 0) if s.task == task)
    postures = []
    for pose in range(3):
        one = dataclasses.replace(
            spec, interface="head_array", start_pose=pose, initial_mode=0, goals=(0,) * len(spec.goals)
        )
        scenario = trial_scenario(one, context)
        postures.append(scenario.start_joint_positions)
        result = run_trial(scenario, progress=False)
        assert result.success, (
            f"{task} start pose {pose}: reached {result.reached_goal_names} at {result.time} s"
        )
    assert len({tuple(p) if p else None for p in postures}) == 3


def test_trials_are_submitted_longest_first(tmp_path: Path) -> None:
    """Multi-step tasks and the head array first, so that no worker starts a long trial last. A
    fake executor records the order and fails every trial (nothing is simulated or written)."""
    import concurrent.futures as cf

    from drake_disamb.study.run.runner import TrialOutput

    class Recording(cf.Executor):
        def __init__(self) -> None:
            self.order: list = []

        def submit(self, fn, spec, *args, **kwargs):  # type: ignore[no-untyped-def, override]
            self.order.append(spec)
            future: cf.Future = cf.Future()
            future.set_result(TrialOutput(record=None, trace={}, error="RuntimeError: not run"))
            return future

    data = compatible_protocol_data()
    data.update(subjects=1)
    plan = plan_study(tmp_path / "s", P.protocol_from_dict(data), 0)
    executor = Recording()
    result = run_study(plan, executor)
    assert len(result.errors) == len(plan.pending) == len(executor.order) and not result.ran
    keys = [(len(s.goals), s.interface != "joystick") for s in executor.order]
    assert keys == sorted(keys, reverse=True) and keys[0] != keys[-1]
    assert sorted(s.trial_id for s in executor.order) == sorted(s.trial_id for s in plan.pending)


# -- one writer, signals ----------------------------------------------------------------------------


def _session_processes(sid: int) -> list[int]:
    """PIDs of the live processes of session ``sid`` (from /proc)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":  # fields[3]: the session id, [0]: the state
            pids.append(int(entry.name))
    return pids


def _start_run(out: Path, protocol: Path) -> subprocess.Popen:
    argv = ["study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3", "--workers", "2"]
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen(
        [sys.executable, "-m", "drake_disamb.cli", *argv, "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )


@pytest.mark.slow
def test_sigterm_stops_the_run_leaves_no_process_and_a_rerun_completes(
    reference: tuple[Path, dict], tmp_path: Path
) -> None:
    out = tmp_path / "term"
    protocol = write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())
    proc = _start_run(out, protocol)
    records = out / "trials.jsonl"
    try:
        end = time.monotonic() + 180
        while time.monotonic() < end and not (records.exists() and records.read_bytes().count(b"\n") >= 1):
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)  # to the main process only, as a scheduler or `timeout` does
        _, err = proc.communicate(timeout=30)
        gone = time.monotonic() + 5.0
        while _session_processes(proc.pid) and time.monotonic() < gone:
            time.sleep(0.1)
        assert _session_processes(proc.pid) == []
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert "stopped by SIGTERM" in err and "rerun the same command to resume" in err
    assert "Traceback" not in err
    res = cli("study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3", "--workers", "2")
    assert res.returncode == 0, res.stderr
    assert records_by_id(read_records(records)) == reference[1]


@pytest.mark.slow
def test_ctrl_c_to_the_process_group_prints_no_worker_traceback(tmp_path: Path) -> None:
    data = tiny_protocol_data()
    data["subjects"] = 8  # 32 trials: still running when the first record is written
    protocol = write_yaml(tmp_path / "protocol.yaml", data)
    proc = _start_run(tmp_path / "int", protocol)
    records = tmp_path / "int" / "trials.jsonl"
    try:
        wait_for_line(proc, "trials to run", timeout=180)
        end = time.monotonic() + 180
        while time.monotonic() < end and not (records.exists() and records.read_bytes().count(b"\n") >= 1):
            time.sleep(0.05)  # the workers are running trials
        os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert err.strip().count("\n") == 0 and "stopped by SIGINT" in err


@pytest.mark.slow
def test_two_concurrent_runs_one_is_refused_and_the_folder_reports_and_resumes(
    reference: tuple[Path, dict], tmp_path: Path
) -> None:
    out = tmp_path / "both"
    protocol = write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())
    first = _start_run(out, protocol)
    try:
        wait_for_line(first, "trials to run", timeout=180)
        start = time.monotonic()
        second = cli("study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3")
        assert second.returncode == 2 and f"PID {first.pid}" in second.stderr, second.stderr
        # the lock is the first check: refused as soon as the command has started (its imports)
        assert "Traceback" not in second.stderr and time.monotonic() - start < 10
        first.communicate(timeout=300)
    finally:
        if first.poll() is None:
            os.killpg(first.pid, signal.SIGKILL)
    assert first.returncode == 0
    assert records_by_id(read_records(out / "trials.jsonl")) == reference[1]
    assert cli("study", "report", str(out), "--no-mixed-model").returncode == 0
    res = cli("study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3")
    assert res.returncode == 0 and "0 trials to run" in res.stdout, res.stderr
