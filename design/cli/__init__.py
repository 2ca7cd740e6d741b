"""The ``gantry`` command line: one thin module per command (parse, call the library, write), registered
here by name.

``main`` is the one error boundary: bad input becomes one line on stderr and exit status 2, Ctrl-C
exit status 130, and a genuine bug keeps its traceback.

Each command imports the library it runs inside its function, so that a command (and ``gantry --help``, a bad
argument, a Ctrl-C at start-up) pays only for its own: ``gantry --help`` 0.39 s wall, against 3.1 s for importing
the workflows, views, solvers and python-control together (measured on the 2-core machine).

May import: ``design.workflows``, ``design.views``, ``design.results``, ``design.admittance``, ``design.synth``,
``design.spec``, ``design.loop``, ``design.problem``, ``design.parallel``, ``plant``.
"""

from __future__ import annotations

import contextvars
import functools
import sys


def _register() -> None:
    """Register every command on the app, explicitly, once per process (``main`` may run many times in one)."""
    from design.cli import (
        coupling,
        diagnose,
        excite,
        export,
        fit,
        mouse_run,
        planar_run,
        planar_synth,
        report,
        reproduce,
        simulate,
        sweep,
        synth,
    )
    from design.cli.common import app

    commands = ((reproduce, "reproduce"), (simulate, "simulate"), (fit, "fit"), (diagnose, "diagnose"),
                (coupling, "coupling"), (excite, "excite"), (synth, "synth"), (sweep, "sweep"), (report, "report"),
                (mouse_run, "mouse-run"), (planar_run, "planar-run"), (planar_synth, "planar-synth"),
                (export, "export"))
    if [c.name for c in app.registered_commands] == [name for _, name in commands]:
        return
    app.registered_commands.clear()     # none, or a registration a Ctrl-C cut short
    for module, name in commands:
        app.command(name=name)(getattr(module, name.replace("-", "_")))


@functools.cache
def _command():
    """The app's click command, built once per process: typer builds it from the commands' signatures on every
    call, which costs tens of milliseconds each time ``main`` runs in one process (tests, scripts)."""
    import typer.main

    from design.cli.common import app

    _register()
    return typer.main.get_command(app)


def main() -> None:
    """Console entry point, the one error boundary: bad input (``GantryError``, usage errors, files that
    cannot be read or written, not enough memory) is one line on stderr and exit status 2; Ctrl-C is
    exit status 130 and SIGTERM 143, wherever they land (imports included, and also when a library
    swallowed the exception: ``plant.host.interrupts``); anything else is a bug, shown with its traceback and
    a request to report it. The command runs in a copy of the caller's context: a Ctrl-C that lands inside a
    library's context manager (numpy's ``errstate`` between setting its state and its ``with`` block) cannot
    leave that state behind for an in-process caller."""
    try:
        from design.parallel import one_blas_thread

        one_blas_thread()
        from plant.host import interrupts
        previous = interrupts.install()
    except KeyboardInterrupt:      # before the handlers (SIGTERM's default action ends the process quietly)
        _fail("interrupted", 130)
    sys.stderr = _SilentAfterStop(sys.stderr)
    try:
        _quiet_cvxpy_after_a_stop()
        code = contextvars.copy_context().run(_run)   # a library's context state ends with the command
        _stop_if_requested()
        if code == 130:
            _fail("interrupted", 130)
        sys.stdout.flush()
    except BrokenPipeError:     # the reader went away (gantry ... | head): end as a program SIGPIPE ends, quietly
        _stdout_to_devnull()
        sys.exit(128 + 13)
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    except interrupts.Terminated:
        _fail("terminated", 143)
    finally:        # called in-process (tests, scripts): the caller's handlers and stderr back, no stop pending
        interrupts.uninstall(previous)
        sys.stderr = sys.stderr.stream if isinstance(sys.stderr, _SilentAfterStop) else sys.stderr
    sys.exit(code if isinstance(code, int) else 0)


