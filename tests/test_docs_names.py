"""Docs that tell the truth: every path, module and command that the documentation names exists.

Read from the pages (``docs/**/*.md``, the README, ``CONTRIBUTING.md``, ``benchmarks/README.md``:
their inline code and code blocks) and from the docstrings under ``src/`` (module, class and
function docstrings):

- a **path** of the repository (``src/...``, ``tests/...``, ``benchmarks/...``, ``scripts/...``,
  ``docs/...``, ``examples/...``; a ``*`` or an all-capitals placeholder segment such as ``NAME``
  matches any name), and every file a layout tree (a code block whose first line is a folder,
  ``src/barkgen/``) places in a folder;
- a **module** or an attribute of one (``barkgen.synth``, ``barkgen.synth.texture_by_numbers``):
  the longest importable prefix is imported, the rest looked up as attributes;
- a **command** (``barkgen generate ... --tile``, a shell line of a code block or an inline code):
  the command and its sub-command exist in the Typer app (``barkgen.cli.app``), and so does every
  ``--flag`` given to it.

Names that only illustrate (a hypothetical option in a walk-through) are in :data:`ILLUSTRATIVE`.
"""

from __future__ import annotations

import ast
import functools
import importlib
import re
import shlex
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src" / "barkgen"
PAGES = sorted(
    [*(REPO / "docs").rglob("*.md"), REPO / "README.md", REPO / "CONTRIBUTING.md", REPO / "benchmarks" / "README.md"]
)

#: names that need not exist, each with its reason (keep it short): a name that illustrates, or
#: a folder made when something runs (matched as a prefix)
ILLUSTRATIVE: dict[str, str] = {
    "benchmarks/.cache/": "the benchmarks' cache of downloaded peers and data, made when they run",
    "barkgen.kernels": "a logger's name (logging.getLogger), not a module",
    "--grain": "the made-up option of the add-an-option walk-through (docs/development.md)",
}

FENCE = re.compile(r"^(?P<fence>`{3,}|~{3,})[^\n]*\n(?P<body>.*?)^(?P=fence)[ \t]*$", re.MULTILINE | re.DOTALL)
INLINE = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")
RST_INLINE = re.compile(r"``(.+?)``", re.DOTALL)
PATH = re.compile(r"(?<![\w./~$@-])((?:src|tests|benchmarks|scripts|docs|examples)/[\w./*-]*)")
MODULE = re.compile(r"(?<![\w./@-])(barkgen(?:\.[A-Za-z_]\w*)+)")
#: a placeholder segment of a path or a command (NAME, OUT, COMMAND, PHOTO.png's PHOTO)
PLACEHOLDER = re.compile(r"^[A-Z][A-Z0-9_]*$")
#: what ends a shell command on a line
SHELL_BREAK = re.compile(r"\s(?:&&|\|\||;|\||>|2>|&>|#)\s|\s#|;")
#: a line of a layout tree: indent, the entry (``synth/``, ``testing.py``), what it holds
TREE_LINE = re.compile(r"^(?P<indent> *)(?P<entry>[\w.-]+/?)(?:\s{2,}(?P<text>.*))?$")
PY_FILE = re.compile(r"(?<![\w./-])(_*[A-Za-z]\w*\.py)\b")


# -- reading the names ------------------------------------------------------------------------
def _line(text: str, offset: int) -> int:
    return text.count("\n", 0, offset) + 1


def page_code(text: str) -> Iterator[tuple[int, str, bool]]:
    """``(line, code, is_block)`` of every code block and inline code of a Markdown page."""
    spans = []
    for match in FENCE.finditer(text):
        spans.append((match.start(), match.end()))
        yield _line(text, match.start("body")), match.group("body"), True
    cursor = 0
    prose = []
    for start, end in spans + [(len(text), len(text))]:
        prose.append((cursor, text[cursor:start]))
        cursor = end
    for base, chunk in prose:
        chunk = chunk.replace("\\`", " `")  # (an escaped backtick in a table cell: code too)
        for match in INLINE.finditer(chunk):
            yield _line(text, base + match.start()), match.group(1), False


