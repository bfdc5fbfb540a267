"""The paper's inference comparison: trials replayed through the three inference methods, and scored.

Paper Section "Field-Theoretic Intent Inference For Assistive Robotics"; the metric is in
docs/facts.md section 3. The trials (:class:`~drake_disamb.comparison.trials.Trial`) come from
:mod:`drake_disamb.comparison.trial_files` or :mod:`drake_disamb.comparison.trials`' generator.

- :func:`replay_trials` runs all three methods of :mod:`drake_disamb.core.inference` over any
  number of trials in one vectorised numpy pass per goal count (trials padded in time), with the
  authors' discretisation.
- :func:`score_trials` computes the paper's metric (zeroed stretch counted as correct through a
  sentinel) and the strict metric (zeroed stretch excluded).
- :func:`score_trial_stream` replays and scores a stream of chunks (generate or load, replay,
  score, drop), so memory stays flat in the number of trials; the scores are identical to
  :func:`score_trials` on :func:`replay_trials` of all of them at once.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from drake_disamb.comparison.trials import Trial
from drake_disamb.core.inference import INFERENCE_METHODS, DFTParams, RecordedSamples, path_cost_increment

METHODS: tuple[str, ...] = INFERENCE_METHODS.names()
"""The three inference methods of the comparison (the registry's), in the order the paper lists them."""

METHOD_LABELS: dict[str, str] = {method.name: method.label for method in INFERENCE_METHODS.variants()}
"""What people read for each method (the variants' labels)."""

PUBLISHED_ACCURACY: dict[str, float] = {"dft": 0.8746, "bayes": 0.8743, "memory": 0.5915}
"""The paper's accuracies on its 500 simulated trials (paper Section "Field-Theoretic Intent Inference For
Assistive Robotics")."""


def authors_dft_params(**overrides: object) -> DFTParams:
    """The DFT parameters of the authors' simulation comparison (docs/facts.md section 1).

    tau1 = tau2 = 10 s, lambda = 200 I, directedness term only; the goal-transition matrix is
    taken per trial from the data (see :func:`replay_trials`).
    """
    base = {"tau1": 10.0, "tau2": 10.0, "lam": 200.0, "directedness": True, "agreement": False}
    base.update(overrides)
    base.setdefault("proximity", False)
    return DFTParams(**base)  # type: ignore[arg-type]


def replay_trials(
    trials: Sequence[Trial],
    params: DFTParams | None = None,
    methods: Iterable[str] = METHODS,
    progress: bool = False,
) -> dict[str, list[NDArray[np.float64]]]:
    """Run the inference methods over ``trials`` with the authors' replay conventions.

    Per trial the belief starts uniform and update ``j`` (``j = 0 .. L-1``) uses the command
    ``u_h[j]`` and the position ``traj[j]`` (the memory-based method also the move to
    ``traj[j + 1]``), giving ``L + 1`` beliefs. DFT: explicit Euler at the trial's ``dt``, clip and
    renormalise (:func:`~drake_disamb.core.inference.dft_euler_update`) with ``params`` (default
    :func:`authors_dft_params`) whose transition matrix is replaced by each trial's ``P``. Bayes
    and memory: :func:`~drake_disamb.core.inference.posterior_update` with the trial's ``P``.

    All trials run in one numpy pass over time. The belief-independent parts (DFT drive,
    likelihoods) are computed for every sample of every trial up front; the recursion then loops
    over time on a batch of all trials, sorted longest first so that the trials still running at
    step ``t`` are a prefix of the batch ("packed" sequences: no work on padding). Trials with
    fewer goals are padded with dummy goals whose likelihood is 0 and drive ``-inf``: the core's
    projection pins them at :data:`~drake_disamb.core.inference.TINY`, far below one ulp of the
    real entries, so they change nothing. Returns ``{method: [beliefs (L+1, n) per trial]}``.
    """
    from tqdm import tqdm

    methods = tuple(methods)
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"methods: unknown method {m!r}, expected some of {METHODS}")
    if len(trials) == 0:
        raise ValueError("trials: nothing to replay (empty list)")
    params = authors_dft_params() if params is None else params
    # Each method as the registry has it, the DFT with ``params`` (every trial's P replaces theirs).
    variants = {m: INFERENCE_METHODS.get(m).from_settings(replace(params, transition=None)) for m in methods}

    lengths = np.array([tr.n_steps for tr in trials])
    n_goals = np.array([tr.n_goals for tr in trials])
    order = np.argsort(-lengths, kind="stable")  # batch slot k holds trial order[k]
    B, T, nmax = len(trials), int(lengths.max()), int(n_goals.max())
    L_sorted = lengths[order]
    active = np.searchsorted(-L_sorted, -np.arange(T), side="right")  # trials running at step t
    offsets = np.concatenate([[0], np.cumsum(active)])  # packed row of (step t, slot k): offsets[t] + k

    # Flat, trial-major samples (every update of every trial) and their packed rows.
    slot_of_trial = np.empty(B, dtype=np.int64)
    slot_of_trial[order] = np.arange(B)
    step = np.concatenate([np.arange(L) for L in lengths])
    trial_id = np.repeat(np.arange(B), lengths)
    rows = offsets[step] + slot_of_trial[trial_id]
    x_cur = np.concatenate([tr.traj[:-1] for tr in trials])
    x_next = np.concatenate([tr.traj[1:] for tr in trials])
    u_h = np.concatenate([tr.u_h for tr in trials])
    starts = np.cumsum(lengths) - lengths

    # Packed arrays are stored goal-major, (n, rows): the per-step slices are then (b, n) views
    # whose goal axis is strided, which makes numpy's reductions over it several times faster.
    packed: dict[str, NDArray[np.float64]] = {}
    for m, variant in variants.items():
        packed[m] = np.full((nmax, offsets[-1]), variant.replay_padding)
    # Running path cost, summed per trial in time order (as the authors' loop does).
    moves = path_cost_increment(x_cur, x_next)
    cost = np.concatenate([np.cumsum(moves[s : s + L]) for s, L in zip(starts, lengths, strict=True)])
    x0 = np.repeat(np.stack([tr.traj[0] for tr in trials]), lengths, axis=0)
    for n in np.unique(n_goals):
        sel = np.repeat(n_goals == n, lengths)
        G = np.concatenate(
            [np.broadcast_to(tr.goals, (tr.n_steps, n, 3)) for tr in trials if tr.n_goals == n]
        )
        samples = RecordedSamples(u_h=u_h[sel], x_cur=x_cur[sel], x_start=x0[sel], path_cost=cost[sel])
        for m, variant in variants.items():
            packed[m][:n, rows[sel]] = variant.recorded_evidence(samples, G).T

    # Padded per-slot constants: transition matrices (a dummy goal only maps to itself) and steps.
    P = np.zeros((nmax, nmax, B)).transpose(2, 0, 1)  # (B, n, n) view, batch axis fastest
    for k, i in enumerate(order):
        n = n_goals[i]
        P[k, :n, :n] = trials[i].transition
        P[k, range(n, nmax), range(n, nmax)] = 1.0
    dt = np.array([[trials[i].dt] for i in order])
    belief0 = np.zeros((B, nmax))
    for k, i in enumerate(order):
        belief0[k, : n_goals[i]] = 1.0 / n_goals[i]

    # hist[m][:, offsets[t] + k] is the belief of slot k after update t; the belief entering
    # update t of the b trials still running is the first b columns of the previous block.
    hist = {m: np.empty((nmax, offsets[-1])) for m in methods}
    start = np.ascontiguousarray(belief0.T)  # (n, B)
    steps = {m: variant.replayer(P, dt) for m, variant in variants.items()}
    with tqdm(total=T, desc="replaying", unit="step", disable=not progress, mininterval=0.5) as bar:
        for t in range(T):
            b, lo, hi = int(active[t]), int(offsets[t]), int(offsets[t + 1])
            prev_lo = int(offsets[t - 1]) if t else 0
            for m in methods:
                p = (hist[m][:, prev_lo : prev_lo + b] if t else start[:, :b]).T
                hist[m][:, lo:hi] = steps[m](p, packed[m][:, lo:hi].T).T
            if t % 256 == 255:
                bar.update(256)
        bar.update(T % 256)

    # Trial-major output: trial i owns rows first[i] .. first[i] + L_i (its L_i + 1 beliefs).
    first = np.concatenate([[0], np.cumsum(lengths + 1)])[:-1]
    sample_rows = np.repeat(first + 1, lengths) + step
    out: dict[str, list[NDArray[np.float64]]] = {}
    for m in methods:
        full = np.empty((int(lengths.sum()) + B, nmax))
        full[first] = belief0[slot_of_trial]
        full[sample_rows] = hist[m][:, rows].T
        out[m] = [full[first[i] : first[i] + lengths[i] + 1, : n_goals[i]] for i in range(B)]
    return out


