"""Identification of gas-film models from a measured accelerance, and their comparison like the paper's Table 2.

* :mod:`.fitter` — :func:`~.fitter.fit_model`, input checks, the assembled :class:`~.result.FitResult`;
* :mod:`.problem` — one fit's data, search coordinates, residual and Jacobian (through the element algebra's one
  evaluator, :meth:`~gasfilm.analysis.physics.elements.FilmModel.stiffness_and_gradient`);
* :mod:`.default_search` — variable projection and Levenberg–Marquardt (the default, fast search);
* :mod:`.gapso` — the paper's GA-PSO;
* :mod:`.uncertainty` — parameters at a bound, standard errors, correlations, flags;
* :mod:`.comparison` — Table 2 (RMS, E, peak error, E_m, AIC, BIC).
"""

from gasfilm.analysis.identification.comparison import ComparisonRow, best_by_bic, compare_models, format_table2
from gasfilm.analysis.identification.fitter import DEFAULT_FIT_BAND_HZ, METHODS, default_fit_band_hz, fit_model
from gasfilm.analysis.identification.gapso import GapsoSettings
from gasfilm.analysis.identification.problem import FitCancelledError
from gasfilm.analysis.identification.result import FitResult

__all__ = [
    "DEFAULT_FIT_BAND_HZ",
    "METHODS",
    "ComparisonRow",
    "FitCancelledError",
    "FitResult",
    "GapsoSettings",
    "best_by_bic",
    "compare_models",
    "default_fit_band_hz",
    "fit_model",
    "format_table2",
]
