"""The ``gantry`` command line: one thin module per command (parse, call the library, write), registered
here by name.

``main`` is the one error boundary: bad input becomes one line on stderr and exit status 2, Ctrl-C
exit status 130, and a genuine bug keeps its traceback.
"""

from __future__ import annotations

import signal
import sys

from plant.errors import GantryError


def _register() -> None:
    """Register every command on the app, explicitly."""
    from design.cli import (
        diagnose,
        excite,
        fit,
        report,
        reproduce,
        simulate,
        sweep,
        synth,
    )
    from design.cli.common import app

    for module, name in ((reproduce, "reproduce"), (simulate, "simulate"), (fit, "fit"), (diagnose, "diagnose"),
                         (excite, "excite"), (synth, "synth"), (sweep, "sweep"), (report, "report")):
        app.command(name=name)(getattr(module, name))


def main() -> None:
    """Console entry point, the one error boundary: bad input (``GantryError``, usage errors, files that
    cannot be read or written, not enough memory) is one line on stderr and exit status 2; Ctrl-C is
    exit status 130; anything else is a bug, shown with its traceback and a request to report it."""
    import matplotlib
    import typer

    try:    # typer >= 0.20 carries its own click
        from typer._click.exceptions import ClickException, NoArgsIsHelpError
    except ImportError:     # pragma: no cover
        from click.exceptions import ClickException, NoArgsIsHelpError

    matplotlib.use("Agg")
    from design.cli.common import app

    _register()
    signal.signal(signal.SIGTERM, _terminated)   # unwind (temporary files removed) instead of dying mid-write
    try:
        code = app(standalone_mode=False)     # Ctrl-C inside a command comes back as exit code 130
    except GantryError as exc:
        _fail(str(exc), 2)
    except (typer.Abort, KeyboardInterrupt):
        _fail("interrupted", 130)
    except Terminated:
        _fail("terminated", 143)
    except NoArgsIsHelpError as exc:     # the help (rich prints it itself and leaves the message empty)
        if exc.format_message().strip():
            print(exc.format_message())
        _fail("no command given (gantry --help lists the commands)", exc.exit_code)
    except ClickException as exc:
        _fail(f"{exc.format_message()} (gantry --help lists the commands; gantry COMMAND --help their options)",
              exc.exit_code)
    except MemoryError:
        _fail("not enough memory for this input; use fewer payloads, samples, frequencies or a shorter duration", 2)
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        _fail(f"{where}{exc.strerror or exc}", 2)
    except Exception:
        import traceback

        traceback.print_exc()
        _fail("this is a bug in gantry, not a problem with your input: please report it with the traceback above", 1)
    if code == 130:
        _fail("interrupted", 130)
    sys.exit(code if isinstance(code, int) else 0)


class Terminated(BaseException):
    """SIGTERM, raised where the program is so that it unwinds like Ctrl-C."""


def _terminated(signum, frame) -> None:
    raise Terminated


def _fail(message: str, status: int) -> None:
    """The one line on stderr (a message over several lines is joined) and the exit status."""
    line = " ".join(part.strip() for part in message.splitlines() if part.strip())
    print(f"gantry: error: {line}", file=sys.stderr)
    sys.exit(status)