def entry() -> None:
    """The program's entry (the ``gantry`` script, ``python -m design``): ``main``, and once a signal has stopped
    it, out at once with its status, past the interpreter's finalization: a solver's own threads may still hold
    Python state then, and clean-up at exit has ended the process with a fatal error instead of the documented
    status (once in CI, SIGINT 2 s into a synthesis). The one line is written and the outputs committed or
    removed before this point; in-process callers use ``main``."""
    import os

    try:
        main()
    except SystemExit as stop:
        if stop.code in (130, 143):
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except (OSError, ValueError):      # a closed pipe: nothing more can be said anyway
                    pass
            os._exit(stop.code)
        raise


def _run():
    """Parse and run the command; expected failures end in ``_fail``."""
    import os

    import typer

    from plant.errors import GantryError

    try:    # typer >= 0.20 carries its own click
        from typer._click.exceptions import ClickException, NoArgsIsHelpError
    except ImportError:     # pragma: no cover
        from click.exceptions import ClickException, NoArgsIsHelpError

    os.environ["MPLBACKEND"] = "Agg"    # files only, never a window; read when matplotlib is first imported
    if "matplotlib" in sys.modules:      # already imported (a caller in the same process)
        sys.modules["matplotlib"].use("Agg")
    from plant.host.memory import keep_freed_memory

    keep_freed_memory()

    try:
        return _command()(standalone_mode=False)     # Ctrl-C inside a command comes back as exit code 130
    except typer.Abort:
        _fail("interrupted", 130)
    except GantryError as exc:
        _stop_if_requested()
        _fail(str(exc), 2)
    except NoArgsIsHelpError as exc:     # the help (rich prints it itself and leaves the message empty)
        if exc.format_message().strip():
            print(exc.format_message())
        _fail("no command given (gantry --help lists the commands)", exc.exit_code)
    except ClickException as exc:
        _fail(f"{exc.format_message()} (gantry --help lists the commands; gantry COMMAND --help their options)",
              exc.exit_code)
    except BrokenPipeError:
        raise
    except MemoryError:
        _fail("not enough memory for this input; use fewer payloads, samples, frequencies or a shorter duration", 2)
    except OSError as exc:
        _stop_if_requested()
        where = f"{exc.filename}: " if exc.filename else ""
        _fail(f"{where}{exc.strerror or exc}", 2)
    except Exception:
        _stop_if_requested()        # a solver that turned Ctrl-C into its own failure
        import traceback

        traceback.print_exc()
        _fail("this is a bug in gantry, not a problem with your input: please report it with the traceback above", 1)


def _stdout_to_devnull() -> None:
    """Standard output to /dev/null, so that the interpreter's final flush has nowhere to fail."""
    import os

    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _quiet_cvxpy_after_a_stop() -> None:
    """No cvxpy warning once a stop was requested: a Ctrl-C that lands while cvxpy probes its solvers makes
    one fail to import, which it would report on stderr beside the one line."""
    import logging

    logging.getLogger("__cvxpy__").addFilter(_no_stop_requested)     # one filter however often main() runs


def _no_stop_requested(record) -> bool:
    from plant.host.interrupts import requested

    return requested() is None


def _stop_if_requested() -> None:
    """Exit 130 (Ctrl-C) or 143 (SIGTERM) when one was received, even if a library swallowed it."""
    from plant.host.interrupts import requested

    kind = requested()
    if kind is not None:
        _fail("interrupted" if kind == "interrupt" else "terminated", 130 if kind == "interrupt" else 143)


class _SilentAfterStop:
    """Standard error that passes nothing on once Ctrl-C or SIGTERM was requested: a library that catches the
    interrupt reports it itself (casadi's IPOPT callback prints a KeyboardInterruptException warning), and the
    one line of ``_fail`` is all the user should see."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> int:
        from plant.host.interrupts import requested

        return len(text) if requested() is not None else self.stream.write(text)

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


def _fail(message: str, status: int) -> None:
    """The one line on stderr (a message over several lines is joined) and the exit status."""
    line = " ".join(part.strip() for part in message.splitlines() if part.strip())
    stream = sys.stderr.stream if isinstance(sys.stderr, _SilentAfterStop) else sys.stderr
    print(f"gantry: error: {line}", file=stream)
    sys.exit(status)
