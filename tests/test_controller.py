"""The controllers between the shared-control commands and the station (drake_disamb.controller):
each LeafSystem alone with a fixed-input context (its ports and units), and their wiring to a
station of every backend."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import Simulator

from drake_disamb.controller import (
    CONTROLLER_INPUTS,
    DifferentialIKIntegrator,
    GripperController,
    IkStatus,
    build_controlled_station,
)
from drake_disamb.station import MICO_HOME_Q, StationConfig, build_station
from drake_disamb.station.backends import InProcessLcm
from drake_disamb.station.lcm.driver import SimulatedDriver
from drake_disamb.station.ports import SHARED_OUTPUTS


@pytest.fixture(scope="module")
def station():  # noqa: ANN201
    return build_station()


def _ports(system, kind: str) -> dict[str, int]:  # noqa: ANN001
    count = system.num_input_ports() if kind == "input" else system.num_output_ports()
    port = system.get_input_port if kind == "input" else system.get_output_port
    return {port(k).get_name(): port(k).size() for k in range(count)}


def test_diff_ik_alone(station) -> None:  # noqa: ANN001
    """An end-effector twist (m/s, rad/s, paper order) in, joint velocities (rad/s) out."""
    config = StationConfig()
    ik = DifferentialIKIntegrator(station.control_plant, config, geometry=station.geometry)
    assert _ports(ik, "input") == {"ee_velocity_command": 6, "arm_joint_state": 12}
    assert _ports(ik, "output") == {
        "arm_velocity_command": 6,
        "set_point": 6,
        "ik_status": 1,
        "sanitized_input_count": 1,
    }
    ctx = ik.CreateDefaultContext()
    ik.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([MICO_HOME_Q, np.zeros(6)]))
    # Small enough that the first step from rest meets the acceleration limits at full speed.
    ik.GetInputPort("ee_velocity_command").FixValue(ctx, [0.0, 0.0, 0.0, 0.0, 0.0, 0.02])
    update = ik.EvalUniquePeriodicDiscreteUpdate(ctx)
    q1, v1 = update.get_vector(0).CopyToVector(), update.get_vector(1).CopyToVector()
    assert update.get_vector(2).GetAtIndex(0) == IkStatus.OK
    np.testing.assert_array_equal(q1, np.asarray(MICO_HOME_Q) + v1 * config.control_period)
    # The joint velocity produces the commanded spatial velocity (paper order -> Drake order).
    plant = station.control_plant
    plant_ctx = plant.CreateDefaultContext()
    q = plant.GetPositions(plant_ctx)
    q[:6] = MICO_HOME_Q
    plant.SetPositions(plant_ctx, q)
    frame, world = plant.GetFrameByName("mico_end_effector"), plant.world_frame()
    J = plant.CalcJacobianSpatialVelocity(plant_ctx, JacobianWrtVariable.kV, frame, np.zeros(3), world, world)
    assert np.allclose(J[:, :6] @ v1, [0, 0, 0.02, 0, 0, 0], atol=1e-6)  # Drake order [w; v]
    # The output ports are the state: the joint velocities held until the next tick.
    ctx.SetDiscreteState(0, q1)
    ctx.SetDiscreteState(1, v1)
    np.testing.assert_array_equal(ik.GetOutputPort("arm_velocity_command").Eval(ctx), v1)
    np.testing.assert_array_equal(ik.GetOutputPort("set_point").Eval(ctx), q1)
    assert ik.GetOutputPort("ik_status").Eval(ctx)[0] == IkStatus.OK
    # Invalid command: zero velocity, status INVALID_COMMAND, the count.
    ik.GetInputPort("ee_velocity_command").FixValue(ctx, [np.inf, 0, 0, 0, 0, 0])
    with pytest.warns(RuntimeWarning, match="non-finite ee_velocity_command"):
        update = ik.EvalUniquePeriodicDiscreteUpdate(ctx)
    np.testing.assert_array_equal(update.get_vector(0).CopyToVector(), q1)
    assert not update.get_vector(1).CopyToVector().any()
    assert update.get_vector(2).GetAtIndex(0) == IkStatus.INVALID_COMMAND
    with pytest.raises(AssertionError):  # the station refuses it (test_station.py); the IK asserts it
        DifferentialIKIntegrator(
            station.control_plant, StationConfig(home_q=(0.0,) * 6), geometry=station.geometry
        )


def test_gripper_controller_alone() -> None:
    """An opening speed (m/s) in, each finger slide's velocity (m/s, half of it) out, held."""
    gripper = GripperController(StationConfig())
    assert _ports(gripper, "input") == {"gripper_command": 1}
    assert _ports(gripper, "output") == {"finger_velocity_command": 2, "sanitized_input_count": 1}
    ctx = gripper.CreateDefaultContext()
    assert not gripper.GetOutputPort("finger_velocity_command").Eval(ctx).any()
    gripper.GetInputPort("gripper_command").FixValue(ctx, [-0.03])
    simulator = Simulator(gripper, ctx)
    np.testing.assert_array_equal(gripper.GetOutputPort("finger_velocity_command").Eval(ctx), [0, 0])
    simulator.AdvanceTo(0.005)  # the tick at t = 0
    np.testing.assert_array_equal(
        gripper.GetOutputPort("finger_velocity_command").Eval(ctx), [-0.015, -0.015]
    )
    gripper.GetInputPort("gripper_command").FixValue(ctx, [np.nan])
    with pytest.warns(RuntimeWarning, match="non-finite gripper_command"):
        simulator.AdvanceTo(0.015)
    np.testing.assert_array_equal(gripper.GetOutputPort("finger_velocity_command").Eval(ctx), [0, 0])
    assert gripper.GetOutputPort("sanitized_input_count").Eval(ctx)[0] == 1
    slower = GripperController(StationConfig(control_period=0.02))  # the station's period
    assert slower.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == 0.02


