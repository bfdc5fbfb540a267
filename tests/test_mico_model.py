"""Our MICO model (models/mico) against an independent classic-DH computation, plus physical sanity."""

from __future__ import annotations

import logging
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import BodyIndex, JointIndex

from drake_disamb import paths

# Kinova "DH Parameters of Mico" v1.0.1 (classic DH), transcribed independently of the model generator.
_D1, _D2, _D3, _D4, _D5, _D6, _E2 = 0.2755, 0.2900, 0.1233, 0.0741, 0.0741, 0.1600, 0.0070
_AA = math.pi / 6
_D4B = _D3 + math.sin(_AA) / math.sin(2 * _AA) * _D4
_D5B = math.sin(_AA) / math.sin(2 * _AA) * (_D4 + _D5)
_D6B = math.sin(_AA) / math.sin(2 * _AA) * _D5 + _D6
_ROWS = [  # (d, a, alpha)
    (_D1, 0.0, math.pi / 2),
    (0.0, _D2, math.pi),
    (-_E2, 0.0, math.pi / 2),
    (-_D4B, 0.0, 2 * _AA),
    (-_D5B, 0.0, 2 * _AA),
    (-_D6B, 0.0, math.pi),
]


def _dh(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Classic DH: Rz(theta) Tz(d) Tx(a) Rx(alpha) as a 4x4 matrix."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def _dh_frames(q: np.ndarray) -> list[np.ndarray]:
    """DH frames 0..6 in the base frame."""
    X = np.eye(4)
    out = [X]
    for theta, (d, a, alpha) in zip(q, _ROWS, strict=True):
        X = X @ _dh(theta, d, a, alpha)
        out.append(X)
    return out


@pytest.fixture(scope="module")
def mico():
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.package_map().Add(paths.MODELS_PACKAGE, str(paths.models_dir()))
    (instance,) = parser.AddModels(str(paths.mico_urdf()))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("mico_link_base"))
    plant.Finalize()
    return plant, instance


def _arm_joints(plant):
    return [plant.GetJointByName(f"mico_joint_{i}") for i in range(1, 7)]


def test_parses_without_warnings(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING)
    plant = MultibodyPlant(0.001)
    parser = Parser(plant)
    parser.package_map().Add(paths.MODELS_PACKAGE, str(paths.models_dir()))
    ProcessModelDirectives(LoadModelDirectives(str(paths.mico_directives())), plant, parser)
    plant.Finalize()
    drake_warnings = [
        r for r in caplog.records if r.levelno >= logging.WARNING and r.name.startswith("drake")
    ]
    assert drake_warnings == []
    assert plant.HasModelInstanceNamed("mico") and plant.HasModelInstanceNamed("table")
    # The base is welded at the world origin: W is the base frame.
    ctx = plant.CreateDefaultContext()
    X_WB = plant.GetFrameByName("mico_link_base").CalcPoseInWorld(ctx)
    assert np.allclose(X_WB.GetAsMatrix4(), np.eye(4))


def test_structure(mico) -> None:
    plant, instance = mico
    names = [plant.get_joint(j).name() for j in plant.GetJointIndices(instance)]
    for i in range(1, 7):
        assert plant.GetJointByName(f"mico_joint_{i}").type_name() == "revolute"
    for side in ("left", "right"):
        assert plant.GetJointByName(f"mico_finger_joint_{side}").type_name() == "prismatic"
    assert plant.num_positions() == 8 and plant.num_actuators() == 8, names
    plant.GetFrameByName("mico_end_effector")
    for a in plant.GetJointActuatorIndices(instance):
        assert plant.get_joint_actuator(a).effort_limit() > 0


def test_forward_kinematics_matches_dh(mico) -> None:
    plant, _ = mico
    ctx = plant.CreateDefaultContext()
    joints = _arm_joints(plant)
    lo = np.array([j.position_lower_limits()[0] for j in joints])
    hi = np.array([j.position_upper_limits()[0] for j in joints])
    rng = np.random.default_rng(20200101)
    ee = plant.GetFrameByName("mico_end_effector")
    base = plant.GetFrameByName("mico_link_base")
    worst_p, worst_r = 0.0, 0.0
    for _ in range(50):
        q = rng.uniform(lo, hi)
        for j, qi in zip(joints, q, strict=True):
            j.set_angle(ctx, qi)
        X = plant.CalcRelativeTransform(ctx, base, ee).GetAsMatrix4()
        X_dh = _dh_frames(q)[-1]
        worst_p = max(worst_p, float(np.linalg.norm(X[:3, 3] - X_dh[:3, 3])))
        R_err = X[:3, :3].T @ X_dh[:3, :3]
        worst_r = max(worst_r, math.acos(max(-1.0, min(1.0, (np.trace(R_err) - 1) / 2))))
    assert worst_p < 1e-3, worst_p
    assert worst_r < 1e-3, worst_r


def test_link_frames_are_dh_frames(mico) -> None:
    """mico_link_{i+1}'s origin is DH frame i's origin (so visuals drawn between them sit on the arm)."""
    plant, _ = mico
    ctx = plant.CreateDefaultContext()
    q = np.array([0.3, 1.2, 4.0, -0.7, 1.1, 2.0])
    for j, qi in zip(_arm_joints(plant), q, strict=True):
        j.set_angle(ctx, qi)
    frames = _dh_frames(q)
    for i in range(1, 6):
        p = plant.GetFrameByName(f"mico_link_{i + 1}").CalcPoseInWorld(ctx).translation()
        assert np.allclose(p, frames[i][:3, 3], atol=1e-9), i