def docstrings(path: Path) -> Iterator[tuple[int, str]]:
    """``(line, docstring)`` of a module's, its classes' and its functions' docstrings."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                line = node.body[0].lineno if node.body else getattr(node, "lineno", 1)
                yield line, doc


def shell_commands(code: str) -> Iterator[tuple[int, list[str]]]:
    """``(line offset, arguments after barkgen)`` of every ``barkgen`` command run in ``code``
    (a shell block, or an inline code), continuation lines joined."""
    lines = code.replace("\\\n", " ").split("\n")
    for offset, line in enumerate(lines):
        for part in SHELL_BREAK.split(" " + line + " "):
            try:
                words = shlex.split(part)
            except ValueError:
                words = part.split()
            while words and (words[0] in ("$", "time", "sudo") or re.match(r"^\w+=", words[0])):
                words = words[1:]
            if words[:1] == ["nice"]:
                words = words[3:] if words[1:2] == ["-n"] else words[1:]
            if len(words) >= 3 and words[0].endswith(("python", "python3")) and words[1:3] == ["-m", "barkgen"]:
                words = words[2:]
            if words and (words[0] == "barkgen" or words[0].endswith("/barkgen")) and len(words) > 1:
                yield offset, words[1:]


def page_names(path: Path) -> Iterator[tuple[str, str, int]]:
    """``(kind, name, line)`` of every path, module and command a Markdown page names."""
    text = path.read_text(encoding="utf-8")
    for line, code, block in page_code(text):
        for match in PATH.finditer(code):
            yield "path", match.group(1), line + code.count("\n", 0, match.start())
        for match in MODULE.finditer(code):
            yield "module", match.group(1), line + code.count("\n", 0, match.start())
        for offset, words in shell_commands(code):
            yield "command", shlex.join(words), line + offset
        if block:
            yield from tree_files(code, line)


def tree_files(code: str, line: int) -> Iterator[tuple[str, str, int]]:
    """The files a layout tree places: a code block whose first line is a folder of the
    repository (``src/barkgen/``) and whose lines are ``  entry/   what it holds (file.py, ...)``;
    an entry is a path under the root (or the repository, unindented), a ``file.py`` in its text
    a file under the entry."""
    lines = code.splitlines()
    if not lines or not re.fullmatch(r"[\w./-]+/", lines[0].strip()) or not (REPO / lines[0].strip()).is_dir():
        return
    root = lines[0].strip()
    entry = root
    for number, text in enumerate(lines[1:], start=1):
        match = TREE_LINE.match(text)
        if (
            match
            and match.group("indent") in ("", "  ")
            and (match.group("text") or match.group("entry").endswith("/"))
        ):
            entry = (root if match.group("indent") else "") + match.group("entry")
            yield "path", entry, line + number
            described = match.group("text") or ""
        else:  # a line that goes on with the entry above
            described = text
        if entry.endswith("/"):
            for name in PY_FILE.findall(described):
                yield "path", f"{entry}**/{name}", line + number


def src_names(path: Path) -> Iterator[tuple[str, str, int]]:
    """``(kind, name, line)`` of every path and module a module's docstrings name, and every
    command of their inline code (````barkgen generate --tile````)."""
    for line, doc in docstrings(path):
        for match in PATH.finditer(doc):
            yield "path", match.group(1), line + doc.count("\n", 0, match.start())
        for match in MODULE.finditer(doc):
            yield "module", match.group(1), line + doc.count("\n", 0, match.start())
        for match in RST_INLINE.finditer(doc):
            for offset, words in shell_commands(match.group(1)):
                yield "command", shlex.join(words), line + doc.count("\n", 0, match.start()) + offset


# -- checking them ----------------------------------------------------------------------------
def path_exists(name: str) -> bool:
    name = name.rstrip(".,:;)")
    if not name:
        return True
    parts = ["*" if PLACEHOLDER.match(Path(p).stem) else p for p in name.split("/")]
    pattern = "/".join(p for p in parts if p)
    if "*" in pattern:
        return any(REPO.glob(pattern))
    return (REPO / pattern).exists()


def _has(owner, attribute: str) -> bool:
    """``owner.attribute`` exists, a dataclass's field without a default included."""
    if hasattr(owner, attribute):
        return True
    fields = getattr(owner, "__dataclass_fields__", {})
    return attribute in fields or any(
        attribute in getattr(c, "__annotations__", {}) for c in getattr(owner, "__mro__", ())
    )


@functools.cache
def module_exists(name: str) -> bool:
    parts = name.rstrip(".").split(".")
    if any(PLACEHOLDER.match(part) for part in parts):  # barkgen.NAME
        return True
    for cut in range(len(parts), 0, -1):
        try:
            found = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attribute in parts[cut:]:
            if not hasattr(found, attribute):
                try:  # a submodule not imported by its package
                    found = importlib.import_module(f"{found.__name__}.{attribute}")
                    continue
                except (ImportError, AttributeError, TypeError):
                    return _has(found, attribute) and attribute == parts[-1]
            found = getattr(found, attribute)
        return True
    return False


@functools.cache
def command_tree():
    import typer.main

    from barkgen.cli.app import app

    return typer.main.get_command(app)


def _flags(node) -> set[str]:
    flags = {"--help", "-h"}
    for param in node.params:
        flags.update(param.opts)
        flags.update(param.secondary_opts)
    return flags


