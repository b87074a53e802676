"""The house's layout rules: no import circles, no import that
runs back up from io or an algorithm package to a front end, the pipeline or the package face
(imports inside functions count, and ``from barkgen.synth import _kernels`` counts as an import
of ``barkgen.synth``), and no module, function or kernel grows past its limit beyond the ones
still listed here to be split."""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
FRONT_ENDS = ("barkgen.cli", "barkgen.web", "barkgen.batch")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 120
MAX_KERNEL_PARAMETERS = 12

#: still to be split (the architecture issue); the lists may only shrink
LONG_MODULES: set[str] = set()
LONG_FUNCTIONS: set[str] = set()
WIDE_KERNELS: set[str] = set()


def modules() -> dict[str, Path]:
    found = {}
    for path in (SRC / "barkgen").rglob("*.py"):
        name = ".".join(path.relative_to(SRC).with_suffix("").parts)
        found[name.removesuffix(".__init__")] = path
    return found


def import_graph(mods: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the barkgen modules it imports anywhere in its body."""
    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                # `import a.b.c as K` binds the submodule: an import of a.b.c alone
                targets.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(parts + ([node.module] if node.module else []))
                targets.add(base)  # `from pkg import x` runs and reads pkg's face
                targets.update(f"{base}.{alias.name}" for alias in node.names)
        edges = set()
        for target in targets:
            while target not in mods and "." in target:
                target = target.rpartition(".")[0]
            if target in mods and target != name and target.startswith("barkgen"):
                edges.add(target)
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return found


def test_no_import_circles():
    assert cycles(import_graph(modules())) == []


def test_the_checker_sees_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(graph) == [["a", "b", "c"]]


def test_no_import_runs_back_up():
    upward = []
    for name, targets in import_graph(modules()).items():
        if name == "barkgen" or name.startswith(FRONT_ENDS + ("barkgen.pipeline", "barkgen.__main__")):
            continue
        upward += [(name, t) for t in targets if t == "barkgen" or t.startswith(FRONT_ENDS + ("barkgen.pipeline",))]
    assert upward == []


def function_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """A function's lines from its ``def`` to its end, its docstring aside (numpydoc docstrings
    are long by design; the code is what must stay short)."""
    lines = node.end_lineno - node.lineno + 1
    first = node.body[0]
    if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def test_no_new_long_module_function_or_wide_kernel():
    long_modules, long_functions, wide_kernels = set(), set(), set()
    for name, path in modules().items():
        text = path.read_text()
        if len(text.splitlines()) > MAX_MODULE_LINES and "_kernels" not in path.name:
            long_modules.add(name)
        for node in ast.walk(ast.parse(text)):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            if function_lines(node) > MAX_FUNCTION_LINES:
                long_functions.add(f"{name}.{node.name}")
            args = node.args
            if "_kernels" in path.name and len(args.posonlyargs + args.args + args.kwonlyargs) > MAX_KERNEL_PARAMETERS:
                wide_kernels.add(f"{name}.{node.name}")
    assert long_modules <= LONG_MODULES, long_modules - LONG_MODULES
    assert long_functions <= LONG_FUNCTIONS, long_functions - LONG_FUNCTIONS
    assert wide_kernels <= WIDE_KERNELS, wide_kernels - WIDE_KERNELS


def test_no_test_imports_a_benchmark():
    """Tests import barkgen (its helpers for tests live in :mod:`barkgen.testing`), never the
    scripts of ``benchmarks/``."""
    bench = {p.stem for p in (SRC.parent / "benchmarks").glob("*.py")}
    found = []
    for path in (SRC.parent / "tests").rglob("*.py"):
        text = path.read_text()
        if path.name != "test_layout.py" and "benchmarks" in text and "sys.path." in text:
            found.append((path.name, "sys.path"))
        for node in ast.walk(ast.parse(text)):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            found += [(path.name, n) for n in names if n.split(".")[0] in bench | {"benchmarks"}]
    assert found == []


def test_other_packages_reach_synth_through_its_face():
    """Every other package (the label-map engine :mod:`barkgen.shapes` driving the solver, the
    pipeline, the front ends, material, branching) reaches :mod:`barkgen.synth` only through
    its face, ``barkgen.synth`` itself, never into its modules or its wings (``seams``,
    ``guides``)."""
    graph = import_graph(modules())
    reach = {
        (name, t)
        for name, targets in graph.items()
        if name != "barkgen.synth" and not name.startswith("barkgen.synth.")
        for t in targets
        if t.startswith("barkgen.synth")
    }
    assert ("barkgen.shapes.engine", "barkgen.synth") in reach
    assert all(t == "barkgen.synth" for _, t in reach), sorted(t for t in reach if t[1] != "barkgen.synth")


def test_synth_has_one_face():
    """Inside :mod:`barkgen.synth`, only the package's ``__init__`` is public: the solver's
    core modules are private (``_name.py``) and the rest lives in the wings ``seams`` and
    ``guides``, whose faces import nothing (so no core module runs the package's face)."""
    synth = SRC / "barkgen" / "synth"
    public = sorted(p.name for p in synth.glob("*.py") if not p.name.startswith("_"))
    assert public == []
    wings = sorted(p.name for p in synth.iterdir() if (p / "__init__.py").is_file())
    assert wings == ["guides", "seams"]
    for wing in wings:
        tree = ast.parse((synth / wing / "__init__.py").read_text())
        assert not [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom))], wing


