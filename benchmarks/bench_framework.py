"""Drake's own cost of a Python LeafSystem per 100 Hz tick, with nothing to compute.

Usage: ``python benchmarks/bench_framework.py [--seconds 20] [--pairs 1 5 10]``

Builds diagrams of N pairs of trivial Python systems -- a source whose output port returns six
zeros, feeding a system that adds its input to a 6-vector discrete state every 10 ms (one output
calculation and one periodic discrete update per tick, each crossing from C++ to Python) -- and
prints the wall time per tick and per pair. This is the floor under every Python LeafSystem of the
shared-control loop; what a real system costs beyond it is its own numpy work.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _host import HostMeter
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, Context, DiagramBuilder, DiscreteValues, LeafSystem

PERIOD = 0.01


class _Source(LeafSystem):
    def __init__(self) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("y", 6, self._calc)

    def _calc(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(np.zeros(6))


class _Accumulator(LeafSystem):
    def __init__(self) -> None:
        super().__init__()
        self._u = self.DeclareVectorInputPort("u", 6)
        self._x = self.DeclareDiscreteState(6)
        self.DeclarePeriodicDiscreteUpdateEvent(PERIOD, 0.0, self._update)
        self.DeclareStateOutputPort("x", self._x)

    def _update(self, context: Context, state: DiscreteValues) -> None:
        state.set_value(context.get_discrete_state(0).get_value() + self._u.Eval(context))


def measure(pairs: int, seconds: float) -> float:
    """Wall seconds per tick of ``pairs`` source/accumulator pairs over ``seconds`` simulated."""
    builder = DiagramBuilder()
    for _ in range(pairs):
        source = builder.AddSystem(_Source())
        accumulator = builder.AddSystem(_Accumulator())
        builder.Connect(source.get_output_port(), accumulator.get_input_port())
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    start = time.perf_counter()
    simulator.AdvanceTo(seconds)
    return (time.perf_counter() - start) / (seconds / PERIOD)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per diagram")
    parser.add_argument("--pairs", type=int, nargs="+", default=[1, 5, 10], help="pairs per diagram")
    args = parser.parse_args()
    print("pairs   us per tick   us per pair (1 output calc + 1 discrete update)")
    for n in args.pairs:
        with HostMeter() as host:
            per_tick = measure(n, args.seconds) * 1e6
        print(f"{n:5d} {per_tick:13.1f} {per_tick / n:13.1f}   ({host.describe()})")


if __name__ == "__main__":
    main()
