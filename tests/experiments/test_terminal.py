"""experiments.terminal: tables fit the width they are given (the terminal's, 100 columns
when not a terminal, never more than 120), cut text ends in "…", numbers are never cut."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from experiments import terminal

LONG = "die OGL-Methode [muss] qualitativ keinerlei Abstriche gegenüber den anderen Techniken " * 4


def _claims() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "item": ["Abb. 8 left, the OGL method's quality", "short"],
            "document": [LONG, "x"],
            "ours": ["queries 40.2 %, 0 false culls; " * 10, "1"],
            "verdict": ["trend", "numbers"],
            "basis": ["b" * 300, ""],
        }
    )


@pytest.mark.parametrize("columns", [40, 60, 80, 100, 120])
def test_a_table_of_long_text_fits_every_width(columns):
    text = terminal.table(_claims(), ["item", "document", "ours", "verdict"], columns_width=columns)
    lines = text.splitlines()
    assert max(map(len, lines)) <= columns, text
    assert "trend" in text and "numbers" in text  # the short column is never cut
    assert "…" in text  # the long cells were cut, not dropped
    assert lines[0].startswith("item") and set(lines[1]) <= {"-", " "}


def test_a_cell_wraps_onto_at_most_max_lines_and_the_last_is_cut():
    df = pd.DataFrame({"a": ["one two three four five six seven eight nine ten"]})
    lines = terminal.table(df, columns_width=10, max_lines=2).splitlines()[2:]
    assert len(lines) == 2 and lines[0] == "one two" and lines[1].endswith("…")
    lines = terminal.table(df, columns_width=10, max_lines={"a": 3}).splitlines()[2:]
    assert len(lines) == 3


def test_a_table_that_fits_is_left_as_it_is():
    df = pd.DataFrame({"name": ["a", "bb"], "n": [1, 22000], "x": [0.5, np.nan]})
    text = terminal.table(df, columns_width=100)
    assert text.splitlines() == [
        "name  n       x",
        "----  ------  ----",
        "a          1  0.50",
        "bb    22,000",
    ]


def test_numbers_are_right_aligned_and_never_cut_headers_wrap_instead():
    df = pd.DataFrame({f"quantity_number_{i}": [123456.789] for i in range(4)})
    text = terminal.table(df, columns_width=60)
    assert max(map(len, text.splitlines())) <= 60, text
    assert text.count("123,456.79") == 4
    assert "quantity" in text.splitlines()[0] and "…" not in text


def test_too_many_columns_print_in_blocks_each_led_by_the_first():
    df = pd.DataFrame({"run": ["queries 320x192"], **{f"col{i}": [1000.0 * i] for i in range(12)}})
    text = terminal.table(df, columns_width=50)
    blocks = text.split("\n\n")
    assert len(blocks) > 1 and all(b.startswith("run") for b in blocks)
    assert max(map(len, text.splitlines())) <= 50
    assert all(f"{1000.0 * i:,.2f}" in text for i in range(12))


def test_weights_give_a_column_more_of_the_width():
    df = _claims()[["document", "ours"]]
    plain = terminal.table(df, columns_width=80).splitlines()[1]
    ours_first = terminal.table(df, columns_width=80, weights={"ours": 3}).splitlines()[1]
    assert len(ours_first.split()[1]) > len(plain.split()[1])


def test_width_is_100_when_not_a_terminal_and_at_most_120(monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    assert terminal.width() == 100  # pytest captures stdout: not a terminal
    monkeypatch.setenv("COLUMNS", "80")
    assert terminal.width() == 80
    monkeypatch.setenv("COLUMNS", "300")
    assert terminal.width() == 120


def test_paragraph_wraps_long_messages_with_an_indent():
    text = terminal.paragraph("word " * 50, 30, indent="  ")
    lines = text.splitlines()
    assert max(map(len, lines)) <= 30 and all(line.startswith("  ") for line in lines[1:])
    assert terminal.cut("abcdef", 4) == "abc…" and terminal.cut("abc", 4) == "abc"