def command_problem(words: list[str]) -> str | None:
    """None when ``barkgen WORDS`` names an existing command with existing flags."""
    node = command_tree()
    root_flags = _flags(node)
    words = [w for w in words if w not in ("...", "…")]
    while words and words[0].startswith("-"):
        flag = words.pop(0).split("=")[0]
        if flag not in root_flags:
            return f"barkgen has no option {flag}"
        if flag in ("--version", "--help", "-h"):
            return None
        if flag == "--max-pixels" and words and not words[0].startswith("-"):
            words.pop(0)
    path: list[str] = []
    while words and hasattr(node, "commands"):
        word = words[0]
        if word.startswith("-"):
            break
        if PLACEHOLDER.match(word) or word == "[OPTIONS]":
            return None  # barkgen COMMAND --help
        if "/" in word and not words[1:]:  # barkgen library add/list/show/rm: each of them
            missing = [w for w in word.split("/") if w not in node.commands]
            return f"barkgen {' '.join(path)} has no command {missing}" if missing else None
        if word not in node.commands:
            return f"barkgen {' '.join(path) + ' ' if path else ''}has no command {word!r}"
        node = node.commands[word]
        path.append(words.pop(0))
    if hasattr(node, "commands"):
        return None  # a group alone (its --help)
    flags = _flags(node)
    for word in words:
        if re.fullmatch(r"--?[A-Za-z][\w-]*(=.*)?", word):
            flag = word.split("=")[0]
            if flag not in flags and flag not in ILLUSTRATIVE:
                return f"barkgen {' '.join(path)} has no option {flag}"
    return None


def problems(names: Iterator[tuple[str, str, int]], where: Path) -> list[str]:
    found = []
    for kind, name, line in names:
        if any(name == known or (known.endswith("/") and name.startswith(known)) for known in ILLUSTRATIVE):
            continue
        if kind == "path":
            bad = None if path_exists(name) else f"no such path {name}"
        elif kind == "module":
            bad = None if module_exists(name) else f"no such module or attribute {name}"
        else:
            bad = command_problem(shlex.split(name))
        if bad:
            found.append(f"{where.relative_to(REPO)}:{line}: {bad}")
    return sorted(set(found), key=lambda s: (s.split(":")[0], int(s.split(":")[1])))


# -- the tests --------------------------------------------------------------------------------
def test_the_readers_find_what_the_pages_name():
    page = (
        "See `src/barkgen/synth/` and `barkgen.synth.texture_by_numbers`.\n\n"
        "```bash\n$ barkgen --max-pixels 100 generate photo.jpg -o out/ --tile \\\n  --seed 3 | head\n"
        "nice -n 10 .venv/bin/python -m barkgen bilayer synth m.npz --no-blend\n```\n"
        "```python\nimport barkgen\nfrom barkgen.io import read_image\n```\n"
    )
    found = [(kind, name) for line, code, block in page_code(page) for kind, name in _kinds(code)]
    assert ("path", "src/barkgen/synth/") in found
    assert ("module", "barkgen.synth.texture_by_numbers") in found
    assert ("module", "barkgen.io") in found
    commands = [shlex.split(name) for kind, name in found if kind == "command"]
    assert ["--max-pixels", "100", "generate", "photo.jpg", "-o", "out/", "--tile", "--seed", "3"] in commands
    assert ["bilayer", "synth", "m.npz", "--no-blend"] in commands
    assert all(words[0] not in ("import", "io") for words in commands)


def _kinds(code: str):
    for match in PATH.finditer(code):
        yield "path", match.group(1)
    for match in MODULE.finditer(code):
        yield "module", match.group(1)
    for _, words in shell_commands(code):
        yield "command", shlex.join(words)


def test_the_checks_tell_real_names_from_wrong_ones():
    assert path_exists("src/barkgen/pipeline/options.py") and path_exists("docs/benchmarks/NAME.md")
    assert not path_exists("src/barkgen/synth/api.py") and not path_exists("tests/test_options.py")
    assert module_exists("barkgen.synth.texture_by_numbers") and module_exists("barkgen.cli.app.app")
    assert not module_exists("barkgen.synth.engine_of_nothing")
    assert command_problem(["generate", "p.jpg", "-o", "out", "--tile", "--size", "64x64"]) is None
    assert command_problem(["bilayer", "synth", "m.npz", "--no-blend"]) is None
    assert command_problem(["COMMAND", "--help"]) is None
    assert "no command" in command_problem(["engine", "x"])
    assert "no option --no-such" in command_problem(["generate", "p.jpg", "--no-such"])
    tree = "```\nsrc/barkgen/\n  synth/      the solver (_solver.py), api.py\n  testing.py  cases\n```\n"
    names = {name for _, code, _ in page_code(tree) for _, name, _ in tree_files(code, 1)}
    assert {"src/barkgen/synth/", "src/barkgen/synth/**/_solver.py", "src/barkgen/synth/**/api.py"} <= names
    assert not path_exists("src/barkgen/synth/**/api.py")


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(REPO)))
def test_every_name_a_page_gives_exists(page):
    found = problems(page_names(page), page)
    assert not found, "\n".join(found)


@pytest.mark.parametrize(
    "package",
    sorted({p.relative_to(SRC).parts[0] if len(p.relative_to(SRC).parts) > 1 else "." for p in SRC.rglob("*.py")}),
)
def test_every_name_a_docstring_gives_exists(package):
    files = sorted((SRC / package).rglob("*.py")) if package != "." else sorted(SRC.glob("*.py"))
    found = [problem for path in files for problem in problems(src_names(path), path)]
    assert not found, "\n".join(found)
