"""The bibliography: every paper key that a docstring in ``src/`` cites (``laitoch2018 §3.5``,
``[laitoch2018]``, ``.. [1] laitoch2018, §3.5``, ``(mazzolini2012; han2006)``) has an entry in
``docs/references.bib``, and every entry is complete."""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIB = REPO / "docs" / "references.bib"
#: a citation key: a surname in lower case and a year (laitoch2018, efros2001, kwatra2003b)
KEY = re.compile(r"(?<![\w.-])([a-z]+(?:19|20)\d\d[a-z]?)(?![\w-])")
ENTRY = re.compile(r"^@(\w+)\{([^,\s]+),", re.MULTILINE)


def bib_entries() -> dict[str, str]:
    """Key -> the entry's text."""
    text = BIB.read_text(encoding="utf-8")
    starts = list(ENTRY.finditer(text))
    entries: dict[str, str] = {}
    for i, match in enumerate(starts):
        key = match.group(2)
        assert key not in entries, f"{key} is in references.bib twice"
        entries[key] = text[match.start() : starts[i + 1].start() if i + 1 < len(starts) else len(text)]
    return entries


def docstrings(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                yield getattr(node, "lineno", 1), doc


def cited_keys() -> dict[str, str]:
    """Key -> where it is first cited (``path:line``)."""
    cited: dict[str, str] = {}
    for path in sorted((REPO / "src" / "barkgen").rglob("*.py")):
        for line, doc in docstrings(path):
            for key in KEY.findall(doc):
                cited.setdefault(key, f"{path.relative_to(REPO)}:{line}")
    return cited


def test_the_key_pattern_finds_the_citation_forms():
    doc = (
        "Label maps (laitoch2018 §3.5, wang2003 §3.2); see [guingo2017].\n"
        ".. [1] mazzolini2012, §4.1 (the discrete solver of han2006).\n"
        ".. [2] lefebvre2006; kaspar2015 §5. Not keys: py311, float32, 2018, barkgen.v2019."
    )
    assert KEY.findall(doc) == [
        "laitoch2018",
        "wang2003",
        "guingo2017",
        "mazzolini2012",
        "han2006",
        "lefebvre2006",
        "kaspar2015",
    ]


def test_every_cited_key_is_in_the_bibliography():
    cited = cited_keys()
    assert {"laitoch2018", "mazzolini2012", "wang2003", "guingo2017", "sibbing2010"} <= set(cited)
    missing = {key: where for key, where in cited.items() if key not in bib_entries()}
    assert not missing, f"cited but not in docs/references.bib: {missing}"


def test_every_entry_has_author_title_year_and_a_venue():
    for key, entry in bib_entries().items():
        for field in ("author", "title", "year"):
            assert re.search(rf"^\s*{field}\s*=", entry, re.MULTILINE), f"{key}: no {field}"
        assert re.search(r"^\s*(journal|booktitle|school|institution)\s*=", entry, re.MULTILINE), f"{key}: no venue"
        year = re.search(r"year\s*=\s*\{(\d{4})\}", entry)
        assert year and re.search(r"(\d{4})[a-z]?$", key).group(1) == year.group(1), (
            f"{key}: the key's year is not the entry's"
        )
        assert entry.count("{") == entry.count("}"), f"{key}: unbalanced braces"
