"""The admittance verdict's order (a failed check, a violating draw, a mouse that cannot drive, else optimal), the
same for one- and two-motor designs."""

from types import SimpleNamespace

import pytest

from design.admittance.verdict import admittance_verdict

ADM = SimpleNamespace(locomotion=SimpleNamespace(peak_acceleration_m_per_s2=1.0, peak_speed_m_per_s=0.2),
                      mouse=SimpleNamespace(peak_force_n=1.2))
WORST = SimpleNamespace(label=lambda: "floating")


def verdict(failures=None, violations=0, felt_n=1.0):
    mc = SimpleNamespace(violations=violations, samples=1000, rate_upper_bound=0.003,
                         worst_scenario=SimpleNamespace(as_dict=lambda: {"payload_kg": 40.0}), worst_mouse=WORST)
    feel = SimpleNamespace(can_drive=felt_n <= 1.2, peak_force_n=felt_n)
    binding = SimpleNamespace(detail="interaction-loop phase margin")
    return admittance_verdict(ADM, failures=failures, held_on="4 design scenarios x 2 mice", draws_over="payload",
                              monte_carlo=mc, feel=feel, binding=binding, hint="lower the PM", m_v=0.05, b_v=5.0)


@pytest.mark.parametrize("args,status,words", [
    (dict(failures="NOT verified: GM 5.9 dB", violations=3, felt_n=2.0), "infeasible", "NOT verified: GM 5.9 dB"),
    (dict(violations=3, felt_n=2.0), "infeasible", "3 of 1000 Monte Carlo draws over payload and mouse violate"),
    (dict(felt_n=2.0), "mouse_cannot_drive", "m_v a + b_v v = 1.05 N) against the mouse's 1.2 N"),
    (dict(), "optimal", "verified on 4 design scenarios x 2 mice; 0 of 1000 Monte Carlo draws"),
])
def test_the_first_failing_stage_decides(args, status, words):
    got_status, message = verdict(**args)
    assert got_status == status and words in message
    if status == "mouse_cannot_drive":
        assert "it binds: interaction-loop phase margin; lower the PM" in message and "1.67 times" in message
