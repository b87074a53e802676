"""The guides (``docs/guide/``) are written for the artists who read them: each opens with its
task, one command to copy and the picture it makes, then the options that matter most (a table
of flag, default, what it changes in the picture and when to change it), then troubleshooting.
Every ``--flag`` of an options table exists in the ``--help`` of the command it belongs to: the
command of the nearest heading above the table that names one (``## Texture-by-numbers
(`barkgen tbn`)``), else the guide's opening command."""

from __future__ import annotations

import functools
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
GUIDE = REPO / "docs" / "guide"
#: the guides written to this shape (evaluate.md has its own)
GUIDES = (
    "generate.md",
    "material.md",
    "flow.md",
    "tree.md",
    "batch.md",
    "bilayer.md",
    "branches.md",
    "web.md",
    "inputs-outputs.md",
)
#: the opening command block starts within this many lines of the top
OPENING_LINES = 12
FENCE = re.compile(r"^```[a-z]*\n(.*?)^```", re.MULTILINE | re.DOTALL)
#: ``barkgen [global options] command [sub-command]`` as a shell line or inline code names it
COMMAND = re.compile(r"\bbarkgen(?:\s+--[\w-]+(?:\s+\d+)?)*\s+([a-z][\w-]*)(?:\s+([a-z][\w-]*))?")
FLAG = re.compile(r"(?<![\w-])(--[a-z][\w-]*|-[a-z])\b")


@functools.cache
def command_tree():
    import typer.main

    from barkgen.cli.app import app

    return typer.main.get_command(app)


def command_path(words: tuple[str, ...]) -> tuple[str, ...]:
    """The longest prefix of ``words`` that is a command of the app (``("bilayer", "synth")``)."""
    root = command_tree()
    path: list[str] = []
    node = root
    for word in words:
        if word is None or not hasattr(node, "commands") or word not in node.commands:
            break
        node = node.commands[word]
        path.append(word)
    return tuple(path)


def help_flags(path: tuple[str, ...]) -> set[str]:
    """Every option string (``--size``, ``-o``, ``--no-blend``) of ``barkgen PATH --help``."""
    node = command_tree()
    for word in path:
        node = node.commands[word]
    flags: set[str] = set()
    for param in node.params:
        flags.update(param.opts)
        flags.update(param.secondary_opts)
    return flags


def named_command(text: str) -> tuple[str, ...] | None:
    """The command named in ``text`` (a heading, a shell line), or None."""
    for match in COMMAND.finditer(text):
        path = command_path((match.group(1), match.group(2)))
        if path:
            return path
    return None


def opening(text: str) -> tuple[int, str]:
    """Line number and body of the guide's first fenced code block."""
    match = FENCE.search(text)
    assert match, "no code block"
    return text[: match.start()].count("\n") + 1, match.group(1)


def option_tables(text: str):
    """``(command path, [flag cells])`` of every table whose first header cell is ``flag``; the
    command is the nearest heading's above the table that names one, else the opening's."""
    _, body = opening(text)
    first = named_command(body)
    current = first
    table: list[str] | None = None
    lines = FENCE.sub("", text).splitlines()
    for line in lines + [""]:
        if line.startswith("#"):
            current = named_command(line) or first
        if line.startswith("|"):
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            if table is None:
                table = ["header", cells[0]]
            else:
                table.append(cells[0])
            continue
        if table is not None:
            if table[1].lower() == "flag":
                yield current, [cell for cell in table[2:] if not set(cell) <= set("-: ")]
            table = None


def test_the_command_pattern_finds_commands_and_sub_commands():
    assert named_command("barkgen generate my.jpg -o out/") == ("generate",)
    assert named_command("## Synthesis (`barkgen bilayer synth`)") == ("bilayer", "synth")
    assert named_command("barkgen --max-pixels 100 tbn a.png") == ("tbn",)
    assert named_command("# Bark for a whole tree") is None
    assert {"--size", "-o", "--tile"} <= help_flags(("generate",))
    assert "--no-blend" in help_flags(("bilayer", "synth"))


@pytest.mark.parametrize("name", GUIDES)
def test_a_guide_opens_with_one_command_and_its_picture(name):
    text = (GUIDE / name).read_text(encoding="utf-8")
    line, body = opening(text)
    assert line <= OPENING_LINES, f"{name}: its first command block starts at line {line}"
    commands = [row for row in body.splitlines() if row.strip() and not row.lstrip().startswith("#")]
    assert len(commands) == 1, f"{name}: the opening block holds {len(commands)} commands, not one"
    assert named_command(commands[0]), f"{name}: the opening block is no barkgen command: {commands[0]!r}"
    picture = re.search(r"!\[[^\]]*\]\((\.\./images/[^)\s]+)\)", text)
    assert picture and text.index(picture.group(0)) < text.index("## "), f"{name}: no picture before its sections"
    assert (GUIDE / picture.group(1)).resolve().is_file(), picture.group(1)


@pytest.mark.parametrize("name", GUIDES)
def test_a_guide_has_an_options_table_and_troubleshooting(name):
    text = (GUIDE / name).read_text(encoding="utf-8")
    tables = list(option_tables(text))
    assert tables, f"{name}: no options table (| flag | default | ... |)"
    headings = re.findall(r"^## (.+)$", text, re.MULTILINE)
    assert "Troubleshooting" in headings, f"{name}: no ## Troubleshooting"
    assert headings.index("Troubleshooting") <= 2, f"{name}: troubleshooting comes after the options"
    header = re.search(r"^\|\s*symptom\s*\|\s*cause\s*\|\s*what to do\s*\|", text, re.MULTILINE)
    assert header, f"{name}: troubleshooting is no symptom | cause | what to do table"
    assert "../how-it-works.md" in text, f"{name}: no link to How it works"


@pytest.mark.parametrize("name", GUIDES)
def test_every_flag_in_a_guides_tables_is_in_its_commands_help(name):
    text = (GUIDE / name).read_text(encoding="utf-8")
    unknown = []
    for path, cells in option_tables(text):
        assert path, f"{name}: an options table with no command (no barkgen command above it)"
        flags = help_flags(path)
        for cell in cells:
            named = FLAG.findall(cell)
            assert named, f"{name}: the flag cell {cell!r} names no flag"
            unknown += [f"barkgen {' '.join(path)} {flag}" for flag in named if flag not in flags]
    assert not unknown, f"{name}: not in --help: {unknown}"
