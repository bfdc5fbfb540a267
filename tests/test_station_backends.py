"""The station seam: the backend registry, the ports every backend provides, the start pose."""

from __future__ import annotations

import numpy as np
import pytest

from drake_disamb.builder import start_ee_pose
from drake_disamb.station import EE_FRAME, StationConfig
from drake_disamb.station.backends import BACKENDS, InProcessLcm, Sim, make_station
from drake_disamb.station.ports import (
    HARDWARE_OUTPUTS,
    INPUT_SIZES,
    OUTPUT_SIZES,
    SHARED_INPUTS,
    SHARED_OUTPUTS,
    SIMULATION_OUTPUTS,
)


def test_unknown_backend_lists_the_registered_ones() -> None:
    from drake_disamb.config import load_scenario

    with pytest.raises(ValueError, match=r"scenario\.station: unknown tag '!Ros' \(one of !Sim, !Lcm\)"):
        load_scenario("reaching", "station: !Ros {}")
    assert isinstance(load_scenario("reaching").station, Sim) and BACKENDS["sim"] is Sim


def test_the_simulated_station_offers_the_shared_and_the_simulation_ports() -> None:
    station = make_station(None, StationConfig())
    d = station.diagram
    assert set(station.outputs) == set(SHARED_OUTPUTS + SIMULATION_OUTPUTS)
    for name in SHARED_INPUTS:
        assert d.HasInputPort(name)
    for name in SHARED_OUTPUTS + SIMULATION_OUTPUTS:
        assert d.HasOutputPort(name)
        if name in OUTPUT_SIZES:
            assert d.GetOutputPort(name).size() == OUTPUT_SIZES[name]


@pytest.mark.parametrize("backend", ["sim", "lcm"])
def test_every_backends_inputs_are_joint_level(backend: str) -> None:
    """The station is the hardware: whatever the backend, its inputs are exactly the arm's joint
    velocities (6) and the fingers' (2), what lcmt_jaco_command carries, and its outputs the
    shared measured ones (with the same sizes) plus the backend's own."""
    station = make_station(Sim() if backend == "sim" else InProcessLcm(lcm_url="memq://"), StationConfig())
    d = station.diagram
    inputs = {d.get_input_port(k).get_name(): d.get_input_port(k).size() for k in range(d.num_input_ports())}
    assert inputs == INPUT_SIZES == {"arm_velocity_command": 6, "finger_velocity_command": 2}
    own = SIMULATION_OUTPUTS if backend == "sim" else HARDWARE_OUTPUTS
    assert station.outputs == SHARED_OUTPUTS + own
    outputs = {d.get_output_port(k).get_name() for k in range(d.num_output_ports())}
    assert outputs == set(SHARED_OUTPUTS + own)
    for name in SHARED_OUTPUTS:
        assert d.GetOutputPort(name).size() == OUTPUT_SIZES[name]
    if station.link is not None:
        station.link.stop_arm()


def test_start_pose_is_the_stations_ee_pose_output() -> None:
    station = make_station(Sim(), StationConfig())
    plant = station.plant
    X = plant.GetFrameByName(EE_FRAME).CalcPoseInWorld(plant.CreateDefaultContext())
    np.testing.assert_allclose(start_ee_pose(station)[:3], X.translation(), atol=1e-12)
    np.testing.assert_allclose(start_ee_pose(station)[:3], [0.0, -0.35, 0.3], atol=1e-3)
