"""The frequency response of any measurement, by the estimator its kind calls for: a stepped sine
(``plant.data.recordings.Recording``) by the lock-in per block (``plant.estimate.lockin``), any other
excitation (``plant.data.recordings.TimeRecording``) by the FRF estimators (``plant.estimate.frf_estimation``:
periodic, local polynomial or closed loop, ``method="auto"`` choosing)."""

from __future__ import annotations

from plant.data.frequency_response import MeasuredResponse
from plant.data.recordings import Recording, TimeRecording
from plant.errors import DataError
from plant.estimate.frf_estimation import estimate_frf
from plant.estimate.lockin import estimate_response


def estimate(measurement: Recording | TimeRecording, *, method: str = "auto", **options) -> MeasuredResponse:
    """``MeasuredResponse`` of ``measurement``. ``method``: "auto", or for a time-domain recording "periodic",
    "lpm" or "closed-loop", for a stepped sine "lock-in"; ``options`` go to the estimator (a band for the
    FRF estimators, ``settle_s`` for the lock-in)."""
    if isinstance(measurement, TimeRecording):
        return estimate_frf(measurement, method=method, **options)
    if isinstance(measurement, Recording):
        if method not in ("auto", "lock-in"):
            raise DataError(f"{measurement.source}: a stepped sine is estimated by the lock-in, not {method!r}")
        return estimate_response(measurement, **options)
    raise DataError(f"cannot estimate a frequency response from a {type(measurement).__name__}")
