"""Tests of the MICO station (drake_disamb.station), alone with its joint-level inputs and behind its
controllers (drake_disamb.controller: the differential IK, the gripper's). No Meshcat."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_disamb.controller import IkStatus, add_station_controller, build_controlled_station
from drake_disamb.station import (
    ARM_JOINTS,
    FINGER_JOINTS,
    FINGER_MAX_OPENING,
    MICO_HOME_GRIPPER_OPENING,
    MICO_HOME_Q,
    STATION_INPUTS,
    STATION_OUTPUTS,
    EndEffectorState,
    JointVelocityIntegrator,
    SceneObject,
    StationConfig,
    build_station,
    default_plant_config,
)


def _R(pose: np.ndarray) -> RotationMatrix:
    return RotationMatrix(Quaternion(pose[3:] / np.linalg.norm(pose[3:])))


def _rotation_vector(p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Rotation from pose p0 to pose p1 as a world-frame rotation vector (rad)."""
    aa = _R(p1).multiply(_R(p0).inverse()).ToAngleAxis()
    return aa.axis() * aa.angle()


class Rig:
    """One station behind its controllers + simulator, reset to the home state for each test."""

    def __init__(self, config: StationConfig | None = None, objects=()) -> None:
        self.station = build_station(config, objects)
        self.controlled = build_controlled_station(self.station)
        self.diagram = self.controlled.diagram
        self.sim = Simulator(self.diagram)
        self.ctx = self.sim.get_mutable_context()
        self.command(np.zeros(6))
        self.gripper(0.0)
        self.sim.Initialize()
        self.home = self.ctx.Clone()

    def reset(self) -> None:
        self.ctx.SetTimeStateAndParametersFrom(self.home)
        self.command(np.zeros(6))
        self.gripper(0.0)
        self.sim.Initialize()

    def command(self, V) -> None:
        self.diagram.GetInputPort("ee_velocity_command").FixValue(self.ctx, np.asarray(V, dtype=float))

    def gripper(self, speed: float) -> None:
        self.diagram.GetInputPort("gripper_command").FixValue(self.ctx, [speed])

    def advance(self, dt: float) -> None:
        self.sim.AdvanceTo(self.ctx.get_time() + dt)

    def out(self, name: str) -> np.ndarray:
        return np.array(self.diagram.GetOutputPort(name).Eval(self.ctx), copy=True)

    def sub(self, system, port: str) -> np.ndarray:  # noqa: ANN001
        """The output ``port`` of subsystem ``system`` in the rig's context."""
        return np.array(system.GetOutputPort(port).Eval(system.GetMyContextFromRoot(self.ctx)), copy=True)

    def status(self) -> IkStatus:
        return IkStatus(int(self.out("ik_status")[0]))


@pytest.fixture(scope="module")
def rig() -> Rig:
    return Rig()


@pytest.fixture
def home(rig: Rig) -> Rig:
    rig.reset()
    return rig


def test_ports_and_home(home: Rig) -> None:
    d = home.station.diagram
    inputs = {d.get_input_port(k).get_name(): d.get_input_port(k).size() for k in range(d.num_input_ports())}
    assert inputs == {"arm_velocity_command": 6, "finger_velocity_command": 2}  # joint level
    assert set(STATION_INPUTS) == set(inputs)
    sizes = {n: d.GetOutputPort(n).size() for n in STATION_OUTPUTS if n != "query_object"}
    assert sizes == {
        "ee_pose": 7,
        "ee_velocity": 6,
        "arm_joint_state": 12,
        "finger_state": 4,
        "gripper_opening": 1,
    }
    assert not d.HasOutputPort("ik_status")  # the controller's, not the hardware's
    assert home.diagram.GetOutputPort("ik_status").size() == 1
    pose = home.out("ee_pose")
    assert np.allclose(pose[:3], [0.0, -0.35, 0.30], atol=2e-3)
    assert np.allclose(_R(pose).matrix()[:, 2], [0, 0, -1], atol=1e-3)  # gripper points down
    assert np.allclose(home.out("arm_joint_state")[:6], MICO_HOME_Q, atol=1e-12)
    assert home.out("gripper_opening")[0] == pytest.approx(home.station.config.home_gripper_opening)
    # Gravity compensation + PD hold the arm still with a zero command.
    home.advance(0.5)
    assert np.linalg.norm(home.out("ee_pose")[:3] - pose[:3]) < 5e-4
    assert np.linalg.norm(home.out("ee_velocity")) < 1e-3
    assert home.status() == IkStatus.OK


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_translation(home: Rig, axis: int, sign: float) -> None:
    p0 = home.out("ee_pose")
    V = np.zeros(6)
    V[axis] = 0.05 * sign
    home.command(V)
    home.advance(0.5)
    assert np.allclose(home.out("ee_velocity"), V, atol=5e-3)  # measured velocity, paper order
    home.advance(0.5)
    home.command(np.zeros(6))
    home.advance(0.3)  # settle
    p1 = home.out("ee_pose")
    expected = np.zeros(3)
    expected[axis] = 0.05 * sign
    assert np.all(np.abs(p1[:3] - p0[:3] - expected) < 3e-3), p1[:3] - p0[:3]
    assert np.linalg.norm(_rotation_vector(p0, p1)) < 0.02


