"""The ``gantry`` command line: one thin module per command (parse, call the library, write), registered
here by name.

Bad input (any ``GantryError``) becomes one line on stderr and exit status 2.
"""

from __future__ import annotations

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
    """Console entry point: ``GantryError`` -> one line on stderr, exit status 2."""
    import matplotlib

    matplotlib.use("Agg")
    from design.cli.common import app

    _register()
    try:
        app()
    except GantryError as exc:
        print(f"gantry: error: {exc}", file=sys.stderr)
        sys.exit(2)
