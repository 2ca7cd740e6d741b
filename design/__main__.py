"""``python -m design`` runs the ``gantry`` command line."""

from design.cli import main

try:
    main()
finally:
    # CPython records a KeyboardInterrupt that escaped any string passed to exec or eval (dataclasses and
    # namedtuple build their methods that way while modules import) and, under ``python -m``, ends the
    # process with SIGINT instead of main's exit status even though main handled it; evaluating a string
    # that completes clears that record.
    exec("")
