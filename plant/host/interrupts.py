"""Ctrl-C and SIGTERM as the command line receives them. The signal handlers record the request here as
well as raising, because a library may swallow the exception raised in its callbacks (casadi's SWIG
wrappers clear it, IPOPT returns "User_Requested_Stop", Clarabel turns it into a solver failure):
outputs are not committed once a stop was requested (``plant.host.files.atomic_write_texts``), and the
command line ends with the status of the request whatever the exception that reached it."""

from __future__ import annotations

import signal


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that it unwinds like Ctrl-C."""


_requested: list[str] = []


def install() -> tuple:
    """Handlers for SIGINT (``KeyboardInterrupt``) and SIGTERM (``Terminated``) that record the request;
    returns the handlers they replace (for ``uninstall``)."""
    _requested.clear()
    return signal.signal(signal.SIGINT, _on_signal), signal.signal(signal.SIGTERM, _on_signal)


def uninstall(previous: tuple) -> None:
    """The handlers ``install`` replaced back, and no stop pending."""
    signal.signal(signal.SIGINT, previous[0])
    signal.signal(signal.SIGTERM, previous[1])
    _requested.clear()


def _on_signal(signum, frame) -> None:
    _requested.append("terminate" if signum == signal.SIGTERM else "interrupt")
    raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt


def requested() -> str | None:
    """"interrupt", "terminate" or None: the first stop requested since the handlers were installed."""
    return _requested[0] if _requested else None


def raise_if_requested() -> None:
    """Raise the requested stop again (a library swallowed it)."""
    kind = requested()
    if kind == "terminate":
        raise Terminated
    if kind == "interrupt":
        raise KeyboardInterrupt
