"""What the optimisers share: IPOPT traps Ctrl-C itself and returns "User_Requested_Stop", so a
caller that did not look would go on and write its results; this turns that back into an interrupt."""

from __future__ import annotations

#: IPOPT return statuses that mean the user interrupted the solve
INTERRUPTED = ("User_Requested_Stop",)


def raise_if_interrupted(solver) -> dict:
    """The casadi solver's stats; ``KeyboardInterrupt`` when IPOPT stopped on Ctrl-C."""
    stats = solver.stats()
    if stats.get("return_status") in INTERRUPTED:
        raise KeyboardInterrupt
    return stats