@pytest.mark.parametrize("axis", [3, 4, 5])
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_rotation(home: Rig, axis: int, sign: float) -> None:
    p0 = home.out("ee_pose")
    V = np.zeros(6)
    V[axis] = 0.2 * sign
    home.command(V)
    home.advance(1.0)
    home.command(np.zeros(6))
    home.advance(0.3)
    p1 = home.out("ee_pose")
    expected = np.zeros(3)
    expected[axis - 3] = 0.2 * sign
    assert np.all(np.abs(_rotation_vector(p0, p1) - expected) < 0.02), _rotation_vector(p0, p1)
    assert np.linalg.norm(p1[:3] - p0[:3]) < 5e-3


def test_gripper_opens_and_closes(home: Rig) -> None:
    o0 = home.out("gripper_opening")[0]
    p0 = home.out("ee_pose")
    home.gripper(0.04)
    home.advance(0.5)
    home.gripper(0.0)
    home.advance(0.2)
    o1 = home.out("gripper_opening")[0]
    assert o1 - o0 == pytest.approx(0.02, abs=2e-3)
    home.gripper(-0.1)
    home.advance(1.5)
    home.gripper(0.0)
    home.advance(0.2)
    assert home.out("gripper_opening")[0] < 2e-3  # fully closed
    home.gripper(1.0)  # far faster than the fingers can go: the set point saturates at the limit
    home.advance(1.0)
    home.gripper(0.0)
    home.advance(0.5)
    assert home.out("gripper_opening")[0] == pytest.approx(FINGER_MAX_OPENING, abs=3e-3)
    assert np.linalg.norm(home.out("ee_pose")[:3] - p0[:3]) < 1e-3  # the arm did not move


