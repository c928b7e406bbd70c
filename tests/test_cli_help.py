"""Every command's --help reads well at 80 columns (issue 26, item 4): its examples on lines
of their own, no line wider than the terminal, no docstring markup shown."""

from __future__ import annotations

import re

import pytest

from pendfmu.cli import SUBCOMMANDS, main

WIDTH = 80


def rendered(command: str, capsys, monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", str(WIDTH))
    with pytest.raises(SystemExit) as exit_:
        main([command, "--help"])
    assert exit_.value.code == 0
    return capsys.readouterr().out


@pytest.mark.parametrize("command", list(SUBCOMMANDS))
def test_help_fits_the_terminal_and_shows_no_markup(command, capsys, monkeypatch):
    text = rendered(command, capsys, monkeypatch)
    wide = [line for line in text.splitlines() if len(line) > WIDTH]
    assert wide == [], wide
    assert "``" not in text and not re.search(r"`[^`\s]+`", text), text


@pytest.mark.parametrize("command", list(SUBCOMMANDS))
def test_each_example_starts_its_own_line(command, capsys, monkeypatch):
    """An example (`pendfmu COMMAND ...`) of the docstring is a line of its own, never run
    into the prose or into the next example, as argparse's default formatter did."""
    import pendfmu.cli as cli

    text = rendered(command, capsys, monkeypatch)
    written = [line.strip() for line in (SUBCOMMANDS[command].__doc__ or "").splitlines()
               if line.startswith("    pendfmu ")]
    for example in written:
        assert any(line.strip() == example for line in text.splitlines()), example
    for line in text.splitlines():
        assert line.count(f"pendfmu {command} ") <= 1 or line.lstrip().startswith("usage"), line
    assert cli.HelpFormatter  # the commands' formatter


def test_the_formatter_keeps_examples_and_wraps_prose():
    from pendfmu.cli import HelpFormatter

    formatter = HelpFormatter("pendfmu", width=40)
    text = formatter._fill_text("Words ``marked`` and `quoted` wrap to the width of the terminal.\n\n"
                                "    pendfmu fit cart a.csv --out r.json\n    pendfmu fit all DIR --out r.json",
                                40, "")
    assert text.splitlines()[:2] == ["Words marked and quoted wrap to the", "width of the terminal."]
    assert "    pendfmu fit cart a.csv --out r.json\n    pendfmu fit all DIR --out r.json" in text
