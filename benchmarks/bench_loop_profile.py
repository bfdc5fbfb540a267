"""Real-time rate of the full shared-control loop, and where its wall time goes, per system.

Usage::

    python benchmarks/bench_loop_profile.py [--task reaching] [--repeats 3] [--no-breakdown]

Runs ``run_trial(load_scenario(task))`` (simulated user, the scenario's interface -- the head array
for ``reaching`` --, no Meshcat) ``--repeats`` times and prints the simulated time, the wall time
and the real-time rate of each run (``simulated s / wall s``; higher is faster; also per CPU
second, which depends less on other processes sharing the machine), then the best and the median.
The diagram is built outside the timed region (``run_trial`` times ``Simulator.Initialize`` +
``AdvanceTo``).

The breakdown (one more run) wraps every Python callback of the project's systems -- output port
calculations, cache entries, update events, time derivatives -- in an exclusive timer (time spent in
a nested evaluation of another system's port is charged to that system) and reports, per system,
the calls per control tick, the microseconds per tick and the share of the wall time. What is left
("Drake C++ and framework") is the MultibodyPlant step, SceneGraph, the C++ primitives (zero-order
hold, loggers, gains, inverse dynamics), event dispatch and the pybind11 crossings. The wrappers
add about a microsecond per call, so that run is a little slower than the plain ones.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import statistics
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

CALLBACK_PREFIXES = (
    "_calc",
    "_update",
    "_initialize",
    "_reset_update",
    "_periodic_update",
    "_check",
    "DoCalc",
)
"""Methods of the project's LeafSystems that Drake calls back (by naming convention)."""


class _ExclusiveTimer:
    """Exclusive wall time per label: a nested timed call's time is charged to its own label."""

    def __init__(self) -> None:
        self.time: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._stack: list[list[float]] = []  # [start, time of timed children]

    def wrap(self, label: Callable[[Any, str], str], func: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(func)
        def timed(system: Any, *args: Any, **kwargs: Any) -> Any:
            frame = [time.perf_counter(), 0.0]
            self._stack.append(frame)
            try:
                return func(system, *args, **kwargs)
            finally:
                elapsed = time.perf_counter() - frame[0]
                self._stack.pop()
                name = label(system, func.__name__)
                self.time[name] += elapsed - frame[1]
                self.calls[name] += 1
                if self._stack:
                    self._stack[-1][1] += elapsed

        return timed


def _project_system_classes() -> list[type]:
    """Every LeafSystem class of the project that the shared-control diagram may contain."""
    from drake_disamb.controller import systems as controller
    from drake_disamb.interfaces import system as interfaces
    from drake_disamb.station import systems as station
    from drake_disamb.systems import autonomy, blending, disambiguation, inference, task
    from drake_disamb.user import system as user

    classes = []
    for module in (
        station,
        controller,
        autonomy,
        blending,
        disambiguation,
        inference,
        interfaces,
        task,
        user,
    ):
        for obj in vars(module).values():
            if (
                isinstance(obj, type)
                and obj.__module__ == module.__name__
                and hasattr(obj, "DeclareVectorOutputPort")
            ):
                classes.append(obj)
    return classes


def _instrument(timer: _ExclusiveTimer, by_method: bool = False) -> Callable[[], None]:
    """Wrap the callbacks of the project's system classes (before any system is built); returns undo.
    Labels are system names, or ``system.method`` with ``by_method``."""
    originals: list[tuple[type, str, Any]] = []

    def label(system: Any, method: str) -> str:
        name = system.get_name() or type(system).__name__
        return f"{name}.{method}" if by_method else name

    for cls in _project_system_classes():
        for name, value in list(vars(cls).items()):
            if callable(value) and name.startswith(CALLBACK_PREFIXES):
                originals.append((cls, name, value))
                setattr(cls, name, timer.wrap(label, value))
            elif name == "_make_copy_calc":  # a factory of per-port closures (the interfaces)
                originals.append((cls, name, value))

                def factory(self: Any, *args: Any, _make: Any = value) -> Any:
                    return functools.partial(timer.wrap(label, lambda s, *a: _make(s, *args)(*a)), self)

                setattr(cls, name, factory)

    def undo() -> None:
        for cls, name, value in originals:
            setattr(cls, name, value)

    return undo


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="reaching", help="scenario name (default: reaching)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs (default: 3)")
    parser.add_argument("--no-breakdown", action="store_true", help="skip the per-system breakdown run")
    parser.add_argument("--by-method", action="store_true", help="break down per callback, not per system")
    args = parser.parse_args()

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    scenario = load_scenario(args.task)
    print(
        f"task {args.task}: interface {scenario.interface}, paradigm {scenario.paradigm}, "
        f"inference {scenario.inference.method}, control period {scenario.control_period} s, "
        f"plant step {scenario.plant_config.time_step} s, "
        f"integrator {scenario.simulator_config.integration_scheme}, no Meshcat"
    )
    # Warm-up (not timed): numba loads its compiled kernels on their first call, about a second.
    run_trial(build_shared_control_diagram(dataclasses.replace(scenario, duration=0.2)), progress=False)
    rates, cpu_rates = [], []
    for k in range(args.repeats):
        handles = build_shared_control_diagram(scenario)
        cpu = time.process_time()
        result = run_trial(handles, progress=False)
        cpu = time.process_time() - cpu
        rates.append(result.realtime_rate)
        cpu_rates.append(result.time / cpu)
        print(
            f"run {k + 1}: success {result.success}, simulated {result.time:.2f} s in "
            f"{result.wall_time:.3f} s wall -> real-time rate {result.realtime_rate:.2f} "
            f"(per CPU second: {cpu_rates[-1]:.2f})"
        )
    print(
        f"real-time rate: best {max(rates):.2f}, median {statistics.median(rates):.2f} "
        f"(per CPU second: median {statistics.median(cpu_rates):.2f}; {args.repeats} runs)"
    )
    if args.no_breakdown:
        return

    timer = _ExclusiveTimer()
    undo = _instrument(timer, args.by_method)
    try:
        handles = build_shared_control_diagram(scenario)
        result = run_trial(handles, progress=False)
    finally:
        undo()
    ticks = result.time / scenario.control_period
    wall = result.wall_time
    python = sum(timer.time.values())
    print(
        f"\nper-system breakdown (instrumented run: rate {result.realtime_rate:.2f}, "
        f"{wall / ticks * 1e6:.0f} us wall per {scenario.control_period * 1e3:.0f} ms tick)"
    )
    print(f"{'system':40s} {'calls/tick':>10s} {'us/tick':>9s} {'share':>7s}")
    rows = sorted(timer.time.items(), key=lambda kv: -kv[1])
    rows.append(("Drake C++ and framework", wall - python))
    for name, seconds in rows:
        calls = f"{timer.calls[name] / ticks:10.2f}" if name in timer.calls else f"{'':10s}"
        print(f"{name:40s} {calls} {seconds / ticks * 1e6:9.1f} {seconds / wall * 100:6.1f}%")
    print(f"callbacks per tick: {sum(timer.calls.values()) / ticks:.1f}")


if __name__ == "__main__":
    main()
