"""Every help text of the command line reaches the terminal whole: rich reads square brackets as markup, so a
spec section such as ``[admittance]`` written without its escape would vanish from ``--help``."""

from rich.text import Text

from design.cli import _command


def _texts():
    group = _command()
    for name, command in group.commands.items():
        yield name, "help", command.help or ""
        for param in command.params:
            yield name, param.name, getattr(param, "help", None) or ""


def test_no_help_text_loses_a_bracketed_word_to_markup():
    lost = [(name, param, text) for name, param, text in _texts()
            if Text.from_markup(text).plain != text.replace("\\[", "[")]
    assert not lost, lost


def test_no_help_text_shows_restructured_text_quotes():
    # the commands' docstrings are the terminal's help: no ``literal`` quotes there
    quoted = [(name, param) for name, param, text in _texts() if "``" in text]
    assert not quoted, quoted