def _limits(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    return rig.controlled.diff_ik.joint_position_limits


def _arm_jacobian(rig: Rig, q_arm) -> np.ndarray:  # noqa: ANN001
    """Drake's 6 x 6 end-effector Jacobian ([w; v] rows, world frame) at arm positions ``q_arm``."""
    cp = rig.station.control_plant
    cc = cp.CreateDefaultContext()
    q = cp.GetPositions(cc)
    q[:6] = q_arm
    cp.SetPositions(cc, q)
    return cp.CalcJacobianSpatialVelocity(
        cc,
        JacobianWrtVariable.kV,
        cp.GetFrameByName("mico_end_effector"),
        np.zeros(3),
        cp.world_frame(),
        cp.world_frame(),
    )[:, :6]


def test_drive_towards_singularity(home: Rig) -> None:
    """Straight up at fixed orientation runs into the wrist singularity (theta_5 -> 0).

    The arm rises along the command, slows as it nears the singularity and stops short of it, with
    the status saying so; it never trades the command's direction for progress (the old damped IK
    kept rising but drifted sideways and turned). Joints stay inside their limits, nothing is NaN.
    """
    lo, hi = _limits(home)
    p0 = home.out("ee_pose")
    home.command([0, 0, 0.1, 0, 0, 0])
    seen = set()
    for _ in range(50):
        home.advance(0.1)
        x = home.out("arm_joint_state")
        assert np.all(np.isfinite(x))
        assert np.all(x[:6] >= lo - 1e-3) and np.all(x[:6] <= hi + 1e-3)
        seen.add(home.status())
    assert IkStatus.SINGULAR in seen
    assert home.status() in (IkStatus.SINGULAR, IkStatus.STOPPED)  # still at the singularity
    assert abs(x[4]) < 0.2  # next to theta_5 = 0, never through it
    p1 = home.out("ee_pose")
    assert p1[2] - p0[2] > 0.05  # rose along the command
    assert np.linalg.norm(p1[:2] - p0[:2]) < 0.01  # and nowhere else
    assert np.linalg.norm(home.out("ee_velocity")) < 0.01  # stopped
    assert np.linalg.norm(_rotation_vector(p0, p1)) < 0.05  # the orientation held


def test_drive_into_joint_limit() -> None:
    """Command the Cartesian velocity that closes the elbow (joint 3) until it reaches its limit.

    Joint 3 brakes toward its limit and the arm stops, status saying so: the other joints do not
    carry on in some other direction (the old IK did, 36 degrees off the command). The arm is
    near a singularity there too (the smallest singular value about 0.003 at the limit, 0.01 some
    0.08 rad before it): it stops at the singular barrier (``IkParams.singular_barrier``), short of
    the limit, or on it.
    """
    start = np.array(MICO_HOME_Q)
    start[2] = math.radians(109.0) + 0.2  # 0.2 rad above the lower limit of joint 3 (DH 109 deg)
    rig = Rig(StationConfig(home_q=tuple(start)))
    lo, hi = _limits(rig)
    J = _arm_jacobian(rig, start)
    V_drake = J @ np.array([0, 0, -0.5, 0, 0, 0])  # what joint 3 alone moving at -0.5 rad/s does
    V = np.concatenate([V_drake[3:], V_drake[:3]])
    p0 = rig.out("ee_pose")
    rig.command(V)
    at_limit = []
    for _ in range(20):
        rig.advance(0.1)
        x = rig.out("arm_joint_state")
        assert np.all(np.isfinite(x))
        assert np.all(x[:6] >= lo - 1e-3) and np.all(x[:6] <= hi + 1e-3), x[:6] - lo
        if x[2] - lo[2] < 0.1:  # joint 3 sits at (or at the singular barrier before) its lower limit
            at_limit.append(rig.status())
    assert np.linalg.norm(rig.out("ee_velocity")[:3]) < 0.005  # stopped there
    assert len(at_limit) >= 5, at_limit
    assert set(at_limit) <= {IkStatus.STOPPED, IkStatus.LIMITED, IkStatus.SINGULAR}
    # Everything it did was along the command: displacement parallel to V's linear part.
    d = rig.out("ee_pose")[:3] - p0[:3]
    e = V[:3] / np.linalg.norm(V[:3])
    assert np.linalg.norm(d - (d @ e) * e) < 0.01 and d @ e > 0.02


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_command_is_zero(home: Rig, bad: float) -> None:
    x0 = home.out("arm_joint_state")
    home.command([0.05, bad, 0, 0, 0, 0])
    with pytest.warns(RuntimeWarning, match="non-finite") as record:
        home.advance(2.05)  # 206 bad control steps, warnings at most once per simulated second
    assert len(record) == 3  # t = 0, 1 and 2 s
    assert home.status() == IkStatus.INVALID_COMMAND
    x1 = home.out("arm_joint_state")
    assert np.all(np.isfinite(x1))
    assert np.allclose(x1[:6], x0[:6], atol=1e-3)  # treated as zero: the arm held still
    # A valid command afterwards works as usual.
    home.command([0.05, 0, 0, 0, 0, 0])
    home.advance(0.3)
    assert home.status() == IkStatus.OK
    assert home.out("ee_velocity")[0] > 0.04


def test_warnings_are_rate_limited(home: Rig) -> None:
    home.command([np.nan] * 6)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        home.advance(2.5)
    messages = [str(w.message) for w in record if issubclass(w.category, RuntimeWarning)]
    assert len(messages) == 3, messages  # t = 0, 1, 2 s (warn_interval = 1 s), not 250
    assert "suppressed" in messages[-1]


def test_wrong_length_command_is_rejected(home: Rig) -> None:
    x0 = home.out("arm_joint_state")
    with pytest.raises(RuntimeError, match="size=6"):
        home.command(np.zeros(5))
    with pytest.raises(RuntimeError, match="size=1"):
        home.diagram.GetInputPort("gripper_command").FixValue(home.ctx, [0.0, 0.0])
    station = build_station()
    station_ctx = station.diagram.CreateDefaultContext()
    with pytest.raises(RuntimeError, match="size=6"):
        station.diagram.GetInputPort("arm_velocity_command").FixValue(station_ctx, np.zeros(7))
    with pytest.raises(RuntimeError, match="size=2"):
        station.diagram.GetInputPort("finger_velocity_command").FixValue(station_ctx, [0.0])
    home.advance(0.2)  # the previous (zero) commands are still in place
    assert np.allclose(home.out("arm_joint_state"), x0, atol=1e-4)
    assert home.status() == IkStatus.OK


def test_non_finite_gripper_command(home: Rig) -> None:
    o0 = home.out("gripper_opening")[0]
    home.gripper(float("nan"))
    with pytest.warns(RuntimeWarning, match="gripper_command"):
        home.advance(0.3)
    assert home.out("gripper_opening")[0] == pytest.approx(o0, abs=1e-4)


def test_tracking_error_reseeds() -> None:
    """If the plant is moved away from the set point (e.g. blocked), the set point follows it: the
    IK's and the simulated arm's own, at the same tick."""
    rig = Rig()
    pc = rig.station.plant_context(rig.ctx)
    q = rig.station.plant.GetPositions(pc, rig.station.arm)
    q[0] += 0.5
    rig.station.plant.SetPositions(pc, rig.station.arm, q)
    rig.advance(0.005)  # one control step (at t = 0)
    assert rig.status() == IkStatus.RESEEDED
    np.testing.assert_array_equal(rig.sub(rig.controlled.diff_ik, "set_point"), q[:6])
    np.testing.assert_array_equal(rig.sub(rig.station.integrator, "desired_state")[:6], q[:6])
    rig.advance(0.5)
    assert rig.status() == IkStatus.OK
    assert rig.out("arm_joint_state")[0] == pytest.approx(q[0], abs=0.02)


def test_the_arms_set_point_is_the_iks_at_every_tick() -> None:
    """The simulated arm integrates the joint velocities the IK outputs as the IK integrates its own
    set point: the set point the plant tracks is the IK's, bit for bit, moving, at a joint limit,
    across a reseed and between ticks (a plant step finer than the control period)."""
    rig = Rig(StationConfig(plant_config=default_plant_config(0.005)))
    ik, integrator = rig.controlled.diff_ik, rig.station.integrator
    pc = rig.station.plant_context(rig.ctx)
    seen = set()
    for k, V in enumerate(([0.05, 0, 0.03, 0, 0, 0.2], [0, 0, 0.1, 0, 0, 0], [0, -0.1, 0, 0.3, 0, 0])):
        rig.command(V)
        for _ in range(60):
            rig.advance(0.005)
            np.testing.assert_array_equal(rig.sub(integrator, "desired_state")[:6], rig.sub(ik, "set_point"))
            np.testing.assert_array_equal(
                rig.sub(integrator, "desired_state")[8:14], rig.sub(ik, "arm_velocity_command")
            )
            seen.add(rig.status())
        if k == 0:  # push the arm away: both reseed
            q = rig.station.plant.GetPositions(pc, rig.station.arm)
            q[1] += 0.3
            rig.station.plant.SetPositions(pc, rig.station.arm, q)
    assert {IkStatus.OK, IkStatus.RESEEDED} <= seen and seen - {IkStatus.OK, IkStatus.RESEEDED}


def test_scene_objects_and_attached_cup() -> None:
    box = SceneObject("shelf", "box", (0.1, 0.2, 0.05), (0.3, -0.5, 0.025, 1, 0, 0, 0))
    cup = SceneObject(
        "cup", "cylinder", (0.035, 0.1), (0, 0, -0.01, 1, 0, 0, 0), attached_to_gripper=True, mass=0.3
    )
    ball = SceneObject("ball", "sphere", (0.03,), (-0.3, -0.4, 0.03, 1, 0, 0, 0), rgba=(0, 0, 1, 1))
    rig = Rig(StationConfig(scene_objects=(box,)), objects=(cup, ball))
    st = rig.station
    assert [o.name for o in st.scene_objects] == ["shelf", "cup", "ball"]
    pc = st.plant_context(rig.ctx)
    inspector = rig.out  # noqa: F841  (outputs still evaluate with objects present)
    X_WB = st.plant.GetBodyByName("shelf").EvalPoseInWorld(pc)
    assert np.allclose(X_WB.translation(), [0.3, -0.5, 0.025])
    # The cup moves with the end effector and its weight is compensated: the arm holds still.
    p0 = rig.out("ee_pose")
    rig.advance(0.5)
    assert np.linalg.norm(rig.out("ee_pose")[:3] - p0[:3]) < 1e-3
    rig.command([0.05, 0, 0, 0, 0, 0])
    rig.advance(1.0)
    rig.command(np.zeros(6))
    rig.advance(0.3)
    X_WE = st.plant.GetFrameByName("mico_end_effector").CalcPoseInWorld(pc)
    X_WC = st.plant.GetBodyByName("cup").EvalPoseInWorld(pc)
    assert np.allclose((X_WE.inverse() @ X_WC).translation(), [0, 0, -0.01], atol=1e-9)
    assert rig.out("ee_pose")[0] - p0[0] == pytest.approx(0.05, abs=3e-3)
    query = rig.diagram.GetOutputPort("query_object").Eval(rig.ctx)
    names = {query.inspector().GetName(g) for g in query.inspector().GetAllGeometryIds()}
    assert any("cup" in n for n in names) and any("shelf" in n for n in names)


def test_embedded_in_a_bigger_diagram() -> None:
    builder = DiagramBuilder()
    st = build_station()
    station = builder.AddSystem(st.diagram)
    assert station.GetSubsystemByName("joint_velocity_integrator") is st.integrator  # documented names
    assert station.GetSubsystemByName("plant") is st.plant
    controller = add_station_controller(builder, st)
    src = builder.AddSystem(ConstantVectorSource([0.0, 0.0, 0.05, 0.0, 0.0, 0.0]))
    grip = builder.AddSystem(ConstantVectorSource([0.0]))
    builder.Connect(src.get_output_port(), controller.diff_ik.GetInputPort("ee_velocity_command"))
    builder.Connect(grip.get_output_port(), controller.gripper.GetInputPort("gripper_command"))
    builder.ExportOutput(station.GetOutputPort("ee_pose"), "pose")
    diagram = builder.Build()
    sim = Simulator(diagram)
    sim.Initialize()
    p0 = diagram.GetOutputPort("pose").Eval(sim.get_context()).copy()
    sim.AdvanceTo(0.4)
    p1 = diagram.GetOutputPort("pose").Eval(sim.get_context())
    assert p1[2] - p0[2] == pytest.approx(0.05 * 0.4, abs=3e-3)
    q = st.plant.GetPositions(st.plant_context(sim.get_context()), st.arm)  # from the outer root
    assert q[0] != MICO_HOME_Q[0] and q.size == 8


# ----------------------------------------------------------------------------------------------
# The leaf systems in isolation, with fixed inputs.
# ----------------------------------------------------------------------------------------------
def _integrator(rig: Rig, **kwargs) -> tuple[JointVelocityIntegrator, object]:  # noqa: ANN003
    lower, upper = rig.station.geometry.joint_limits()
    options = {"reseed_tolerance": 0.15, **kwargs}
    system = JointVelocityIntegrator(0.01, lower, upper, 0.06, MICO_HOME_Q, (0.04, 0.04), **options)
    ctx = system.CreateDefaultContext()
    system.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([MICO_HOME_Q, np.zeros(6)]))
    system.GetInputPort("finger_state").FixValue(ctx, [0.04, 0.04, 0.0, 0.0])
    return system, ctx