@pytest.mark.parametrize("backend", ["sim", "lcm"])
def test_the_controllers_drive_every_backend_through_its_joint_level_inputs(backend: str) -> None:
    """A station of either backend behind its controllers: the Cartesian commands reach the
    station's joint-level inputs (their values are the controllers' outputs), and the arm moves."""
    if backend == "sim":
        station = build_station()
    else:
        station = InProcessLcm(lcm_url="memq://", driver=SimulatedDriver(DrakeLcm("memq://"))).build(
            StationConfig()
        )
    controlled = build_controlled_station(station)
    d = controlled.diagram
    assert _ports(d, "input") == {"ee_velocity_command": 6, "gripper_command": 1}
    assert set(CONTROLLER_INPUTS) == set(_ports(d, "input"))
    assert set(SHARED_OUTPUTS) | {"ik_status"} <= set(_ports(d, "output"))
    simulator = Simulator(d)
    ctx = simulator.get_mutable_context()
    d.GetInputPort("ee_velocity_command").FixValue(ctx, [0.05, 0, 0, 0, 0, 0])
    d.GetInputPort("gripper_command").FixValue(ctx, [0.02])
    simulator.Initialize()
    p0 = d.GetOutputPort("ee_pose").Eval(ctx).copy()
    opening = d.GetOutputPort("gripper_opening").Eval(ctx)[0]
    simulator.AdvanceTo(0.5)
    station_ctx = station.diagram.GetMyContextFromRoot(ctx)
    np.testing.assert_array_equal(
        station.diagram.GetInputPort("arm_velocity_command").Eval(station_ctx),
        controlled.diff_ik.GetOutputPort("arm_velocity_command").Eval(
            controlled.diff_ik.GetMyContextFromRoot(ctx)
        ),
    )
    np.testing.assert_array_equal(
        station.diagram.GetInputPort("finger_velocity_command").Eval(station_ctx), [0.01, 0.01]
    )
    assert d.GetOutputPort("ee_pose").Eval(ctx)[0] > p0[0] + 0.015
    assert d.GetOutputPort("gripper_opening").Eval(ctx)[0] > opening + 0.005
    assert d.GetOutputPort("ik_status").Eval(ctx)[0] == IkStatus.OK
    if station.link is not None:
        station.link.stop_arm()


def test_the_scenarios_joint_speed_limits_reach_the_ik_and_are_bounded_by_the_models() -> None:
    """``joint_velocity_limits`` in a scenario (a first run on a real arm takes a fraction of the
    model's) are the IK's limits, which the station on LCM's sender uses too; a limit above the
    model's or not positive is refused at resolution, naming the field and the joint."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario

    slow = [0.1, 0.1, 0.1, 0.2, 0.2, 0.2]
    handles = build_shared_control_diagram(load_scenario("reaching", {"joint_velocity_limits": slow}))
    np.testing.assert_array_equal(handles.systems["diff_ik"].velocity_limits, slow)
    default = build_shared_control_diagram(load_scenario("reaching")).systems["diff_ik"].velocity_limits
    np.testing.assert_allclose(default, [0.6283185307] * 3 + [0.837758041] * 3)
    for bad, k in (([0.1] * 5 + [2.0], 5), ([0.0] + [0.1] * 5, 0)):
        with pytest.raises(ValueError, match=rf"scenario.joint_velocity_limits\[{k}\]: expected a speed in"):
            load_scenario("reaching", {"joint_velocity_limits": bad})
