"""Intent inference: the belief over the goals, updated by a registered method
(:data:`INFERENCE_METHODS`: field-theoretic, the paper's; recursive Bayes; memory-based) from the
user's commands and the end-effector's path.

Every array function broadcasts over any number of leading batch dimensions, so the same update
serves a single live step, a vectorised replay of hundreds of trials, and the disambiguation's
forward projection of all probe directions at once.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

# The variants register as they are imported: in the paper's order (dft, bayes, memory).
# isort: off
from drake_disamb.core.inference import dft, bayes, memory  # noqa: F401
# isort: on

from drake_disamb.core.inference.bayes import (
    BAYES_COS_DECIMALS,
    BAYES_SIGMA,
    BayesInference,
    bayes_likelihood,
    bayes_step,
)
from drake_disamb.core.inference.belief import (
    TINY,
    check_probability_vector,
    check_transition,
    has_command,
    normalize_belief,
    posterior_update,
    rest_state,
    safe_unit,
    sanitize_command,
    squared_norm,
    transition_prior,
    uniform_belief,
)
from drake_disamb.core.inference.dft import (
    AGREEMENT_MEASURES,
    DFTInference,
    DFTParams,
    DFTRow,
    agreement,
    biased_sigmoid,
    dft_drive,
    dft_euler_rollout,
    dft_euler_step,
    dft_euler_update,
    dft_mass_conserving_rhs,
    dft_mass_conserving_rhs_from_drive,
    dft_rhs,
    dft_rhs_from_drive,
    dft_xi,
    directedness,
    proximity,
)
from drake_disamb.core.inference.memory import (
    MemoryInference,
    likelihood_from_log,
    memory_log_likelihood,
    memory_step,
    path_cost_increment,
)
from drake_disamb.core.inference.methods import (
    INFERENCE_METHODS,
    InferenceMethod,
    ProjectedInference,
    RecordedSamples,
)

__all__ = [
    "AGREEMENT_MEASURES",
    "BAYES_COS_DECIMALS",
    "BAYES_SIGMA",
    "INFERENCE_METHODS",
    "TINY",
    "BayesInference",
    "DFTInference",
    "DFTParams",
    "DFTRow",
    "InferenceMethod",
    "MemoryInference",
    "ProjectedInference",
    "RecordedSamples",
    "agreement",
    "bayes_likelihood",
    "bayes_step",
    "biased_sigmoid",
    "check_probability_vector",
    "check_transition",
    "dft_drive",
    "dft_euler_rollout",
    "dft_euler_step",
    "dft_euler_update",
    "dft_mass_conserving_rhs",
    "dft_mass_conserving_rhs_from_drive",
    "dft_rhs",
    "dft_rhs_from_drive",
    "dft_xi",
    "directedness",
    "has_command",
    "likelihood_from_log",
    "memory_log_likelihood",
    "memory_step",
    "normalize_belief",
    "path_cost_increment",
    "posterior_update",
    "proximity",
    "rest_state",
    "safe_unit",
    "sanitize_command",
    "squared_norm",
    "transition_prior",
    "uniform_belief",
]