def test_joint_velocity_integrator_alone(rig: Rig) -> None:
    """The simulated arm's velocity mode: rad/s and m/s in, the set point [q; v] (rad, m, rad/s,
    m/s) for the end of the period out, at once; the state advances at the tick."""
    system, ctx = _integrator(rig)
    assert {system.get_input_port(k).get_name(): system.get_input_port(k).size() for k in range(4)} == {
        "arm_velocity_command": 6,
        "finger_velocity_command": 2,
        "arm_joint_state": 12,
        "finger_state": 4,
    }
    v = np.array([0.1, -0.2, 0.0, 0.0, 0.3, 0.0])
    system.GetInputPort("arm_velocity_command").FixValue(ctx, v)
    system.GetInputPort("finger_velocity_command").FixValue(ctx, [0.01, 0.01])
    desired = system.GetOutputPort("desired_state").Eval(ctx)
    np.testing.assert_allclose(desired[:6], np.asarray(MICO_HOME_Q) + v * 0.01, rtol=0, atol=1e-15)
    np.testing.assert_allclose(desired[6:8], [0.0401, 0.0401], atol=1e-15)
    np.testing.assert_array_equal(desired[8:14], v)  # the arm's: the command
    np.testing.assert_allclose(desired[14:], [0.01, 0.01], rtol=1e-9)  # the fingers': their rate
    update = system.EvalUniquePeriodicDiscreteUpdate(ctx).get_vector(0).CopyToVector()
    np.testing.assert_array_equal(update, desired[:8])  # the tick takes the set point there
    # The fingers stop at their travel and their set point's velocity is then zero.
    ctx.SetDiscreteState(0, np.concatenate([MICO_HOME_Q, [0.0599, 0.0]]))
    system.GetInputPort("finger_velocity_command").FixValue(ctx, [0.05, -0.05])
    desired = system.GetOutputPort("desired_state").Eval(ctx)
    np.testing.assert_allclose(desired[6:8], [0.06, 0.0], atol=1e-15)
    np.testing.assert_allclose(desired[14:], [0.01, 0.0], rtol=1e-9)
    # A joint at its limit is held there.
    lower, _ = system.joint_position_limits
    q = np.array(MICO_HOME_Q)
    q[2] = lower[2]
    ctx.SetDiscreteState(0, np.concatenate([q, [0.04, 0.04]]))
    system.GetInputPort("arm_velocity_command").FixValue(ctx, [0, 0, -0.5, 0, 0, 0])
    assert system.GetOutputPort("desired_state").Eval(ctx)[2] == lower[2]


