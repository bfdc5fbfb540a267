"""The station seam: the backend registry, the ports every backend provides, the start pose."""

from __future__ import annotations

import numpy as np
import pytest

from drake_disamb.builder import start_ee_pose
from drake_disamb.station import EE_FRAME, StationConfig
from drake_disamb.station.backends import BACKENDS, Sim, make_station
from drake_disamb.station.ports import OUTPUT_SIZES, SHARED_INPUTS, SHARED_OUTPUTS, SIMULATION_OUTPUTS


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


def test_start_pose_is_the_stations_ee_pose_output() -> None:
    station = make_station(Sim(), StationConfig())
    plant = station.plant
    X = plant.GetFrameByName(EE_FRAME).CalcPoseInWorld(plant.CreateDefaultContext())
    np.testing.assert_allclose(start_ee_pose(station)[:3], X.translation(), atol=1e-12)
    np.testing.assert_allclose(start_ee_pose(station)[:3], [0.0, -0.35, 0.3], atol=1e-3)
