"""Views of results: the HTML report, figures, the diagnosis sections, the browser check.

May import: ``design.results``, ``design.admittance``, ``design.synth``, ``design.spec``, ``design.loop``,
``design.problem``, ``design.parallel``, ``plant``."""