def test_joint_velocity_integrator_re_anchors_reads_bad_commands_as_zero_and_rests(rig: Rig) -> None:
    system, ctx = _integrator(rig)
    system.GetInputPort("finger_velocity_command").FixValue(ctx, [0.0, 0.0])
    system.GetInputPort("arm_velocity_command").FixValue(ctx, np.zeros(6))
    # At rest nothing is written.
    from pydrake.systems.framework import EventStatus

    state = ctx.get_mutable_state()
    status = system._update(ctx, state.get_mutable_discrete_state())
    assert status.severity() == EventStatus.Severity.kDidNothing
    # A measurement more than reseed_tolerance away: the set point re-anchors there (clamped).
    far = np.array(MICO_HOME_Q)
    far[0] += 0.2
    system.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([far, np.zeros(6)]))
    np.testing.assert_array_equal(
        system.EvalUniquePeriodicDiscreteUpdate(ctx).get_vector(0).CopyToVector()[:6], far
    )
    near = np.array(MICO_HOME_Q)
    near[0] += 0.1  # within the tolerance: kept
    system.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([near, np.zeros(6)]))
    system.GetInputPort("arm_velocity_command").FixValue(ctx, [0.1, 0, 0, 0, 0, 0])
    q = system.EvalUniquePeriodicDiscreteUpdate(ctx).get_vector(0).CopyToVector()
    assert q[0] == pytest.approx(MICO_HOME_Q[0] + 0.001, abs=1e-15)
    # A NaN anywhere: a zero command, with a warning and the count.
    system.GetInputPort("finger_velocity_command").FixValue(ctx, [np.nan, 0.0])
    with pytest.warns(RuntimeWarning, match="non-finite arm or finger velocity command"):
        update = system.EvalUniquePeriodicDiscreteUpdate(ctx)
    np.testing.assert_array_equal(
        update.get_vector(0).CopyToVector(), np.concatenate([MICO_HOME_Q, [0.04, 0.04]])
    )
    assert update.get_vector(1).CopyToVector()[0] == 1  # sanitized_input_count
    desired = system.GetOutputPort("desired_state").Eval(ctx)
    assert not desired[8:].any() and np.all(np.isfinite(desired))
    # Initialisation takes the measured joints and fingers, clamped.
    system.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([near, np.zeros(6)]))
    system.GetInputPort("finger_state").FixValue(ctx, [0.07, 0.02, 0.0, 0.0])
    system.ExecuteInitializationEvents(ctx)
    np.testing.assert_array_equal(
        ctx.get_discrete_state(0).CopyToVector(), np.concatenate([near, [0.06, 0.02]])
    )