def trial_accuracy(belief: NDArray[np.float64], trial: Trial) -> tuple[float, float]:
    """``(published, strict)`` accuracy of one trial's beliefs ``(L + 1, n)``.

    The prediction is ``argmax p`` (first index on ties, as MATLAB's ``max``). Published metric
    (the authors'): fraction of all ``L + 1`` samples where prediction equals truth, with both
    replaced by a sentinel inside the zeroed stretch (so the stretch counts as correct). Strict
    metric: the same fraction over the samples outside the stretch only (NaN if there are none).
    """
    belief = np.asarray(belief)
    if belief.shape != (trial.n_steps + 1, trial.n_goals):
        raise ValueError(
            f"belief: expected shape {(trial.n_steps + 1, trial.n_goals)} for {trial.source or 'the trial'}, "
            f"got {belief.shape}"
        )
    correct = np.argmax(belief, axis=-1) == trial.true_goal
    zeroed = trial.zeroed_mask()
    published = float(np.mean(correct | zeroed))
    strict = float(np.mean(correct[~zeroed])) if np.any(~zeroed) else float("nan")
    return published, strict


def score_trials(
    trials: Sequence[Trial], beliefs: dict[str, list[NDArray[np.float64]]]
) -> dict[str, dict[str, NDArray[np.float64]]]:
    """Per-trial accuracies: ``{method: {"published": (N,), "strict": (N,)}}`` (fractions)."""
    scores = {}
    for m, per_trial in beliefs.items():
        if len(per_trial) != len(trials):
            raise ValueError(f"beliefs[{m!r}]: {len(per_trial)} trials, expected {len(trials)}")
        acc = np.array([trial_accuracy(b, tr) for b, tr in zip(per_trial, trials, strict=True)])
        scores[m] = {"published": acc[:, 0], "strict": acc[:, 1]}
    return scores


