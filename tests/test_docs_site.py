"""The documentation site and the project's Markdown files: the CLI reference (``cli.md``, made
from the Typer app as the site is built, ``scripts/mkdocs_hooks.py``) holds every command and
option; the Python API page documents every public name of ``barkgen``; every
relative link of the README, CONTRIBUTING, CHANGELOG, benchmarks/README and ``docs/`` resolves
to a file of the project (and its anchor to a heading), and none leaves the project."""

from __future__ import annotations

import importlib.util
import re
import unicodedata
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
PAGES = sorted(
    [
        REPO / "README.md",
        REPO / "CONTRIBUTING.md",
        REPO / "CHANGELOG.md",
        REPO / "benchmarks" / "README.md",
        REPO / "examples" / "README.md",
        *DOCS.rglob("*.md"),
    ]
)
#: [text](target) and ![alt](target), the target up to a space or the closing parenthesis
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.MULTILINE | re.DOTALL)
CODE = re.compile(r"(`+)(?:(?!\1).)+?\1", re.DOTALL)


def cli_reference():
    spec = importlib.util.spec_from_file_location("cli_reference", REPO / "scripts" / "cli_reference.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def prose(text: str) -> str:
    """The text without fenced code blocks and inline code (links there are not links)."""
    return CODE.sub("", FENCE.sub("", text))


def slug(heading: str) -> str:
    """A heading's anchor as MkDocs' toc (and, for these headings, GitHub) makes it."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).replace("`", "")
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


#: the page the site's build makes (scripts/mkdocs_hooks.py): no file in the repository
GENERATED = DOCS / "cli.md"


def generated_anchors() -> set[str]:
    return anchors_of(cli_reference().render())


def anchors(path: Path) -> set[str]:
    return anchors_of(path.read_text(encoding="utf-8"))


def anchors_of(markdown: str) -> set[str]:
    text = FENCE.sub("", markdown)
    return {slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*#*\s*$", text, re.MULTILINE)}


def links(path: Path) -> list[str]:
    return LINK.findall(prose(path.read_text(encoding="utf-8")))


def test_the_pages_are_there():
    names = {p.relative_to(REPO).as_posix() for p in PAGES}
    assert {
        "README.md",
        "CONTRIBUTING.md",
        "CHANGELOG.md",
        "benchmarks/README.md",
        "docs/index.md",
        "docs/api.md",
        "docs/getting-started.md",
        "docs/how-it-works.md",
        "docs/development.md",
        "docs/benchmarks/index.md",
    } <= names
    for script in sorted((REPO / "benchmarks").glob("bench_*.py")):
        assert script.name in (DOCS / "benchmarks" / "index.md").read_text(encoding="utf-8"), script.name
        assert script.name in (REPO / "benchmarks" / "README.md").read_text(encoding="utf-8"), script.name


def test_the_link_pattern_finds_links_and_skips_code():
    text = (
        'See [a](docs/a.md), ![pic](images/p.jpg "t") and [b](../c.md#x).\n`[not](a link)`\n```\n[nor](this.md)\n```\n'
    )
    assert LINK.findall(prose(text)) == ["docs/a.md", "images/p.jpg", "../c.md#x"]


def test_the_site_makes_the_cli_reference_from_the_app_and_keeps_no_copy():
    """A new option needs no regenerated page: the build's hook makes ``cli.md`` (replacing a
    stale local copy), and git keeps none."""
    import subprocess

    from mkdocs.config.defaults import MkDocsConfig
    from mkdocs.structure.files import File, Files

    spec = importlib.util.spec_from_file_location("mkdocs_hooks", REPO / "scripts" / "mkdocs_hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    config = MkDocsConfig()
    config.load_dict({"site_name": "t", "docs_dir": str(DOCS), "site_dir": "/tmp/unused"})
    stale = File("cli.md", str(DOCS), "/tmp/unused", False)
    files = hooks.on_files(Files([stale]), config)
    page = files.get_file_from_path("cli.md")
    assert page is not stale and page.content_string == cli_reference().render()
    tracked = subprocess.run(["git", "ls-files", "docs/cli.md"], cwd=REPO, capture_output=True, text=True)
    assert tracked.returncode != 0 or tracked.stdout.strip() == ""


def test_cli_reference_has_every_command_and_option():
    import typer.main

    from barkgen.cli.app import app

    module = cli_reference()
    page = module.render()
    root = typer.main.get_command(app)
    click = module._click(root)

    def walk(command, ctx):
        yield command, ctx
        if hasattr(command, "list_commands"):
            for name in command.list_commands(ctx):
                sub = command.get_command(ctx, name)
                yield from walk(sub, click.Context(sub, info_name=name, parent=ctx))

    seen = 0
    for command, ctx in walk(root, click.Context(root, info_name="barkgen")):
        assert f"`{ctx.command_path}`" in page, ctx.command_path
        for param in command.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is not None:
                assert f"`{record[0]}`" in page, (ctx.command_path, record[0])
        seen += 1
    assert seen >= 25  # 14 commands, 3 groups and their sub-commands


def lazy_names() -> dict[str, str]:
    """Public name -> module, from ``barkgen/__init__.pyi`` (the one list of public names)."""
    import barkgen

    return barkgen._LAZY


def test_api_page_documents_every_public_name():
    page = (DOCS / "api.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"^::: ([\w.]+)\s*$", page, re.MULTILINE))
    missing = {f"{module}.{name}" for name, module in lazy_names().items()} - documented
    assert not missing, f"docs/api.md lacks ::: lines for {sorted(missing)}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(REPO).as_posix())
def test_every_relative_link_resolves(page):
    broken = []
    for target in links(page):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        path_part, _, anchor = target.partition("#")
        dest = (page.parent / path_part).resolve() if path_part else page
        if REPO not in dest.parents and dest != REPO:
            broken.append(f"{target} (outside the project)")
        elif dest == GENERATED and anchor and anchor not in generated_anchors():
            broken.append(f"{target} (no heading #{anchor})")
        elif dest == GENERATED:
            continue
        elif not dest.exists():
            broken.append(f"{target} (no such file)")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target} (no heading #{anchor})")
    assert not broken, f"{page.relative_to(REPO)}: {broken}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(REPO).as_posix())
def test_nothing_points_outside_the_project(page):
    text = page.read_text(encoding="utf-8")
    assert "../shared" not in text, f"{page.relative_to(REPO)} points to ../shared"


def test_readme_is_short_and_keeps_the_set_up_commands():
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 200
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    assert "bash scripts/test.sh" in ci
    assert re.search(r"^bash scripts/test\.sh\s", readme, re.MULTILINE)  # the command .ci/run runs
    assert re.search(r"^bash scripts/quickstart\.sh\s", readme, re.MULTILINE)
    assert "docs/images/" in readme  # one picture