def test_integrator_state_layouts(rig: Rig) -> None:
    ik_context = rig.controlled.diff_ik.CreateDefaultContext()
    assert np.array_equal(ik_context.get_discrete_state(0).CopyToVector(), MICO_HOME_Q)  # q_d
    assert not ik_context.get_discrete_state(1).CopyToVector().any()  # v
    assert ik_context.get_discrete_state(2).CopyToVector().tolist() == [IkStatus.OK]
    x = rig.station.integrator.CreateDefaultContext().get_discrete_state(0).CopyToVector()
    np.testing.assert_array_equal(x, np.concatenate([MICO_HOME_Q, [MICO_HOME_GRIPPER_OPENING / 2] * 2]))


def test_home_posture_is_the_model_directives() -> None:
    """MICO_HOME_Q and the home opening are the directives' default_joint_positions, as Drake parses them."""
    from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
    from pydrake.multibody.plant import MultibodyPlant

    from drake_disamb.paths import MODELS_PACKAGE, mico_directives, models_dir

    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.package_map().Add(MODELS_PACKAGE, str(models_dir()))
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, parser)
    plant.Finalize()
    q = {n: plant.GetJointByName(n).default_positions()[0] for n in ARM_JOINTS + FINGER_JOINTS}
    assert np.array_equal([q[n] for n in ARM_JOINTS], MICO_HOME_Q)
    assert sum(q[n] for n in FINGER_JOINTS) == pytest.approx(MICO_HOME_GRIPPER_OPENING)
    assert StationConfig().home_q == tuple(MICO_HOME_Q)


