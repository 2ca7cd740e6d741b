"""Data-driven PI synthesis: the plant is given as measured responses, one recording per payload.

The loop L_m(jw_k) = G_m(jw_k) (kp + ki/jw_k) is affine in the gains, so the convex-concave
procedure of ``design.synth.pi`` runs unchanged on the measured frequencies; there is no
model for the exact casadi step or for Pade poles, so the design is verified on the data with
python-control (``stability_margins`` of the ``FrequencyResponseData``) and a stable open loop
is assumed (a stepped-sine recording of a runaway plant is not possible). Crossings must lie
inside the measured band; otherwise the margins are not known and the design is refused.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from design.loop.margins import closed_loop_bandwidth_hz, loop_margins
from design.spec.schema import Spec
from plant.errors import DataError


def measured_plants(spec: Spec, *, base_dir: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(payload_kg, w_rad_s, G) with G shaped (n_payloads, n_freq) on the common frequencies; stepped sines by
    the lock-in, time-domain recordings by ``plant.frf_estimation.estimate_frf`` (method chosen from the data)."""
    from plant.frf_estimation import estimate_frf
    from plant.lockin import estimate_response
    from plant.recording_io import parse_column_map
    from plant.time_recording import TimeRecording
    from plant.time_recording_io import read_measurement

    entries = sorted(spec.plant.measured, key=lambda e: e.payload_kg)
    resp = []
    for e in entries:
        path = Path(e.file) if Path(e.file).is_absolute() else base_dir / e.file
        rec = read_measurement(path, columns=parse_column_map(e.columns) if e.columns else None)
        resp.append(estimate_frf(rec) if isinstance(rec, TimeRecording) else estimate_response(rec))
    common = resp[0].f_hz
    for r in resp[1:]:
        common = np.intersect1d(common, r.f_hz)
    if common.size < 5:
        raise DataError(f"plant.measured: the recordings share {common.size} frequencies; at least 5 are needed")
    G = np.array([r.response.mean(axis=0)[np.searchsorted(r.f_hz, common)] for r in resp])
    return np.array([e.payload_kg for e in entries]), 2 * np.pi * common, G


def _numbers(w, G, kp, ki, spec):
    L = G * (kp + ki / (1j * w))
    m = loop_margins(w, L)
    bw = closed_loop_bandwidth_hz(w, L / (1 + L), dc_gain=1.0)
    req = spec.requirements
    gm = np.where(np.isfinite(m.gain_margin_db), m.gain_margin_db, np.inf)
    ok = bool(np.all(m.phase_margin_deg >= req.phase_margin_deg - 1e-6) and np.all(gm >= req.gain_margin_db - 1e-6)
              and np.all(np.isfinite(m.gain_crossover_hz)) and np.all(np.isfinite(bw)))
    return m, bw, ok


def synthesise_from_data(spec: Spec, *, base_dir: Path) -> dict:
    """Synthesis on measured responses; returns the same JSON-ready dict as ``SynthesisResult.to_dict``."""
    import control

    from design.synth.pi import _CCP

    payload, w, G = measured_plants(spec, base_dir=base_dir)
    t0 = time.perf_counter()
    c = spec.controller
    ccp = _CCP(G, w, spec)
    lo, hi = math.log(w[0]), math.log(w[-1])
    x = np.array([max(c.kp.min, 1e-6 * c.kp.max), max(c.ki.min, 1e-6 * c.ki.max)]) / ccp.scale
    best, solves = None, 0
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        xn, t = ccp.solve(x if best is None else best, math.exp(mid))
        solves += 1
        if t >= 0:
            lo, best = mid, xn
        else:
            hi = mid
        if hi - lo < 0.01:
            break
    seconds = time.perf_counter() - t0
    base = {"solver": {"method": "ccp on measured responses (cvxpy+CLARABEL)", "seconds": seconds,
                       "lp_solves": solves, "payload_points": payload.tolist(),
                       "frequency_band_hz": [float(w[0] / 2 / np.pi), float(w[-1] / 2 / np.pi)]},
            "baselines": [], "data_driven": True}
    if best is None:
        return {**base, "status": "infeasible", "message": "no gains meet the requirements on the measured data "
                "even at the lowest bandwidth target in the measured band", "gains": {"kp": None, "ki": None},
                "worst_case": None, "per_payload": [], "binding": None, "verified": False}
    kp, ki = (best * ccp.scale).tolist()
    m, bw, ok = _numbers(w, G, kp, ki, spec)
    failures = []
    for k, p in enumerate(payload):     # independent check: python-control on the measured FRD
        L = control.frd(G[k] * (kp + ki / (1j * w)), w)
        gm, pm, *_ = control.stability_margins(L)
        if pm < spec.requirements.phase_margin_deg - 0.05:
            failures.append(f"phase margin {pm:.2f} deg at {p:g} kg (python-control, FRD)")
        if np.isfinite(gm) and 20 * math.log10(gm) < spec.requirements.gain_margin_db - 0.05:
            failures.append(f"gain margin {20 * math.log10(gm):.2f} dB at {p:g} kg (python-control, FRD)")
    if not np.all(np.isfinite(m.gain_crossover_hz)):
        failures.append("a gain crossover lies outside the measured band: measure to higher frequency")
    i = int(np.argmin(m.phase_margin_deg))
    out = {**base, "gains": {"kp": kp, "ki": ki},
           "worst_case": {"bandwidth_hz": float(np.min(bw)), "phase_margin_deg": float(np.min(m.phase_margin_deg)),
                          "gain_margin_db": None if not np.all(np.isfinite(m.gain_margin_db))
                          else float(np.min(m.gain_margin_db))},
           "per_payload": [{"payload_kg": float(p), "bandwidth_hz": float(b), "phase_margin_deg": float(pm_),
                            "gain_margin_db": float(g) if np.isfinite(g) else None}
                           for p, b, pm_, g in zip(payload, bw, m.phase_margin_deg, m.gain_margin_db)],
           "binding": {"constraint": "phase_margin", "payload_kg": float(payload[i]),
                       "slack": float(m.phase_margin_deg[i] - spec.requirements.phase_margin_deg)},
           "verified": ok and not failures,
           "verification": {"tool": "python-control stability_margins on the measured FRD (open loop assumed "
                                     "stable)", "failures": failures, "payloads": int(payload.size)}}
    out["status"] = "optimal" if out["verified"] else "infeasible"
    out["message"] = "verified on the data" if out["verified"] else "; ".join(failures or ["margins not met"])
    return out
