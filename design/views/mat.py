"""MATLAB files (``scipy.io.savemat``, level 5) of a design and of a measured response, for MATLAB users:
every array in SI units with its unit in the name, written atomically (``plant.host.files``)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from design.results import DesignOutcome
from plant import __version__
from plant.arguments import check_instance
from plant.data.frequency_response import MeasuredResponse
from plant.host.files import atomic_write_texts
from plant.physics.effect_base import PADE_ORDER


def _write(path: str | Path, content: dict) -> None:
    from scipy.io import savemat

    buf = io.BytesIO()
    savemat(buf, {"gantry_version": __version__, **content}, do_compression=True, oned_as="column")
    atomic_write_texts({Path(path): buf.getvalue()})


def write_design_mat(outcome: DesignOutcome, path: str | Path, *, payload_kg: float | None = None,
                     pade_order: int = PADE_ORDER) -> None:
    """The designed gains and P, C, L, S, T as state-space matrices (``<name>_A`` ... ``<name>_D``; load them
    in MATLAB with ``ss(P_A, P_B, P_C, P_D)``) at ``payload_kg`` (default: the spec's nominal payload)."""
    check_instance("outcome", outcome, DesignOutcome, "design.workflows.design(problem) makes one")
    models = outcome.loop_models(payload_kg, pade_order=pade_order)
    gm_db, pm_deg = models.margins()
    content = {"status": outcome.status, "kp_a_per_m_per_s": float(models.controller.kp),
               "ki_a_per_m": float(models.controller.ki),
               "payload_kg": models.payload_kg, "pade_order": models.pade_order,
               "gain_margin_db": gm_db, "phase_margin_deg": pm_deg}
    for name in ("P", "C", "L", "S", "T"):
        sys = getattr(models, name)
        for part in ("A", "B", "C", "D"):
            content[f"{name}_{part}"] = np.atleast_2d(np.asarray(getattr(sys, part), float))
    _write(path, content)


def write_response_mat(measured: MeasuredResponse, path: str | Path) -> None:
    """A measured frequency response: ``f_hz``, ``response_m_per_s_per_a`` (complex, outputs x frequencies),
    its ``variance``, the outputs' names, the excitation current and how it was estimated."""
    check_instance("measured", measured, MeasuredResponse, "design.workflows.measure(path) makes one")
    _write(path, {"f_hz": np.asarray(measured.f_hz, float),
                  "response_m_per_s_per_a": np.asarray(measured.response, complex),
                  "variance_m2_per_s2_per_a2": np.asarray(measured.variance, float),
                  "output_names": np.array(measured.output_names, dtype=object),
                  "current_amplitude_a": np.asarray(measured.current_amplitude_a, float),
                  "source": str(measured.source), "method": measured.method})