def test_end_effector_state_alone() -> None:
    sys = EndEffectorState(1)
    ctx = sys.CreateDefaultContext()
    X = RigidTransform(RotationMatrix.MakeZRotation(0.3), [0.1, 0.2, 0.3])
    sys.GetInputPort("body_poses").FixValue(ctx, [RigidTransform(), X])
    V = SpatialVelocity(w=[0.4, 0.5, 0.6], v=[1.0, 2.0, 3.0])
    sys.GetInputPort("body_spatial_velocities").FixValue(ctx, [SpatialVelocity.Zero(), V])
    pose = sys.GetOutputPort("ee_pose").Eval(ctx)
    assert np.allclose(pose, [0.1, 0.2, 0.3, math.cos(0.15), 0, 0, math.sin(0.15)])
    assert np.allclose(sys.GetOutputPort("ee_velocity").Eval(ctx), [1, 2, 3, 0.4, 0.5, 0.6])


# ----------------------------------------------------------------------------------------------
# Validation.
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"plant_config": default_plant_config(0.0)}, "plant_config.time_step"),
        ({"plant_config": default_plant_config(float("nan"))}, "plant_config.time_step"),
        ({"control_period": 0.0005}, "control_period"),
        (
            {"plant_config": default_plant_config(1e-9), "control_period": 1e-9},
            "plant_config.time_step: expected a finite number in",
        ),
        (
            {"control_period": 0.5},
            r"control_period: expected a finite number in \[0\.001, 0\.1\] s, got 0\.5",
        ),
        ({"home_q": (0.0,) * 5}, "home_q"),
        ({"home_q": (0.0, 1.0, float("nan"), 0, 0, 0)}, "home_q"),
        ({"home_gripper_opening": 0.5}, "home_gripper_opening"),
        ({"joint_velocity_limits": (0.5,) * 5 + (-1.0,)}, "joint_velocity_limits"),
        ({"joint_acceleration_limits": (1.0,) * 3}, "joint_acceleration_limits"),
        ({"kp": (0.0,) * 6}, "kp"),
        ({"finger_kd": -1.0}, "finger_kd"),
        ({"nominal_posture_gain": -0.1}, "nominal_posture_gain"),
        ({"limited_alpha": 1.5}, "limited_alpha"),
        (
            {"plant_config": MultibodyPlantConfig(time_step=0.01, contact_model="magic")},
            "plant_config.contact_model",
        ),
        (
            {"plant_config": MultibodyPlantConfig(time_step=0.01, discrete_contact_approximation="tamsi")},
            "plant_config.discrete_contact_approximation: expected one of sap",
        ),
        ({"scene_objects": ("cup",)}, "scene_objects"),
    ],
)
def test_config_validation(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=f"StationConfig.{field}"):
        StationConfig(**kwargs)


