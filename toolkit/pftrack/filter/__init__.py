"""The particle-filter core: weights, resampling and estimates, vectorised over particles.

Weights are carried as log-weights. Every function here is a pure numpy function of arrays and a
``numpy.random.Generator``; the tracker (:mod:`pftrack.engine.tracker`) composes them.
"""

from pftrack.filter.core import (
    RESAMPLERS,
    effective_sample_size,
    multinomial_resample,
    normalize_log_weight_rows,
    normalize_log_weights,
    resample,
    residual_resample,
    stratified_resample,
    systematic_resample,
    systematic_resample_rows,
    weighted_extent,
    weighted_mean,
    weighted_variance,
)

__all__ = [
    "RESAMPLERS",
    "effective_sample_size",
    "multinomial_resample",
    "normalize_log_weight_rows",
    "normalize_log_weights",
    "resample",
    "residual_resample",
    "stratified_resample",
    "systematic_resample",
    "systematic_resample_rows",
    "weighted_extent",
    "weighted_mean",
    "weighted_variance",
]
