"""Controller design without simulation (pure maths: Riccati equations, LMIs, Galerkin).

The names below are the public synthesis API; the modules hold the rest:
``hinf`` (generalized-plant H∞ state and output feedback), ``problem`` (their plant and
result types), ``controller`` (the one controller type), ``sobolev`` (W∞ channels),
``interop`` (linear systems in, controllers out), ``mechanical`` (Sobolev gains of
Euler–Lagrange systems), ``regions`` (LMI pole regions), ``certificates`` (independent
checks), ``polytopic``, ``galerkin``, ``margins``, ``design_file`` (results saved as JSON / npz),
``designs`` (design rows; :func:`feedback_kind`, the one spelling of a feedback kind),
``options`` (:class:`SynthesisOptions`, the shared knobs as one value).
"""

from sobolev_drake.synthesis import regions
from sobolev_drake.synthesis.certificates import hinf_norm
# (``hinf.output_feedback``/``state_feedback`` are not re-exported: the first would hide the
# module ``synthesis.output_feedback``; ``hinf_output_feedback``/``hinf_state_feedback`` are
# the same functions, also taking linear systems)
from sobolev_drake.synthesis.controller import DynamicController
from sobolev_drake.synthesis.problem import (DiscreteDesign, GeneralizedPlant, SynthesisResult,
                                             SynthesisWarning)
from sobolev_drake.synthesis.interop import (HinfsynOutput, generalized_plant, hinf_output_feedback,
                                             hinf_state_feedback, hinfsyn, state_space_matrices,
                                             to_statespace)
from sobolev_drake.synthesis.design_file import load_result, save_result
from sobolev_drake.synthesis.designs import FEEDBACKS, feedback_kind
from sobolev_drake.synthesis.options import SynthesisOptions
from sobolev_drake.synthesis.lmi import InfeasibleLMIError, SynthesisError
from sobolev_drake.synthesis.mechanical import (controlled_gains, hinf_mechanical_gains,
                                                regulated_gains, stabilized_gains)
from sobolev_drake.synthesis.sobolev import (hinf_output_feedback_qr, hinf_plant,
                                             hinf_state_feedback_qr, winf_output_feedback,
                                             winf_plant, winf_state_feedback)

__all__ = [
    "regions", "hinf_norm",
    "DynamicController", "DiscreteDesign", "GeneralizedPlant", "SynthesisResult", "SynthesisWarning",
    "HinfsynOutput", "generalized_plant", "hinf_output_feedback", "hinf_state_feedback", "hinfsyn",
    "state_space_matrices", "to_statespace",
    "InfeasibleLMIError", "SynthesisError", "save_result", "load_result",
    "FEEDBACKS", "feedback_kind", "SynthesisOptions",
    "controlled_gains", "hinf_mechanical_gains", "regulated_gains", "stabilized_gains",
    "hinf_output_feedback_qr", "hinf_plant", "hinf_state_feedback_qr", "winf_output_feedback",
    "winf_plant", "winf_state_feedback",
]
