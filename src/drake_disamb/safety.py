"""How far the station's end effector strays from a held command: the measurement behind the
safety contract of :mod:`drake_disamb.ik` (motion only along the commanded twist).

:class:`CommandHold` builds a station at a start posture behind its controllers (the differential
IK and the gripper's, :func:`~drake_disamb.controller.build_controlled_station`), holds one
end-effector velocity command for a while and measures, at every control step, the end effector's
motion outside the commanded direction: for the translation, the displacement minus its
(non-negative) part along the command's linear velocity (all of it for a pure rotation command);
for the orientation, likewise about the command's angular velocity. ``tests/test_station_safety.py``
asserts the limits on it and ``benchmarks/bench_safety.py`` prints the figures, on the simulated
station or over the LCM path (the station on a ``memq://`` bus with the simulated driver behind the
messages).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix
from pydrake.systems.analysis import Simulator

from drake_disamb.controller import ControlledStation, IkStatus, build_controlled_station
from drake_disamb.station import Station, StationConfig, build_station

__all__ = ["CommandHold", "HoldResult"]


@dataclass
class HoldResult:
    """What one held command did (SI units).

    Attributes:
        off_total: Path length (m) of the end effector's motion outside the commanded direction.
        off_speed: Largest speed (m/s) of that motion over one control step.
        off_rotation: Total rotation (rad) outside the commanded angular direction.
        progress: Motion along the command: metres along its linear part, or radians about its
            angular part for a pure rotation.
        progress_1s: The same after the first second.
        displacement: Straight-line distance (m) from the start to the end position.
        statuses: The IK's ``ik_status`` at every control step.
    """

    off_total: float = 0.0
    off_speed: float = 0.0
    off_rotation: float = 0.0
    progress: float = 0.0
    progress_1s: float = 0.0
    displacement: float = 0.0
    statuses: list[IkStatus] = field(default_factory=list)


def _rotation(p: NDArray[np.float64]) -> RotationMatrix:
    return RotationMatrix(Quaternion(p[3:] / np.linalg.norm(p[3:])))


class CommandHold:
    """A station at ``home_q`` (other settings from ``config``) behind its controllers, reset
    before every :meth:`run`: ``station`` is the station, ``controlled`` the
    :class:`~drake_disamb.controller.ControlledStation` whose diagram ``sim`` simulates.

    Args:
        home_q: Start joint angles (rad, DH).
        config: Station settings (``home_q`` is replaced); defaults when ``None``.
        step: Sampling period (s) of the measurement; the station's control period by default.
        on_wire: Hold the command over the LCM path instead: the station on a ``memq://`` bus with
            the simulated driver (started at ``home_q``) behind the messages, both rebuilt for
            every run (the driver's arm cannot be reset from the controller's side).
    """

    def __init__(
        self,
        home_q: tuple[float, ...],
        config: StationConfig | None = None,
        step: float | None = None,
        on_wire: bool = False,
    ) -> None:
        import dataclasses  # noqa: PLC0415

        self.config = dataclasses.replace(config or StationConfig(), home_q=tuple(home_q))
        self.step = float(step or self.config.control_period)
        self.on_wire = on_wire
        self._build()

    def _build(self) -> None:
        if self.on_wire:
            from drake_disamb.station.backends import InProcessLcm  # noqa: PLC0415

            self.station: Station = InProcessLcm(lcm_url="memq://").build(self.config)
        else:
            self.station = build_station(self.config)
        self.controlled: ControlledStation = build_controlled_station(self.station)
        self.sim = Simulator(self.controlled.diagram)
        self.ctx = self.sim.get_mutable_context()
        self.controlled.diagram.GetInputPort("gripper_command").FixValue(self.ctx, [0.0])
        self.controlled.diagram.GetInputPort("ee_velocity_command").FixValue(self.ctx, np.zeros(6))
        self.sim.Initialize()
        self._start = self.ctx.Clone()

    def run(self, V: NDArray[np.float64], duration: float) -> HoldResult:
        """Hold the paper-order command ``V`` (m/s, rad/s, world frame) for ``duration`` seconds."""
        if self.on_wire:
            self._build()
        else:
            self.ctx.SetTimeStateAndParametersFrom(self._start)
            self.sim.Initialize()
        V = np.asarray(V, dtype=float)
        self.controlled.diagram.GetInputPort("ee_velocity_command").FixValue(self.ctx, V)
        pose = self.controlled.diagram.GetOutputPort("ee_pose")
        status = self.controlled.diagram.GetOutputPort("ik_status")
        scale = float(np.max(np.abs(V))) or 1.0
        v, w = V[:3] / scale, V[3:] / scale  # directions only: no overflow for a huge command
        e_v = v / np.linalg.norm(v) if v.any() else np.zeros(3)
        e_w = w / np.linalg.norm(w) if w.any() else np.zeros(3)
        p_prev = np.array(pose.Eval(self.ctx))
        p0 = p_prev.copy()
        r = HoldResult()
        t0 = self.ctx.get_time()
        first_second = int(round(1.0 / self.step))
        for k in range(int(round(duration / self.step))):
            self.sim.AdvanceTo(t0 + (k + 1) * self.step)
            p = np.array(pose.Eval(self.ctx))
            dp = p[:3] - p_prev[:3]
            along = max(0.0, float(dp @ e_v))
            off = float(np.linalg.norm(dp - along * e_v))
            aa = _rotation(p).multiply(_rotation(p_prev).inverse()).ToAngleAxis()
            dth = aa.axis() * aa.angle()
            turn = max(0.0, float(dth @ e_w))
            r.off_total += off
            r.off_speed = max(r.off_speed, off / self.step)
            r.off_rotation += float(np.linalg.norm(dth - turn * e_w))
            r.progress += along if v.any() else turn
            if k < first_second:
                r.progress_1s = r.progress
            r.statuses.append(IkStatus(int(status.Eval(self.ctx)[0])))
            p_prev = p
        r.displacement = float(np.linalg.norm(p_prev[:3] - p0[:3]))
        return r
