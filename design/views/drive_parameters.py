"""A design's numbers in a drive's own parameter names, units and scaling (``gantry export``), and each
conversion's inverse, so that a test (or a reader) can convert the typed numbers back to Kp, Ki.

The design's PI controller is C(s) = Kp + Ki / s, Kp in A/(m/s) (current per velocity error), Ki in A/m.

Generic (``generic``): Kp, Ki and the integral action time Tn = Kp / Ki (s), the same controller written
Kp (1 + 1 / (Tn s)); with ``controller.loop_rate_hz`` in the spec, the discrete numbers the synthesis already
wrote (``discrete``: kp, ki per sample of the trapezoidal integral, the filters' biquads).

Beckhoff (``beckhoff``), sources (Beckhoff Information System, infosys.beckhoff.com):

* AX5000 IDN description, "S-0-0100 velocity loop Kp": udec, 32 bit, 3 decimals, max
  4294967.295 (interface revision 210); unit A/(rad/s) (compatible), or Nm/(rad/s) | N/(m/s) with the feature
  flag P-0-0010 bit 15 set. Exported in N/(m/s), the flag set: S-0-0100 = Kp K_f, K_f the motor's force
  constant (N/A, the spec's ``plant.force_constant_n_per_a``). The compatible A/(rad/s) of a linear motor
  depends on how the drive maps its pole pitch to radians, which the page does not give: not exported.
* AX5000 IDN description, "S-0-0101 velocity loop Tn": udec, 16 bit, 1 decimal, unit ms,
  max 6000.0; 0 switches the integral part off. S-0-0101 = 1000 Kp / Ki.
* AX8000 object description, "3140:01 Velocity control proportional gain" (REAL32, unit set by "3005:09
  Scaling index velocity proportional gain") and "3140:02 Velocity control integral action time" (REAL32, s,
  max 5.0). 3140:01 = Kp K_f in the force scaling, 3140:02 = Kp / Ki. The enumeration of 3005:09 names
  Scale_Nm_per_rad_per_Second (36864, the default) and Scale_N_per_rad_per_Second (37120); the pages do not
  say which a linear axis reads as N/(m/s), so the export says to check it on the drive.
* The integral action time as Tn of Kp (1 + 1 / (Tn s)): Beckhoff TF5200 channel parameter P-CHAN-00822,
  "the time after which the P and I components of the manipulated variable are equal" (after Tn, Kp e t / Tn
  = Kp e), the AX5000 Tuning Guide's "proportional gain Kp (S-0-0100) and the integral action time Tn
  (S-0-0101)".

Copley (``copley``), sources (Copley Controls, Parameter Dictionary 16-01091 and CME 2 User Guide, 11.4 and
11.5): the velocity loop's velocities are in 0.1 encoder counts/s (parameters 0x3A velocity limit, 0x3B
instantaneous commanded velocity, 0x18 actual velocity) and its currents in 0.01 A (the actual motor
current); Vp (0x27) and Vi (0x28) are integers 0 to 32,767 whose scaling the manual leaves to the "Velocity
Gains Shift". Neither document gives the factor between Vp, Vi and a current per velocity error, so Vp and Vi
are NOT exported: the export gives the gains in the drive's own units, Kp in 0.01 A per 0.1 counts/s
(= 10 Kp r, r the encoder's resolution in m per count) and Ki in 0.01 A per 0.1 counts (= 10 Ki r), for a
measured step (or Copley's own tools) to map onto Vp and Vi.

LabVIEW (``labview``): the admittance law exactly as the design wrote it (``admittance.rig.discrete``), the
virtual dynamics 1 / (m_v s + b_v) per update T = 1 / update_rate_hz, v[k] = alpha v[k-1] + beta F[k] +
beta_prev F[k-1] (``design.admittance.rig.law_coefficients``), with m_v and b_v as the lab's VI holds them
(bsbrl/exoskeleton LABVIEW/cRIO_4DOF_Admittance_control_v11_NewMousetrack.vi: a = inv(m) (F' - c v_1)
integrated once per loop, forward Euler: m = m_v, c = b_v).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from design.admittance.rig import RULE_NAMES, RULES, law_coefficients
from plant.errors import DataError, ParameterError
from plant.story import Section, Story, Table

#: the targets ``gantry export --drive`` knows
DRIVES = ("beckhoff", "copley", "generic", "labview")

AX5000_IDN = "Beckhoff AX5000 IDN description"
AX8000_OBJECT = "Beckhoff AX8000 object description"
COPLEY = "Copley Parameter Dictionary 16-01091"
LAB_VI = "bsbrl/exoskeleton cRIO_4DOF_Admittance_control_v11_NewMousetrack.vi"
DESIGN = "the design (gantry synth --json)"

#: S-0-0100: 3 decimals, its maximum (interface revision 210)
S0100_DECIMALS, S0100_MAX = 3, 4294967.295
#: S-0-0101: 1 decimal (ms), its maximum
S0101_DECIMALS, S0101_MAX_MS = 1, 6000.0
#: 3140:02: its maximum (s)
AX8000_TN_MAX_S = 5.0
#: Copley's units: velocity 0.1 counts/s, current 0.01 A
COPLEY_VELOCITY_COUNTS_PER_S, COPLEY_CURRENT_A = 0.1, 0.01


@dataclass(frozen=True)
class DriveParameter:
    """One number for the drive: its ``name`` there, ``value`` (exact; None where the design has none),
    ``unit``, ``entry`` (what to type: the value at the parameter's resolution), the ``source`` of its scaling
    and a ``note`` (a limit it exceeds, what 0 means)."""

    name: str
    value: float | None
    unit: str
    entry: str
    source: str
    note: str = ""


@dataclass(frozen=True)
class DriveExport:
    """A design's numbers for one drive: ``parameters`` in the order to type them, ``notes`` on all of them."""

    drive: str
    title: str
    parameters: tuple[DriveParameter, ...]
    notes: tuple[str, ...] = ()

    def parameter(self, name_start: str) -> DriveParameter:
        """The parameter whose name starts with ``name_start`` (KeyError naming those there are)."""
        for p in self.parameters:
            if p.name.startswith(name_start):
                return p
        raise KeyError(f"no parameter {name_start!r}; there are {[p.name for p in self.parameters]}")


def _g(value: float) -> str:
    return f"{value:.6g}"


def _fixed(value: float, decimals: int) -> str:
    return f"{value:.{decimals}f}"


def _check_gains(kp: float, ki: float) -> None:
    if not (math.isfinite(kp) and math.isfinite(ki) and kp >= 0 and ki >= 0):
        raise ParameterError(f"gains must be finite and non-negative, got kp = {kp}, ki = {ki}")


def integral_time_s(kp: float, ki: float) -> float | None:
    """Tn = Kp / Ki (s) of Kp (1 + 1 / (Tn s)); None without integral action (Ki = 0)."""
    return None if ki == 0 else kp / ki


def gains_from_integral_time(kp: float, tn_s: float | None) -> tuple[float, float]:
    """(Kp, Ki) of Kp (1 + 1 / (Tn s)): Ki = Kp / Tn; Tn None or 0 (the integral switched off) gives Ki = 0."""
    return kp, 0.0 if not tn_s else kp / tn_s


def generic(kp: float, ki: float, *, discrete: dict | None = None) -> DriveExport:
    """Kp, Ki and Tn, and with ``discrete`` (``gantry synth --json``'s ``discrete``) the per-sample numbers and
    the filters' biquad coefficients."""
    _check_gains(kp, ki)
    tn = integral_time_s(kp, ki)
    rows = [DriveParameter("Kp", kp, "A/(m/s)", _g(kp), DESIGN),
            DriveParameter("Ki", ki, "A/m", _g(ki), DESIGN),
            DriveParameter("Tn = Kp/Ki", tn, "s", "-" if tn is None else _g(tn), "Kp (1 + 1/(Tn s)) = Kp + Ki/s",
                           "no integral action (Ki = 0)" if tn is None else "")]
    notes = []
    if discrete:
        rate = float(discrete["loop_rate_hz"])
        rows += [DriveParameter("loop rate", rate, "Hz", _g(rate), "the spec's controller.loop_rate_hz"),
                 DriveParameter("kp (per sample)", float(discrete["kp"]), "A/(m/s)", _g(float(discrete["kp"])),
                                DESIGN),
                 DriveParameter("ki per sample", float(discrete["ki_per_sample"]), "A/(m/s)",
                                _g(float(discrete["ki_per_sample"])), DESIGN,
                                "trapezoidal integral: Ki / loop rate per sample")]
        for k, f in enumerate(discrete.get("filters") or (), start=1):
            for c in ("b0", "b1", "b2", "a1", "a2"):
                rows.append(DriveParameter(f"filter {k} ({f.get('kind', '?')}) {c}", float(f[c]), "",
                                           f"{float(f[c]):.10g}", DESIGN,
                                           "H(z) = (b0 + b1 z^-1 + b2 z^-2) / (1 + a1 z^-1 + a2 z^-2)"
                                           if c == "b0" else ""))
    else:
        notes.append("no discrete coefficients: the spec has no controller.loop_rate_hz (give it to export the "
                     "per-sample gains and filter coefficients at the drive's velocity-loop rate)")
    return DriveExport("generic", "PI velocity loop, Kp + Ki/s = Kp (1 + 1/(Tn s))", tuple(rows), tuple(notes))


def beckhoff(kp: float, ki: float, force_constant_n_per_a: float) -> DriveExport:
    """AX5000 S-0-0100 (N/(m/s), P-0-0010 bit 15 set) and S-0-0101 (ms); AX8000 3140:01 and 3140:02 (s)."""
    _check_gains(kp, ki)
    if not (math.isfinite(force_constant_n_per_a) and force_constant_n_per_a > 0):
        raise ParameterError(f"force constant must be finite and > 0 N/A, got {force_constant_n_per_a}")
    kp_n = kp * force_constant_n_per_a
    tn = integral_time_s(kp, ki)
    tn_ms = 0.0 if tn is None else 1000.0 * tn
    off = "0: the integral part off (the design has Ki = 0)" if tn is None else ""
    rows = (
        DriveParameter("S-0-0100 velocity loop Kp", kp_n, "N/(m/s)",
                       _fixed(kp_n, S0100_DECIMALS), f"{AX5000_IDN}, S-0-0100",
                       f"above the parameter's maximum {S0100_MAX}" if kp_n > S0100_MAX else ""),
        DriveParameter("S-0-0101 velocity loop Tn", tn_ms, "ms",
                       _fixed(tn_ms, S0101_DECIMALS), f"{AX5000_IDN}, S-0-0101",
                       off or (f"above the parameter's maximum {S0101_MAX_MS:.1f} ms: the drive cannot hold "
                               "this integral action" if tn_ms > S0101_MAX_MS else "")),
        DriveParameter("AX8000 3140:01 Kp", kp_n, "N/(m/s)", _g(kp_n),
                       f"{AX8000_OBJECT}, 3140:01 and 3005:09"),
        DriveParameter("AX8000 3140:02 Tn", tn_ms / 1000.0, "s",
                       _g(tn_ms / 1000.0), f"{AX8000_OBJECT}, 3140:02",
                       off or (f"above the object's maximum {AX8000_TN_MAX_S:g} s: the drive cannot hold this "
                               "integral action" if tn_ms / 1000.0 > AX8000_TN_MAX_S else "")),
    )
    notes = (f"Kp in force per velocity: Kp {kp:.6g} A/(m/s) x the force constant {force_constant_n_per_a:g} N/A; "
             "on the AX5000 set P-0-0010 bit 15 (S-0-0100 in N/(m/s), not the compatible A/(rad/s))",
             "AX8000: 3140:01's unit is set by 3005:09; the object description names Nm/(rad/s) (default) and "
             "N/(rad/s) only, so read 3140:01 back once on the drive in N/(m/s) before relying on it")
    return DriveExport("beckhoff", "Beckhoff AX5000 / AX8000 velocity controller", rows, notes)


def beckhoff_gains(s0100_n_per_m_per_s: float, s0101_ms: float, force_constant_n_per_a: float
                   ) -> tuple[float, float]:
    """(Kp A/(m/s), Ki A/m) of S-0-0100 (N/(m/s)) and S-0-0101 (ms; 0: no integral part)."""
    kp = s0100_n_per_m_per_s / force_constant_n_per_a
    return gains_from_integral_time(kp, s0101_ms / 1000.0)


def copley(kp: float, ki: float, encoder_resolution_m: float) -> DriveExport:
    """Kp and Ki in the Copley velocity loop's own units (0.01 A per 0.1 counts/s, 0.01 A per 0.1 counts)."""
    _check_gains(kp, ki)
    if not (math.isfinite(encoder_resolution_m) and encoder_resolution_m > 0):
        raise ParameterError(f"--encoder-resolution-m must be finite and > 0 (m per count), got "
                             f"{encoder_resolution_m}")
    r = encoder_resolution_m
    per_unit = COPLEY_VELOCITY_COUNTS_PER_S / COPLEY_CURRENT_A      # (0.01 A per 0.1 counts/s) per (A per count/s)
    kp_drive = kp * r * per_unit
    ki_drive = ki * r * per_unit
    rows = (
        DriveParameter("encoder resolution", 1.0 / r, "counts/m", _g(1.0 / r), "--encoder-resolution-m"),
        DriveParameter("Kp in drive units", kp_drive, "0.01 A/(0.1 count/s)", _g(kp_drive),
                       f"{COPLEY} (velocities 0.1 counts/s: 0x18, 0x3A, 0x3B; currents 0.01 A)"),
        DriveParameter("Ki in drive units", ki_drive, "0.01 A/(0.1 count)", _g(ki_drive),
                       f"{COPLEY} (as Kp; the integral of 0.1 counts/s over s)"),
        DriveParameter("Vp, Vi", None, "", "-", f"{COPLEY} 0x27, 0x28; CME 2 User Guide 11.5", "not exported"),
    )
    notes = ("Vp and Vi are the drive's integers 0-32,767 under its Velocity Gains Shift; Copley's manuals do not "
             "give their factor to A per count/s, so they are not printed: map Kp, Ki onto them with a measured "
             "step (or Copley's CME 2) and check one value by converting back",)
    return DriveExport("copley", "Copley Controls velocity loop (drive units)", rows, notes)


def copley_gains(kp_drive: float, ki_drive: float, encoder_resolution_m: float) -> tuple[float, float]:
    """(Kp A/(m/s), Ki A/m) of the gains in Copley's units (0.01 A per 0.1 counts/s, per 0.1 counts)."""
    per_unit = COPLEY_VELOCITY_COUNTS_PER_S / COPLEY_CURRENT_A
    return kp_drive / (encoder_resolution_m * per_unit), ki_drive / (encoder_resolution_m * per_unit)


#: the rule's key by its text in ``admittance.rig.discrete.rule``
_RULE_KEYS = {text: key for key, text in RULES.items()}


def labview(admittance: dict, where: str) -> DriveExport:
    """The sampled admittance law of ``admittance`` (``gantry synth --json``'s ``admittance``): m_v, b_v, the
    period, the rule's coefficients and the computation delay; DataError where the file's coefficients are not
    its m_v, b_v's by its rule."""
    rig = admittance.get("rig") or {}
    law = rig.get("discrete")
    if not law or not rig.get("update_rate_hz"):
        raise ParameterError(f"{where}: the admittance law is continuous (no admittance.rig.update_rate_hz in the "
                             "spec): there are no discrete coefficients to export")
    try:
        m_v, b_v, rate = float(admittance["m_v"]), float(admittance["b_v"]), float(rig["update_rate_hz"])
        alpha, beta = float(law["alpha"]), float(law["beta_m_per_s_per_n"])
        beta_prev = float(law.get("beta_prev_m_per_s_per_n") or 0.0)
        rule = _RULE_KEYS[str(law["rule"])]
    except (KeyError, TypeError, ValueError):
        raise DataError(f"{where}: admittance.rig.discrete is not as gantry synth --json writes it "
                        "(alpha, beta_m_per_s_per_n, a known rule)") from None
    T = 1.0 / rate
    expected = [float(c) for c in law_coefficients(m_v, b_v, T, rule)]
    if not all(math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12) for a, b in zip(expected, (alpha, beta, beta_prev))):
        raise DataError(f"{where}: admittance.rig.discrete (alpha {alpha:g}, beta {beta:g}) is not the law of its "
                        f"m_v {m_v:g} kg, b_v {b_v:g} N*s/m at {rate:g} Hz by {rule}")
    delay = rig.get("computation_delay_samples")
    rows = [DriveParameter("m (virtual mass)", m_v, "kg", _g(m_v), f"{LAB_VI}: a = inv(m) (F' - c v_1)"),
            DriveParameter("c (virtual damping)", b_v, "N*s/m", _g(b_v), LAB_VI),
            DriveParameter("dt (loop period)", T, "s", _g(T), "the spec's admittance.rig.update_rate_hz"),
            DriveParameter("alpha", alpha, "", f"{alpha:.10g}", DESIGN, RULE_NAMES[rule]),
            DriveParameter("beta", beta, "m/s per N", f"{beta:.10g}", DESIGN)]
    if beta_prev:
        rows.append(DriveParameter("beta_prev", beta_prev, "m/s per N", f"{beta_prev:.10g}", DESIGN))
    if rig.get("force_filter_hz"):
        hz = float(rig["force_filter_hz"])
        rows.append(DriveParameter("force filter", hz, "Hz", _g(hz), "the spec's admittance.rig.force_filter",
                                   f"order {rig.get('force_filter_order')}"))
    notes = (f"{RULES[rule]}, i.e. v[k] = alpha v[k-1] + beta F[k]" + (" + beta_prev F[k-1]" if beta_prev else "")
             + f", once per loop of dt; the velocity held until the next update, applied {delay} sample(s) "
             "after F[k] is read",)
    if rule == "forward_euler":
        notes += ("the lab's VI integrates a = (F - c v) / m by forward Euler: with m and c above it is this law",)
    else:
        notes += (f"the design's rule is {rule}, not the lab VI's forward Euler: program alpha and beta, not m and c",)
    return DriveExport("labview", "LabVIEW admittance law (virtual dynamics 1/(m_v s + b_v))", tuple(rows), notes)