def test_home_outside_limits_is_rejected() -> None:
    with pytest.raises(ValueError, match="home_q"):
        build_station(StationConfig(home_q=(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))  # joint 3 below 109 deg


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"name": "a b", "shape": "box", "size": (1, 1, 1)}, "name"),
        ({"name": "a", "shape": "cone", "size": (1, 1, 1)}, "shape"),
        ({"name": "a", "shape": "box", "size": (1, 1)}, "size"),
        ({"name": "a", "shape": "sphere", "size": (-1,)}, "size"),
        ({"name": "a", "shape": "sphere", "size": (1,), "pose": (0, 0, 0, 0, 0, 0, 0)}, "pose"),
        ({"name": "a", "shape": "sphere", "size": (1,), "rgba": (2, 0, 0, 1)}, "rgba"),
        ({"name": "a", "shape": "sphere", "size": (1,), "welded": False}, "welded"),
        ({"name": "a", "shape": "sphere", "size": (1,), "mass": 0.0}, "mass"),
    ],
)
def test_scene_object_validation(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        SceneObject(**kwargs)


def test_duplicate_object_names() -> None:
    a = SceneObject("a", "sphere", (0.02,), (0.3, -0.3, 0.02, 1, 0, 0, 0))
    with pytest.raises(ValueError, match="duplicate"):
        build_station(scene_objects=(a, a))


def test_scene_object_normalises_quaternion() -> None:
    o = SceneObject("a", "box", (0.1, 0.1, 0.1), (0, 0, 0, 2, 0, 0, 0))
    assert o.pose[3:] == (1.0, 0.0, 0.0, 0.0)


# ----------------------------------------------------------------------------------------------
# The station-demo command.
# ----------------------------------------------------------------------------------------------
def test_station_demo_command(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from drake_disamb.cli import main

    assert main(["station-demo", "--no-meshcat", "--duration", "0.6", "--out", str(tmp_path / "pics")]) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "pics" / "station.dot").read_text().startswith("digraph")
    assert "real-time rate" in out and "final EE displacement" in out
    # 0.6 s of the first leg (+x at 0.05 m/s): about 3 cm along x.
    line = next(ln for ln in out.splitlines() if ln.startswith("final EE displacement"))
    dx = float(line.split("[")[1].split()[0])
    assert dx == pytest.approx(0.03, abs=3e-3)


def test_station_demo_pattern_validation() -> None:
    from drake_disamb.commands.station_demo import pattern

    legs = pattern(0.05)
    assert sum(s.duration for s in legs) == pytest.approx(13.0)
    assert np.allclose(sum(np.asarray(s.velocity) * s.duration for s in legs[:4]), 0.0)  # a closed square
    with pytest.raises(ValueError, match="speed"):
        pattern(float("nan"))
    with pytest.raises(ValueError, match="roll_rate"):
        pattern(0.05, roll_rate=5.0)
