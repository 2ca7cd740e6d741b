"""``python -m design`` runs the ``gantry`` command line.

May import: ``design.cli``."""

try:
    from design.cli import entry
except KeyboardInterrupt:       # Ctrl-C while the entry module itself loads, before main's handlers
    import sys

    sys.stderr.write("gantry: error: interrupted\n")
    sys.exit(130)

try:
    entry()
finally:
    # CPython records a KeyboardInterrupt that escaped any string passed to exec or eval (dataclasses and
    # namedtuple build their methods that way while modules import) and, under ``python -m``, ends the
    # process with SIGINT instead of main's exit status even though main handled it; evaluating a string
    # that completes clears that record.
    exec("")
