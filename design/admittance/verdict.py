"""The verdict of an admittance design, one- or two-motor: its status and the sentence that says it.

In this order: a check that fails makes it ``infeasible`` (naming what failed); so does a Monte Carlo draw that
violates a requirement (naming the worst draw); a verified design the mouse cannot drive on the locomotion
profile is ``mouse_cannot_drive`` (naming the force it asks, the requirement that binds and a hint); else it is
``optimal``, with what it was verified on and the force the mouse feels.
"""

from __future__ import annotations

from design.admittance.feel import MouseFeel
from design.admittance.monte_carlo import AdmittanceMonteCarlo
from design.loop.requirement import Binding
from design.problem import AdmittanceProblem
from design.synth.scenarios import describe_row


def admittance_verdict(adm: AdmittanceProblem, *, failures: str | None, held_on: str, draws_over: str,
                       monte_carlo: AdmittanceMonteCarlo, feel: MouseFeel, binding: Binding, hint: str,
                       m_v: float, b_v: float) -> tuple[str, str]:
    """(status, message) of (m_v, b_v): ``failures`` what the check found failing (None: verified), ``held_on``
    what the check covered ("<n> design scenarios x <k> mice ..."), ``draws_over`` what the Monte Carlo drew over
    besides the mouse ("payload, uncertainty"), ``hint`` how to get a lighter design when ``binding`` binds."""
    mc, loc, peak = monte_carlo, adm.locomotion, adm.mouse.peak_force_n
    if failures is not None:
        return "infeasible", failures
    if mc.violations:
        return "infeasible", (f"verified on {held_on}, but {mc.violations} of {mc.samples} Monte Carlo draws over "
                              f"{draws_over} and mouse violate the requirements (worst at "
                              f"{describe_row(mc.worst_scenario)}, mouse {mc.worst_mouse.label()})")
    if not feel.can_drive:
        r = m_v * loc.peak_acceleration_m_per_s2 + b_v * loc.peak_speed_m_per_s
        return "mouse_cannot_drive", (
            f"the mouse cannot drive this design: it asks {feel.peak_force_n:.3g} N on the locomotion profile "
            f"({loc.peak_speed_m_per_s:g} m/s, {loc.peak_acceleration_m_per_s2:g} m/s^2; m_v a + b_v v = {r:.3g} N) "
            f"against the mouse's {peak:g} N (admittance.mouse.peak_force_n), {feel.peak_force_n / peak:.2f} times; "
            f"it binds: {binding.detail}; {hint}")
    return "optimal", (f"verified on {held_on}; 0 of {mc.samples} Monte Carlo draws over {draws_over} and mouse "
                       f"violate (95 % upper bound {100 * mc.rate_upper_bound:.2g} %); the mouse feels at most "
                       f"{feel.peak_force_n:.3g} N of its {peak:g} N on the locomotion profile")