def labview_virtual(alpha: float, beta: float, beta_prev: float, period_s: float, rule: str
                    ) -> tuple[float, float]:
    """(m_v kg, b_v N*s/m) of a law's coefficients by ``rule`` (the inverse of ``law_coefficients``)."""
    T = period_s
    if rule == "forward_euler":         # alpha = 1 - b T / m, beta = T / m
        m = T / beta
        return m, (1.0 - alpha) * m / T
    if rule == "backward_euler":        # alpha = m / (m + b T), beta = T / (m + b T)
        return alpha * T / beta, (1.0 - alpha) / beta
    if rule == "tustin":                # beta = beta_prev = T / (2m + bT), alpha = (2m - bT) / (2m + bT)
        return T * (1.0 + alpha) / (4.0 * beta), (1.0 - alpha) / (2.0 * beta)
    if rule == "zoh":                   # alpha = e^(-bT/m), beta = (1 - alpha) / b
        b = (1.0 - alpha) / beta
        return b * T / -math.log(alpha), b
    raise ParameterError(f"unknown rule {rule!r}; rules are {', '.join(RULES)}")


def export_story(export: DriveExport, design_file: str) -> Story:
    """The export as the console prints it: the parameters to type, then where each scaling comes from."""
    table = Table(("parameter", "enter", "unit", "note"),
                  tuple((p.name, p.entry, p.unit, p.note) for p in export.parameters), frozenset({0, 2, 3}))
    sources = tuple(dict.fromkeys(f"{p.name}: {p.source}" for p in export.parameters))
    return Story(headline=(("Drive", export.title), ("Design", design_file)),
                 sections=(Section("Parameters", table=table), Section("Sources", sources),
                           Section("Notes", export.notes, kind="notes")))


def export_to_dict(export: DriveExport, design_file: str) -> dict:
    """``gantry export --json``."""
    return {"drive": export.drive, "title": export.title, "design": design_file,
            "parameters": [{"name": p.name, "value": p.value, "unit": p.unit, "entry": p.entry,
                            "source": p.source, "note": p.note} for p in export.parameters],
            "notes": list(export.notes)}
