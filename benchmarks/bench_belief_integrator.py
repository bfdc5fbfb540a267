"""Which integrator for the DFT belief: accuracy and cost of Euler, RK2 and RK3 on the published trials.

Usage::

    python benchmarks/bench_belief_integrator.py [--data DIR] [--limit N] [--period 0.01 0.002]
        [--params authors|mico] [--reference-step 1e-4]

The field-theoretic inference system
(:class:`~drake_disamb.systems.inference.FieldTheoreticIntentInference`) holds the belief as
continuous state that Drake's simulator integrates. This script plays each of the authors'
published simulated trials (``../shared/data/tnsre2018_simulated_trajectories`` beside the
repository, docs/facts.md section 3) into that very system, as the live loop would feed it: a small source
system (:class:`TrialPlayback`) holds the command ``u_h`` and the position of the trial's sample at
each control tick, piecewise constant until the next tick (the interface's state and the loop's
zero-order hold of the end-effector pose do the same). Tick ``k`` at ``t = k T`` takes sample
``j = k T / dt`` of the trial (``dt`` = 2 ms): every 5th sample at the 10 ms control period, every
sample at ``T`` = 2 ms (the data's own rate, the authors' setting). The goal positions are constant
(identity orientations); ``u_a`` is zero (the data have no rotation, so the agreement term of the
``mico`` parameters is zero whatever ``u_a``).

Each trial runs once per scheme through :func:`~pydrake.systems.analysis.ApplySimulatorConfig` with
``SimulatorConfig(integration_scheme=scheme, max_step_size=T, use_error_control=False)``, i.e. one
fixed step per tick (the route the scenario's ``simulator_config`` takes):

- ``explicit_euler``, ``runge_kutta2``, ``runge_kutta3`` at ``max_step_size = T``;
- the **reference**: ``runge_kutta3`` with a fixed step of ``--reference-step`` (default 0.1 ms:
  100 steps per 10 ms tick). With the authors' parameters the flow relaxes at up to about
  ``sum(drive)`` ~ 230 /s, so 0.1 ms is ``h S`` ~ 0.02 and RK3's error is far below anything
  reported here: on the first 10 trials, halving it to 0.05 ms changes the reference's belief by
  at most 2e-8 with the authors' parameters and 4e-14 with the ``mico`` ones, at either period
  (``--reference-step 5e-5 --limit 10``, compare).

The belief (the system's ``belief`` output, what its consumers read) is logged at every tick. Per
scheme the script prints, over all ticks of all trials:

- the belief error against the reference: per tick the largest ``|p_i - p_i,ref|`` over the
  goals, then its maximum and mean over all ticks; and the share of ticks whose most probable
  goal differs from the reference's;
- the accuracy (``argmax p`` equals the true goal) with the paper's metric (zeroed stretch counted
  as correct) and the strict one (stretch excluded), averaged over trials as
  ``drake-disamb inference-benchmark`` does (:func:`~drake_disamb.comparison.replay.trial_accuracy`),
  on the tick samples (:func:`tick_trial`);
- whether the raw state left the simplex before the system's per-tick projection put it back: the
  most negative entry and the largest ``|sum(p) - 1|`` at the end of any integrator step;
- the cost: derivative evaluations per tick (the integrator's
  ``get_num_derivative_evaluations()``; each one is a call of the system's
  ``DoCalcTimeDerivatives``) and wall seconds per simulated second (``Initialize`` +
  ``AdvanceTo``, diagram building excluded; a monitor reading the raw state after every step is
  included in every scheme alike).

For comparison it also prints the authors' own discretisation replayed by the numpy core
(:func:`~drake_disamb.comparison.replay.replay_trials`: explicit Euler, clip and renormalise) at the data's
2 ms (with the authors' parameters on all 100 trials: the numbers of docs/results.md's inference table)
and on the tick samples at ``T``.

The machine's state (hypervisor steal, load, speed gauge) is printed with each setting, since the
wall times depend on it.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from _host import HostMeter, host_summary
from numpy.typing import NDArray
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import (
    Context,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from drake_disamb.comparison.replay import authors_dft_params, replay_trials, trial_accuracy
from drake_disamb.comparison.trial_files import load_trials
from drake_disamb.comparison.trials import Trial
from drake_disamb.core.disambiguation import MICO_DFT
from drake_disamb.core.inference import DFTParams
from drake_disamb.systems.inference import FieldTheoreticIntentInference
from drake_disamb.systems.loop import ControlLoop

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2018_simulated_trajectories"
"""Where the published trials are expected: ``../shared/data/...`` beside the repository."""

SCHEMES: tuple[str, ...] = ("explicit_euler", "runge_kutta2", "runge_kutta3")
"""The fixed-step schemes compared, each at one step per control tick."""

REFERENCE = "reference"
"""Key of the reference run in :func:`run_benchmark`'s result."""

