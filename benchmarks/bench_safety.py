"""Motion off the command: the figures behind the station's safety contract.

Usage: ``python benchmarks/bench_safety.py [--duration 10] [--station sim|lcm]``. From five start
postures (home, next to the wrist singularity, the elbow on its limit, the wrist roll on its limit,
a turned posture) it holds each pure single-axis command (translations at +/-0.1 m/s, rotations at
+/-0.2 and +/-0.67 rad/s) on the simulated station and prints, per posture, the worst total motion
outside the commanded direction (cm), the worst speed of that motion (cm/s), the worst rotation
outside it (rad), and how often each IK status appeared. The acceptance limits are 2 cm and 1 cm/s.
``--station lcm`` holds the commands over the LCM path: the station on a ``memq://`` bus with the
simulated driver behind ``lcmt_jaco_status`` / ``lcmt_jaco_command`` (one period of latency).
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

from drake_disamb.safety import CommandHold
from drake_disamb.station import MICO_HOME_Q

LOWER_J3 = 1.902408885
UPPER_J6 = 6.283185307


def postures() -> dict[str, tuple[float, ...]]:
    def posture(**changes: float) -> tuple[float, ...]:
        q = np.array(MICO_HOME_Q)
        for k, v in changes.items():
            q[int(k[1:]) - 1] = v
        return tuple(q.tolist())

    return {
        "home": posture(),
        "near wrist singularity": posture(j5=0.05),
        "elbow on its limit": posture(j3=LOWER_J3 + 1e-3),
        "wrist roll on its limit": posture(j6=UPPER_J6 - 1e-3),
        "turned left": posture(j1=-0.6, j2=1.3, j4=2.0),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=10.0, help="seconds each command is held")
    parser.add_argument("--station", choices=("sim", "lcm"), default="sim", help="the station's backend")
    args = parser.parse_args()
    print(f"station: {args.station}")
    commands = [(a, s) for a in range(3) for s in (0.1, -0.1)]
    commands += [(a, s) for a in range(3, 6) for s in (0.2, -0.2, 0.67, -0.67)]
    print(f"{'posture':26s} {'off cm':>7s} {'off cm/s':>9s} {'off rad':>8s}  statuses")
    worst = np.zeros(3)
    for name, q in postures().items():
        hold = CommandHold(q, on_wire=args.station == "lcm")
        figures = np.zeros(3)
        statuses: Counter[str] = Counter()
        for axis, speed in commands:
            V = np.zeros(6)
            V[axis] = speed
            r = hold.run(V, args.duration)
            figures = np.maximum(figures, [r.off_total * 100, r.off_speed * 100, r.off_rotation])
            statuses.update(s.name for s in r.statuses)
        worst = np.maximum(worst, figures)
        share = ", ".join(f"{k} {v / sum(statuses.values()):.0%}" for k, v in statuses.most_common())
        print(f"{name:26s} {figures[0]:7.2f} {figures[1]:9.2f} {figures[2]:8.3f}  {share}")
    print(f"{'worst':26s} {worst[0]:7.2f} {worst[1]:9.2f} {worst[2]:8.3f}  (limits: 2 cm, 1 cm/s)")


if __name__ == "__main__":
    main()