@dataclass
class StreamScores:
    """What :func:`score_trial_stream` keeps of a stream of trials.

    Attributes:
        scores: ``{method: {"published": (N,), "strict": (N,)}}``, as :func:`score_trials`.
        n_trials: ``N``, the number of trials seen.
        example: Trial number ``keep`` of the stream (or ``None``).
        example_beliefs: Its beliefs ``{method: (L + 1, n)}`` (or ``None``).
    """

    scores: dict[str, dict[str, NDArray[np.float64]]]
    n_trials: int
    example: Trial | None = None
    example_beliefs: dict[str, NDArray[np.float64]] | None = None


def score_trial_stream(
    chunks: Iterable[Sequence[Trial]],
    params: DFTParams | None = None,
    methods: Iterable[str] = METHODS,
    keep: int | None = None,
    progress: bool = False,
) -> StreamScores:
    """Replay and score ``chunks`` of trials one at a time (replay, score, drop).

    Memory is that of one chunk plus 48 bytes of scores per trial. The replay of a trial does not
    depend on the other trials of its batch (bit for bit), so the scores equal those of
    :func:`score_trials` on :func:`replay_trials` of all trials at once. Trial number ``keep``
    (0-based over the whole stream) and its beliefs are kept for a figure.
    """
    methods = tuple(methods)
    parts: dict[str, dict[str, list[NDArray[np.float64]]]] = {
        m: {"published": [], "strict": []} for m in methods
    }
    seen = 0
    example = example_beliefs = None
    for chunk in chunks:
        beliefs = replay_trials(chunk, params, methods, progress=progress)
        for m, s in score_trials(chunk, beliefs).items():
            parts[m]["published"].append(s["published"])
            parts[m]["strict"].append(s["strict"])
        if keep is not None and seen <= keep < seen + len(chunk):
            example = chunk[keep - seen]
            example_beliefs = {m: beliefs[m][keep - seen].copy() for m in methods}
        seen += len(chunk)
        del chunk, beliefs  # not held while the next chunk is made
    if seen == 0:
        raise ValueError("chunks: nothing to replay (empty stream)")
    scores = {m: {k: np.concatenate(v) for k, v in d.items()} for m, d in parts.items()}
    return StreamScores(scores=scores, n_trials=seen, example=example, example_beliefs=example_beliefs)
