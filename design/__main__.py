"""``python -m design`` runs the ``gantry`` command line."""

from design.cli import main

main()