PARAMS: dict[str, DFTParams] = {"authors": authors_dft_params(), "mico": MICO_DFT}
"""The DFT parameter sets offered: the authors' comparison and the live ``mico`` preset."""


class TrialPlayback(LeafSystem):
    """Plays a trial's commands and positions as the live loop's inputs, held between ticks.

    Output ports (state outputs, no feedthrough):

    - ``u_h`` (6): ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s; the paper's order), the trial's 3-D
      command of the current tick with zero rotation.
    - ``ee_pose`` (7): ``[x, y, z, qw, qx, qy, qz]`` (m), the trial's position of the current
      tick with the identity orientation.

    Discrete state ``[u_h (6), ee_pose (7)]``, set to tick ``k = round(t / period)`` by a periodic
    discrete update every ``period`` (s) from ``t = 0`` (and tick 0 by default), so that the
    inference integrates over ``[k T, (k + 1) T)`` with tick ``k``'s values. After the last command
    the last one is held.

    Args:
        commands: ``(K, 3)`` commands (m/s), one per tick.
        positions: ``(K + 1, 3)`` positions (m), one per tick sample.
        period: Tick period ``T`` (s).
    """

    def __init__(self, commands: NDArray[np.float64], positions: NDArray[np.float64], period: float) -> None:
        super().__init__()
        commands = np.asarray(commands, dtype=float)
        positions = np.asarray(positions, dtype=float)
        if commands.ndim != 2 or commands.shape[1] != 3 or commands.shape[0] < 1:
            raise ValueError(f"commands: expected shape (K, 3) with K >= 1, got {commands.shape}")
        if positions.shape != (commands.shape[0] + 1, 3):
            raise ValueError(f"positions: expected shape {(commands.shape[0] + 1, 3)}, got {positions.shape}")
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"period: expected a finite positive number (s), got {period!r}")
        k = len(commands)
        self._period = float(period)
        # Row k: the values of tick k (the last command is held at the final sample).
        self._u = np.hstack([np.vstack([commands, commands[-1:]]), np.zeros((k + 1, 3))])
        self._pose = np.hstack([positions, np.tile([1.0, 0.0, 0.0, 0.0], (k + 1, 1))])
        self._u_index = self.DeclareDiscreteState(self._u[0])
        self._pose_index = self.DeclareDiscreteState(self._pose[0])
        self.DeclareStateOutputPort("u_h", self._u_index)
        self.DeclareStateOutputPort("ee_pose", self._pose_index)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        k = min(round(context.get_time() / self._period), len(self._u) - 1)
        discrete_state.get_mutable_vector(self._u_index).SetFromVector(self._u[k])
        discrete_state.get_mutable_vector(self._pose_index).SetFromVector(self._pose[k])
        return EventStatus.Succeeded()


