"""Views of results: the HTML report, figures, the diagnosis sections, the browser check."""
