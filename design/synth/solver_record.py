"""How a PI synthesis went, step by step: what ``gantry synth --json`` reports under ``solver`` beside the method,
the time and the payload points (``design.views.json.record_to_dict`` writes it), and the drive filters it
chose (``filters``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class ExactStart:
    """One start of the exact solve (casadi + IPOPT): its label, the gains it started from and reached, IPOPT's
    return status."""

    design: str
    kp0: float
    ki0: float
    kp: float
    ki: float
    ipopt: str


@dataclass(frozen=True)
class Candidate:
    """A candidate design that held on the dense check: its label, gains and worst-case bandwidth (Hz)."""

    design: str
    kp: float
    ki: float
    worst_bandwidth_hz: float


@dataclass(frozen=True)
class VerifiedCandidate:
    """A candidate the independent check (python-control) was run on, and whether it held."""

    design: str
    verified: bool


@dataclass(frozen=True)
class FilterTrial:
    """The drive filters' parameters tried (per filter of ``controller.filters``: its values, or None where it is
    left out), the worst-case bandwidth (Hz, -1 where the design failed) and the status of its synthesis (None
    for the scan, which designs no gains)."""

    filters: tuple[Mapping[str, float] | None, ...]
    worst_bandwidth_hz: float
    status: str | None = None


@dataclass(frozen=True)
class JointExact:
    """One joint solve of the gains and the filters (IPOPT) from a start's filter parameters: its status, the
    parameters it found, and the worst-case bandwidth (Hz) of the synthesis there (None when IPOPT failed)."""

    start: tuple[Mapping[str, float] | None, ...]
    ipopt: str
    filters: tuple[Mapping[str, float] | None, ...]
    worst_bandwidth_hz: float | None = None


@dataclass(frozen=True)
class SolverRecord:
    """The account of one synthesis; a field is None (a tuple empty) where its step did not run."""

    cpu_seconds: float | None = None
    import_seconds: float | None = None
    #: rounds of design and dense check (the worst violator added each time)
    rounds: int | None = None
    #: gain pairs scanned and LPs the ccp design solved, over the rounds
    scan_designs: int | None = None
    lp_solves: int | None = None
    exact_starts: tuple[ExactStart, ...] | None = None
    solver_ccp: str | None = None
    solver_exact: str | None = None
    #: the dense check's scenarios, in words
    dense_check: str | None = None
    polish_evaluations: int | None = None
    verification_seconds: float | None = None
    #: the candidate reported
    chosen: str | None = None
    verified_candidates: tuple[VerifiedCandidate, ...] | None = None
    candidates: tuple[Candidate, ...] | None = None
    design_scenarios: int | None = None
    #: the phase-limiting effects a plant lacks (an unbounded problem)
    missing_effects: tuple[str, ...] | None = None
    #: with designed drive filters: the filter scan, the starts designed and the joint solves
    filter_scan: tuple[FilterTrial, ...] | None = None
    filter_starts: tuple[FilterTrial, ...] | None = None
    joint_exact: tuple[JointExact, ...] | None = None


@dataclass(frozen=True)
class ChosenFilter:
    """A drive filter of ``controller.filters`` as the synthesis left it: its kind, whether the design uses it,
    its parameters (as the spec names them: ``frequency_hz``, ``damping_ratio``, ``depth``) and which of them
    were designed."""

    kind: str
    used: bool
    values: Mapping[str, float]
    designed: tuple[str, ...]