def tick_trial(trial: Trial, period: float) -> Trial:
    """The samples of ``trial`` that a loop ticking every ``period`` sees: every ``s``-th one.

    ``s = period / trial.dt`` must be a whole number. Tick ``k`` is sample ``k s`` (position,
    command, true goal); the trial is cut to ``K = L // s`` commands and ``K + 1`` samples, its
    ``dt`` is ``period``, and the zeroed stretch keeps the ticks inside it (sample ``k s`` in
    ``[zeroed_start, zeroed_stop)``). With ``s = 1`` this is the trial itself.
    """
    stride = round(period / trial.dt)
    if stride < 1 or abs(stride * trial.dt - period) > 1e-9 * period:
        raise ValueError(
            f"period: expected a whole multiple of the trial's dt = {trial.dt} s, got {period!r}"
        )
    ticks = trial.n_steps // stride
    if ticks < 1:
        raise ValueError(
            f"period: {period} s is longer than the trial {trial.source!r} ({trial.n_steps} samples)"
        )
    idx = np.arange(ticks + 1) * stride
    return replace(
        trial,
        dt=float(period),
        traj=trial.traj[idx],
        u_h=trial.u_h[idx[:-1]],
        true_goal=trial.true_goal[idx],
        zeroed_start=min(-(-trial.zeroed_start // stride), ticks + 1),
        zeroed_stop=min(-(-trial.zeroed_stop // stride), ticks + 1),
        traj_raw=None,
        u_h_raw=None,
        source=f"{trial.source} every {stride} samples",
    )


@dataclass
class SchemeRun:
    """What one integration scheme produced over a list of trials (ticks of all trials summed).

    Attributes:
        beliefs: Per trial, the ``belief`` output at every tick, ``(K + 1, n)``.
        derivative_evaluations: Calls of the system's ``DoCalcTimeDerivatives`` (integrator count).
        steps: Integrator steps taken.
        ticks: Control ticks simulated.
        simulated: Simulated time (s).
        wall: Wall time of ``Initialize`` + ``AdvanceTo`` (s).
        min_entry: Smallest entry of the raw continuous state at the end of any step.
        max_sum_error: Largest ``|sum(p) - 1|`` of the raw state at the end of any step.
    """

    beliefs: list[NDArray[np.float64]] = field(default_factory=list)
    derivative_evaluations: int = 0
    steps: int = 0
    ticks: int = 0
    simulated: float = 0.0
    wall: float = 0.0
    min_entry: float = math.inf
    max_sum_error: float = 0.0


@dataclass
class BenchmarkResult:
    """:func:`run_benchmark`'s result: the tick samples of each trial and a run per scheme."""

    period: float
    reference_step: float
    tick_trials: list[Trial]
    runs: dict[str, SchemeRun]


def _trial_params(params: DFTParams, trial: Trial) -> DFTParams:
    """``params`` with the trial's own goal-transition matrix (as the authors' replay does)."""
    return replace(params, transition=trial.transition)


def build_playback(trial: Trial, params: DFTParams):  # noqa: ANN201 (Diagram, inference, logger)
    """The diagram ``TrialPlayback -> FieldTheoreticIntentInference -> belief logger`` for a tick trial.

    ``trial`` is a :func:`tick_trial` (its ``dt`` is the control period). Goal poses: the trial's
    goal positions with identity orientations (a constant source); ``u_a``: zero.
    """
    period, n = trial.dt, trial.n_goals
    builder = DiagramBuilder()
    playback = builder.AddSystem(TrialPlayback(trial.u_h, trial.traj, period))
    inference = builder.AddSystem(
        FieldTheoreticIntentInference(ControlLoop(n, period), _trial_params(params, trial))
    )
    goal_poses = np.hstack([trial.goals, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))]).reshape(-1)
    goals = builder.AddSystem(ConstantVectorSource(goal_poses))
    u_a = builder.AddSystem(ConstantVectorSource(np.zeros(6 * n)))
    builder.Connect(playback.GetOutputPort("u_h"), inference.GetInputPort("u_h"))
    builder.Connect(playback.GetOutputPort("ee_pose"), inference.GetInputPort("ee_pose"))
    builder.Connect(goals.get_output_port(), inference.GetInputPort("goal_poses"))
    builder.Connect(u_a.get_output_port(), inference.GetInputPort("u_a"))
    logger = LogVectorOutput(inference.GetOutputPort("belief"), builder, period)
    return builder.Build(), inference, logger


def simulate(trial: Trial, diagram, inference, logger, scheme: str, max_step: float, run: SchemeRun) -> None:  # noqa: ANN001
    """Integrate one tick trial with ``scheme`` at fixed step ``max_step``; add the outcome to ``run``."""
    period, ticks = trial.dt, trial.n_steps
    simulator = Simulator(diagram)
    config = SimulatorConfig(integration_scheme=scheme, max_step_size=max_step, use_error_control=False)
    ApplySimulatorConfig(config, simulator)
    root = simulator.get_mutable_context()
    state = inference.GetMyContextFromRoot(root).get_continuous_state_vector()
    extremes = [math.inf, 0.0]

    def monitor(_: Context) -> EventStatus:
        p = state.CopyToVector()
        extremes[0] = min(extremes[0], float(p.min()))
        extremes[1] = max(extremes[1], abs(math.fsum(p) - 1.0))
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    start = time.perf_counter()
    simulator.Initialize()
    simulator.AdvanceTo(ticks * period)
    run.wall += time.perf_counter() - start

    log = logger.FindLog(simulator.get_context())
    k = np.round(log.sample_times() / period).astype(int)
    beliefs = np.full((ticks + 1, trial.n_goals), np.nan)
    beliefs[k] = log.data().T  # a tick logged twice (initialization and t = 0) holds the same value
    if np.isnan(beliefs).any():
        raise RuntimeError(
            f"{trial.source}: the logger missed ticks {np.nonzero(np.isnan(beliefs[:, 0]))[0]}"
        )
    integrator = simulator.get_integrator()
    run.beliefs.append(beliefs)
    run.derivative_evaluations += integrator.get_num_derivative_evaluations()
    run.steps += integrator.get_num_steps_taken()
    run.ticks += ticks
    run.simulated += ticks * period
    run.min_entry = min(run.min_entry, extremes[0])
    run.max_sum_error = max(run.max_sum_error, extremes[1])


def run_benchmark(
    trials: Sequence[Trial],
    params: DFTParams,
    period: float,
    schemes: Sequence[str] = SCHEMES,
    reference_step: float = 1e-4,
    progress: bool = False,
) -> BenchmarkResult:
    """Play every trial at ``period`` into the DFT system once per scheme and once for the reference.

    ``params`` get each trial's transition matrix. The schemes take one fixed step per tick
    (``max_step_size = period``); the reference is ``runge_kutta3`` at a fixed ``reference_step``.
    """
    from tqdm import tqdm

    if not (reference_step > 0 and reference_step <= period):
        raise ValueError(
            f"reference_step: expected a step in (0, period = {period}] s, got {reference_step!r}"
        )
    runs = {name: SchemeRun() for name in (*schemes, REFERENCE)}
    ticked = [tick_trial(tr, period) for tr in trials]
    # Warm-up, not counted: the first run of each scheme pays for numba's and Drake's first calls.
    diagram, inference, logger = build_playback(ticked[0], params)
    for scheme in schemes:
        simulate(ticked[0], diagram, inference, logger, scheme, period, SchemeRun())
    for trial in tqdm(ticked, desc=f"T = {period * 1e3:g} ms", unit="trial", disable=not progress):
        diagram, inference, logger = build_playback(trial, params)
        for scheme in schemes:
            simulate(trial, diagram, inference, logger, scheme, period, runs[scheme])
        simulate(trial, diagram, inference, logger, "runge_kutta3", reference_step, runs[REFERENCE])
    return BenchmarkResult(period=period, reference_step=reference_step, tick_trials=ticked, runs=runs)


def accuracy(beliefs: Sequence[NDArray[np.float64]], trials: Sequence[Trial]) -> tuple[float, float]:
    """``(paper's metric, strict metric)`` averaged over trials, as ``inference-benchmark`` reports."""
    scores = np.array([trial_accuracy(b, tr) for b, tr in zip(beliefs, trials, strict=True)])
    return float(scores[:, 0].mean()), float(np.nanmean(scores[:, 1]))


@dataclass
class Summary:
    """One row of the table (errors against the reference; accuracies as fractions)."""

    max_error: float
    mean_error: float
    argmax_differs: float
    published: float
    strict: float
    evaluations_per_tick: float
    steps_per_tick: float
    wall_per_second: float
    min_entry: float
    max_sum_error: float


def summarize(result: BenchmarkResult) -> dict[str, Summary]:
    """Per run: the belief error against the reference over all ticks, the accuracies and the cost."""
    ref = result.runs[REFERENCE].beliefs
    out = {}
    for name, run in result.runs.items():
        err = np.concatenate([np.abs(b - r).max(axis=1) for b, r in zip(run.beliefs, ref, strict=True)])
        differs = np.concatenate(
            [b.argmax(axis=1) != r.argmax(axis=1) for b, r in zip(run.beliefs, ref, strict=True)]
        )
        published, strict = accuracy(run.beliefs, result.tick_trials)
        out[name] = Summary(
            max_error=float(err.max()),
            mean_error=float(err.mean()),
            argmax_differs=float(differs.mean()),
            published=published,
            strict=strict,
            evaluations_per_tick=run.derivative_evaluations / run.ticks,
            steps_per_tick=run.steps / run.ticks,
            wall_per_second=run.wall / run.simulated,
            min_entry=run.min_entry,
            max_sum_error=run.max_sum_error,
        )
    return out


def core_replay_accuracy(trials: Sequence[Trial], params: DFTParams) -> tuple[float, float]:
    """The authors' discretisation (explicit Euler at each trial's ``dt``, clip, renormalise) by the core.

    The agreement term is switched off for the replay (it needs ``u_a``); the data's commands have
    no rotation, so it is zero anyway.
    """
    beliefs = replay_trials(trials, replace(params, agreement=False), methods=("dft",))["dft"]
    return accuracy(beliefs, trials)


def _print_setting(
    result: BenchmarkResult, table: dict[str, Summary], replay: tuple[float, float], host: str
) -> None:
    period, trials = result.period, result.tick_trials
    ticks = result.runs[REFERENCE].ticks
    print(
        f"\ncontrol period T = {period * 1e3:g} ms: {len(trials)} trials, {ticks} ticks, "
        f"{result.runs[REFERENCE].simulated:.2f} s simulated; {host}"
    )
    head = (
        f"{'scheme':<24}{'max |dp|':>10}{'mean |dp|':>11}{'argmax!=ref':>12}{'paper':>9}{'strict':>9}"
        f"{'min p':>11}{'max|sum-1|':>11}{'evals/tick':>11}{'steps/tick':>11}{'wall s/sim s':>13}"
    )
    print(head)
    print("-" * len(head))
    ref_label = f"reference (rk3 {result.reference_step * 1e3:g} ms)"
    for name, s in table.items():
        label = ref_label if name == REFERENCE else name
        print(
            f"{label:<24}{s.max_error:>10.2e}{s.mean_error:>11.2e}{100 * s.argmax_differs:>11.3f}%"
            f"{100 * s.published:>8.2f}%{100 * s.strict:>8.2f}%{s.min_entry:>11.2e}{s.max_sum_error:>11.1e}"
            f"{s.evaluations_per_tick:>11.2f}{s.steps_per_tick:>11.2f}{s.wall_per_second:>13.4f}"
        )
    print(
        f"{'core replay':<24}authors' Euler + clip/renormalise at T on the same tick samples: "
        f"paper {100 * replay[0]:.2f} %, strict {100 * replay[1]:.2f} %"
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--data", type=Path, default=DATA, help="folder of the authors' trajectory_N.mat files"
    )
    parser.add_argument("--limit", type=int, default=None, help="only the first N trials (default all)")
    parser.add_argument(
        "--period", type=float, nargs="+", default=[0.01, 0.002], help="control periods T (s) to compare"
    )
    parser.add_argument(
        "--params",
        choices=sorted(PARAMS),
        default="authors",
        help="DFT parameter set: the authors' comparison (lambda = 200) or the live mico preset",
    )
    parser.add_argument(
        "--reference-step", type=float, default=1e-4, help="fixed step (s) of the RK3 reference"
    )
    parser.add_argument("--progress", action="store_true", help="show a progress bar per setting")
    args = parser.parse_args(argv)
    if not args.data.is_dir():
        print(
            f"bench_belief_integrator: the published trials are not at {args.data} (expected the "
            "shared data folder beside the repository, or pass --data DIR)",
            file=sys.stderr,
        )
        return 2
    if args.limit is not None and args.limit < 1:
        parser.error(f"--limit: expected a positive number of trials, got {args.limit}")
    trials = load_trials(args.data, limit=args.limit)
    params = PARAMS[args.params]
    print(
        f"DFT belief integrators on {len(trials)} published trials ({args.data}), {args.params} DFT "
        f"parameters ({params.tau1=}, {params.tau2=}, lam={params.lam}); {host_summary()}"
    )
    full = core_replay_accuracy(trials, params)
    readme = "; docs/results.md's inference table" if args.params == "authors" and args.limit is None else ""
    print(
        f"core replay at the data's dt = {trials[0].dt * 1e3:g} ms (authors' Euler + clip/renormalise"
        f"{readme}): paper {100 * full[0]:.2f} %, strict {100 * full[1]:.2f} %"
    )
    for period in args.period:
        with HostMeter() as host:
            result = run_benchmark(
                trials, params, period, reference_step=args.reference_step, progress=args.progress
            )
        replay = core_replay_accuracy(result.tick_trials, params)
        _print_setting(result, summarize(result), replay, host.describe())
    return 0


if __name__ == "__main__":
    sys.exit(main())