def test_joint_limits_are_physical(mico) -> None:
    """Kinova's actuator limits in DH angles are centred on the straight-up ("candle") pose."""
    plant, _ = mico
    joints = _arm_joints(plant)
    mid = [(j.position_lower_limits()[0] + j.position_upper_limits()[0]) / 2 for j in joints]
    assert math.degrees(
        joints[1].position_upper_limits()[0] - joints[1].position_lower_limits()[0]
    ) == pytest.approx(266)
    assert math.degrees(
        joints[2].position_upper_limits()[0] - joints[2].position_lower_limits()[0]
    ) == pytest.approx(322)
    q = np.array([0.0, mid[1], mid[2], 0.0, 0.0, 0.0])
    frames = _dh_frames(q)
    shoulder, elbow, wrist = frames[1][:3, 3], frames[2][:3, 3], frames[4][:3, 3]
    assert np.allclose(elbow[:2], shoulder[:2], atol=1e-9) and elbow[2] > shoulder[2] + 0.28
    assert abs(wrist[0]) < 0.01 and wrist[2] > elbow[2] + 0.16  # forearm continues straight up
    for j in joints:
        assert j.velocity_upper_limits()[0] == pytest.approx(-j.velocity_lower_limits()[0])
        assert 0.5 < j.velocity_upper_limits()[0] < 0.9


def test_masses_and_inertias(mico) -> None:
    plant, instance = mico
    ctx = plant.CreateDefaultContext()
    assert plant.CalcTotalMass(ctx, [instance]) == pytest.approx(4.6, abs=1e-9)
    for b in plant.GetBodyIndices(instance):
        body = plant.get_body(b)
        if body.name() == "mico_end_effector":
            continue  # a massless marker link
        M = body.CalcSpatialInertiaInBodyFrame(ctx)
        assert M.get_mass() > 0, body.name()
        assert M.IsPhysicallyValid(), body.name()
        moments = np.sort(M.CalcRotationalInertia().CalcPrincipalMomentsOfInertia())
        assert moments[0] > 0 and moments[0] + moments[1] >= moments[2] * (1 - 1e-9), body.name()


def test_fingers_open_symmetrically(mico) -> None:
    plant, _ = mico
    ctx = plant.CreateDefaultContext()
    plant.GetJointByName("mico_finger_joint_left").set_translation(ctx, 0.03)
    plant.GetJointByName("mico_finger_joint_right").set_translation(ctx, 0.03)
    ee = plant.GetFrameByName("mico_end_effector")
    X_EL = plant.CalcRelativeTransform(ctx, ee, plant.GetFrameByName("mico_link_finger_left"))
    X_ER = plant.CalcRelativeTransform(ctx, ee, plant.GetFrameByName("mico_link_finger_right"))
    assert np.allclose(X_EL.translation(), [0, 0.03, 0]) and np.allclose(X_ER.translation(), [0, -0.03, 0])


def test_table_top_at_z0() -> None:
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.package_map().Add(paths.MODELS_PACKAGE, str(paths.models_dir()))
    ProcessModelDirectives(LoadModelDirectives(str(paths.mico_directives())), plant, parser)
    plant.Finalize()
    inspector_bodies = [plant.get_body(BodyIndex(i)).name() for i in range(plant.num_bodies())]
    assert "table_top" in inspector_bodies
    assert all(plant.get_joint(JointIndex(i)).num_positions() in (0, 1) for i in range(plant.num_joints()))
    X = plant.GetFrameByName("table_top").CalcPoseInWorld(plant.CreateDefaultContext())
    assert X.IsExactlyEqualTo(RigidTransform())


def test_models_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    found = paths.models_dir()
    assert (found / "mico" / "mico.urdf").is_file()
    assert paths.mico_directives().is_file()
    # An override pointing at a copy is honoured; one pointing nowhere falls through to the checkout.
    monkeypatch.setenv(paths.MODELS_ENV_VAR, str(tmp_path))
    assert paths.models_dir() == found
    (tmp_path / "mico").mkdir()
    (tmp_path / "mico" / "mico.urdf").write_text("<robot/>")
    assert paths.models_dir() == tmp_path.resolve()
    # Nothing anywhere: a clear error naming the places searched.
    monkeypatch.setattr(paths, "_candidates", lambda: [tmp_path / "nope"])
    with pytest.raises(FileNotFoundError, match="DRAKE_DISAMB_MODELS"):
        paths.models_dir()


def test_generated_urdf_is_up_to_date(monkeypatch: pytest.MonkeyPatch) -> None:
    """The committed URDF is exactly what models/mico/make_mico_urdf.py writes."""
    import importlib.util

    script = paths.models_dir() / "mico" / "make_mico_urdf.py"
    if not script.is_file():
        pytest.skip("generator script not shipped")
    spec = importlib.util.spec_from_file_location("_make_mico_urdf", script)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    assert module.make_urdf() == paths.mico_urdf().read_text()