#: house-wide checks, at the top of tests/
HOUSE_TESTS = {
    "test_layout.py",
    "test_extras.py",
    "test_examples.py",
    "test_docs.py",
    "test_docs_site.py",
    "test_docs_names.py",
    "test_docs_guides.py",
    "test_wheel.py",
}


def test_tests_mirror_the_packages():
    """A package's tests live in ``tests/PACKAGE/``; only the house-wide checks sit at the top."""
    tests = SRC.parent / "tests"
    packages = {p.name for p in (SRC / "barkgen").iterdir() if (p / "__init__.py").is_file()}
    misplaced = [
        str(p.relative_to(tests))
        for p in tests.rglob("test_*.py")
        if not (p.parent == tests and p.name in HOUSE_TESTS)
        and not (p.parent.parent == tests and p.parent.name in packages)
    ]
    assert misplaced == []


def test_the_public_names_are_one_list_seen_by_type_checkers_too():
    """The public names are listed once, in ``barkgen/__init__.pyi`` (type checkers and IDEs
    read it), and ``barkgen/__init__.py`` imports each of them lazily from it: the stub's
    ``__all__`` is every name it imports, each name resolves, and the package says it is typed.
    (Two hand-kept lists drifted once: make_material, MaterialSet, HeightEditor, render_trunk
    and trunk_mesh were invisible to type checkers.)"""
    import barkgen

    init = Path(barkgen.__file__)
    stub = ast.parse((init.parent / "__init__.pyi").read_text())
    imported = {
        alias.asname or alias.name for node in stub.body if isinstance(node, ast.ImportFrom) for alias in node.names
    }
    listed = next(
        ast.literal_eval(node.value)
        for node in stub.body
        if isinstance(node, ast.Assign) and node.targets[0].id == "__all__"
    )
    assert sorted(listed) == sorted(imported) == sorted(barkgen.__all__)
    for name in barkgen.__all__:
        assert getattr(barkgen, name) is not None, name
    assert (init.parent / "py.typed").is_file()


#: private top-level modules every package may use (the shared helpers, the version)
SHARED_PRIVATE = ("barkgen._shared", "barkgen._version")


def private_imports_across_packages(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(importer, private module) pairs where a package imports another package's private
    module (one whose dotted path has a part starting with ``_``, e.g. ``barkgen.synth._kernels``
    or ``barkgen.cli._common``)."""
    found = []
    for name, targets in graph.items():
        own = ".".join(name.split(".")[:2])
        for target in targets:
            parts = target.split(".")
            if target.startswith(SHARED_PRIVATE) or not any(p.startswith("_") for p in parts[1:]):
                continue
            if ".".join(parts[:2]) != own:
                found.append((name, target))
    return sorted(found)


def test_no_package_imports_another_packages_private_module():
    assert private_imports_across_packages(import_graph(modules())) == []
    # the check finds one when there is one
    assert private_imports_across_packages(
        {
            "barkgen.cli.synth": {"barkgen.synth._kernels"},
            "barkgen.synth.solver": {"barkgen.synth._kernels", "barkgen._shared.arrays"},
        }
    ) == [("barkgen.cli.synth", "barkgen.synth._kernels")]
