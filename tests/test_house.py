"""The house rules of the source tree: layers, no import cycles, sizes, docs that say what is
true now, lint, and a distribution that installs nothing but ``emorbit``.

The import graph is built from the source with :mod:`ast` (every ``import`` statement,
those inside functions included), so it needs no import of the package and sees
``emorbit.validation``, which lives in the repository's ``validation/`` folder.
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
#: package name -> folder: emorbit, and validation/ installed as emorbit.validation
ROOTS = {"emorbit": REPO / "emorbit", "emorbit.validation": REPO / "validation"}
#: the most lines a module of emorbit (validation included) may have
MAX_MODULE_LINES = 800
#: the most lines a kernel module's docstring may have
MAX_KERNEL_DOCSTRING_LINES = 40
#: the most lines README.md may have
MAX_README_LINES = 200
#: what a kernel may import from outside the standard library
KERNEL_THIRD_PARTY = {"numpy", "numba", "llvmlite"}
#: the model: what it must not import
MODEL = ("emorbit.bodies", "emorbit.scene", "emorbit.simulation", "emorbit.io")
ABOVE_MODEL = ("emorbit.bench", "emorbit.validation", "emorbit.sweep", "emorbit.cli")


def modules(roots: dict[str, Path] = ROOTS) -> dict[str, Path]:
    """{dotted module name: file} of every module under ``roots``."""
    out = {}
    for package, folder in roots.items():
        for path in sorted(folder.rglob("*.py")):
            rel = path.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            name = ".".join([package, *parts])
            if name in out:  # emorbit.validation is both a folder of emorbit/ (none) and validation/
                raise AssertionError(f"{name} is defined twice")
            out[name] = path
    return out


def _resolve(name: str, module: str, is_package: bool, level: int) -> str:
    """The absolute name of a relative import ``from <level dots><name>`` inside ``module``."""
    if level == 0:
        return name
    base = module.split(".")
    if not is_package:
        base = base[:-1]
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def imports(mods: dict[str, Path]) -> dict[str, set[str]]:
    """{module: the names it imports}, absolute, in functions too; ``from X import y`` gives
    ``X.y`` where that is a module, else ``X``."""
    graph = {}
    for name, path in mods.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        is_package = path.name == "__init__.py"
        found = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                target = _resolve(node.module or "", name, is_package, node.level)
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    found.add(sub if sub in mods else target)
        graph[name] = found
    return graph


def internal_edges(graph: dict[str, set[str]], mods) -> dict[str, set[str]]:
    """The graph restricted to emorbit's own modules (an import of a.b.c where only a.b is a
    module counts as an import of a.b)."""
    out = {}
    for src, targets in graph.items():
        edges = set()
        for t in targets:
            while t and t not in mods:
                t = t.rpartition(".")[0]
            if t and t != src:
                edges.add(t)
        out[src] = edges
    return out


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def _within(name: str, packages) -> bool:
    return any(name == p or name.startswith(p + ".") for p in packages)


def layer_violations(graph: dict[str, set[str]]) -> list[str]:
    """Imports that break the layers (docs/architecture.md): a kernel importing anything but
    the standard library, numpy, numba, llvmlite and emorbit.kernels; the model importing
    bench, validation, sweep or cli."""
    stdlib = set(sys.stdlib_module_names)
    bad = []
    for src, targets in graph.items():
        for t in sorted(targets):
            top = t.split(".")[0]
            if _within(src, ("emorbit.kernels",)):
                if top == "emorbit" and not _within(t, ("emorbit.kernels",)):
                    bad.append(f"{src} imports {t}")
                elif top not in stdlib and top not in KERNEL_THIRD_PARTY and top not in ("__future__", "emorbit"):
                    bad.append(f"{src} imports {t}")
            if _within(src, MODEL) and _within(t, ABOVE_MODEL):
                bad.append(f"{src} imports {t}")
    return bad


def test_the_graph_sees_every_module_and_its_imports():
    mods = modules()
    assert "emorbit.validation.cli" in mods and "emorbit.kernels.pointmass.packed" in mods
    edges = internal_edges(imports(mods), mods)
    assert "emorbit.simulation" in edges["emorbit.scene"]  # a top-level import
    assert "emorbit.bodies.rigid" in edges["emorbit.assembly"]  # an import inside a method
    assert "emorbit.kernels.eft" in edges["emorbit.kernels.pointmass.cuda"]  # from .. import eft


def test_no_import_cycle():
    mods = modules()
    found = cycles(internal_edges(imports(mods), mods))
    assert not found, f"import cycles among emorbit's modules: {found}"


def test_cycles_and_layer_breaks_are_found(tmp_path):
    """The checks above fail on a tree that breaks them."""
    pkg = tmp_path / "emorbit"
    (pkg / "kernels").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernels" / "__init__.py").write_text("")
    (pkg / "kernels" / "k.py").write_text("import astropy.units\nfrom ..errors import InputError\n")
    (pkg / "errors.py").write_text("")
    (pkg / "scene.py").write_text("def f():\n    from .simulation import x\n")
    (pkg / "simulation.py").write_text("from .scene import f\nfrom .cli import main\n")
    (pkg / "cli.py").write_text("")
    mods = modules({"emorbit": pkg})
    graph = imports(mods)
    assert cycles(internal_edges(graph, mods)) == [["emorbit.scene", "emorbit.simulation"]]
    assert sorted(layer_violations(graph)) == [
        "emorbit.kernels.k imports astropy.units",
        "emorbit.kernels.k imports emorbit.errors",
        "emorbit.simulation imports emorbit.cli",
    ]


def test_layers_hold():
    assert not layer_violations(imports(modules()))


def test_import_contracts():
    """import-linter's contracts in pyproject.toml (the same layers, as users of the tool see them)."""
    exe = shutil.which("lint-imports", path=os.path.dirname(sys.executable)) or shutil.which("lint-imports")
    assert exe, "lint-imports (import-linter) is part of the test extra"
    done = subprocess.run([exe, "--no-cache"], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]


@pytest.mark.parametrize("name", sorted(modules()))
def test_module_is_not_too_long(name):
    lines = len(modules()[name].read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_MODULE_LINES, f"{name}: {lines} lines (at most {MAX_MODULE_LINES}); split it by job"


def test_kernel_docstrings_are_short():
    long = {}
    for name, path in modules().items():
        if _within(name, ("emorbit.kernels",)):
            doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
            assert doc, f"{name} has no module docstring"
            if len(doc.splitlines()) > MAX_KERNEL_DOCSTRING_LINES:
                long[name] = len(doc.splitlines())
    assert not long, f"kernel module docstrings over {MAX_KERNEL_DOCSTRING_LINES} lines: {long}"


def test_readme_is_short():
    lines = len((REPO / "README.md").read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_README_LINES, f"README.md has {lines} lines; the rest belongs in docs/"


#: what an account of earlier work looks like in a source file: a date, a session, an
#: internal issue number, a commit hash named as such
HISTORY = [
    (re.compile(r"\b20\d\d-[01]\d-[0-3]\d\b"), "a date"),
    (re.compile(r"\bsessions?\b", re.I), "a session"),
    (re.compile(r"\bissues?\s*#?\d+", re.I), "an internal issue number"),
    (re.compile(r"\bcommits?\s+[0-9a-f]{7,40}\b", re.I), "a commit hash"),
    (re.compile(r"\b(?:at|since|before|after)\s+[0-9a-f]{7,12}\b(?=[\s,.;:)])"), "a commit hash"),
]


def history_lines(text: str) -> list[str]:
    """'line N: <what>' for each line of ``text`` that reads like an account of earlier work."""
    out = []
    for i, line in enumerate(text.splitlines(), 1):
        for pattern, what in HISTORY:
            if pattern.search(line):
                out.append(f"line {i}: {what}: {line.strip()[:100]}")
    return out


def test_history_patterns_are_found():
    text = "measured 2026-11-23\nthis session found\nas issue 4 asks\nsince commit 58e838c\nat 68bc302, 4.15 ns\n"
    assert len(history_lines(text)) == 5
    assert not history_lines("g_em = GM / (r0 r1) (r0 + r1); 2**-53; 0x7ff8000000000000; dt = T/100\n")


def test_no_history_in_source():
    """Docstrings and comments say what is true now; git keeps the history."""
    files = [p for p in modules().values()] + [REPO / "validation" / "README.md"]
    found = {str(p.relative_to(REPO)): h for p in files if (h := history_lines(p.read_text(encoding="utf-8")))}
    assert not found, f"accounts of earlier work in the source: {found}"


def _tool(name: str) -> str:
    exe = shutil.which(name, path=os.path.dirname(sys.executable)) or shutil.which(name)
    assert exe, f"{name} is part of the test extra"
    return exe


def test_ruff_lint_and_format():
    ruff = _tool("ruff")
    paths = ["emorbit", "validation", "tests", "scripts"]
    lint = subprocess.run([ruff, "check", "--no-cache", *paths], cwd=REPO, capture_output=True, text=True, timeout=300)
    assert lint.returncode == 0, lint.stdout[-3000:]
    fmt = subprocess.run(
        [ruff, "format", "--check", "--no-cache", *paths], cwd=REPO, capture_output=True, text=True, timeout=300
    )
    assert fmt.returncode == 0, fmt.stdout[-3000:]


def test_distribution_installs_only_emorbit(tmp_path):
    """``pip install .`` puts ``emorbit`` (validation as ``emorbit.validation``, the scenes
    beside it) and its metadata into site-packages, and no top-level ``validation``."""
    # from a copy of the sources, so that no build/ folder left by an earlier build adds files
    src = tmp_path / "src"
    for part in ("emorbit", "validation"):
        shutil.copytree(REPO / part, src / part, ignore=shutil.ignore_patterns("__pycache__", "*.nb[ic]"))
    for part in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / part, src / part)
    done = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(src)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    (wheel,) = tmp_path.glob("emorbit-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"emorbit"}, tops
    assert "emorbit/validation/cli.py" in names and "emorbit/scenes/paper-ellipse.toml" in names
    packaged = {n[: -len(".py")].replace("/", ".").removesuffix(".__init__") for n in names if n.endswith(".py")}
    assert packaged == set(modules()), set(modules()) ^ packaged
    licenses = [n for n in names if ".dist-info/" in n and n.rsplit("/", 1)[-1].startswith("LICENSE")]
    assert licenses and b"MIT License" in zipfile.ZipFile(wheel).read(licenses[0]), names


def test_validate_runs_beside_a_file_named_validation(tmp_path):
    """A validation.py in the working folder does not shadow the validation suite."""
    (tmp_path / "validation.py").write_text("raise SystemExit('the wrong validation module was imported')\n")
    script = Path(sys.executable).with_name("emorbit")
    for argv in ([sys.executable, "-m", "emorbit.cli", "validate", "--list"], [str(script), "validate", "--list"]):
        done = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        assert "paper" in done.stdout


#: the folders whose modules may name an effect kind: the effects themselves and their kernels
EFFECT_HOMES = ("emorbit/effects/", "emorbit/kernels/effects/")
#: a body's surface material: every facet carries it, whichever effects read it (it is the
#: body's, like its mass, and the scene names it on the body or the facet)
SURFACE_PROPERTIES = {"drag_coefficient"}
#: the tools above the model (they build scenes that name effects, as users do)
TOOLS = ("emorbit/bench/", "emorbit/sweep/", "emorbit/cli.py", "emorbit/plot.py")


def effect_kinds(folder: Path = REPO / "emorbit" / "effects") -> set[str]:
    """The shipped effects' kinds (central aside: the field is the model's own): every ``NAME =
    "..."`` in the effects' modules (in their classes; in older trees, at module level)."""
    kinds = set()
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "NAME" for t in node.targets)
                and isinstance(node.value, ast.Constant)
                and isinstance(node.value.value, str)
            ):
                kinds.add(node.value.value)
    return kinds - {"central", ""}


def named_kinds(tree: ast.AST, kinds: set[str]) -> list[tuple[int, str]]:
    """(line, what) of every string literal (docstrings aside) equal to an effect kind, and of
    every identifier that has a kind among the words of its snake_case name."""
    docstrings = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                docstrings.add(id(body[0].value))

    def names_a_kind(name: str) -> bool:
        words = f"_{name.lower()}_"
        return any(f"_{kind}_" in words for kind in kinds)

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            if node.value.lower() in kinds:
                found.append((node.lineno, node.value))
        name = node.id if isinstance(node, ast.Name) else node.attr if isinstance(node, ast.Attribute) else None
        if name is None and isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            name = node.name
        if name is not None and names_a_kind(name):
            found.append((node.lineno, name))
    return sorted(found)


def test_no_module_outside_the_effects_names_an_effect_kind():
    """An effect is one declaration: the model and the kernels name no effect kind (no
    ``"zonal"``, no ``drag_p``, no ``mutual`` attribute); only emorbit/effects/ and
    emorbit/kernels/effects/ do, and the tools that build scenes as users do."""
    kinds = effect_kinds()
    assert kinds >= {"zonal", "mutual", "drag", "srp", "third_body"}
    bad = []
    for path in modules({"emorbit": REPO / "emorbit"}).values():
        rel = path.relative_to(REPO).as_posix()
        if rel.startswith(EFFECT_HOMES) or rel.startswith(TOOLS):
            continue
        found = named_kinds(ast.parse(path.read_text()), kinds)
        bad += [f"{rel}:{line}: {what}" for line, what in found if what not in SURFACE_PROPERTIES]
    assert not bad, "modules outside the effects name effect kinds:\n" + "\n".join(bad)


def test_the_effect_kind_check_finds_names():
    source = (
        'x = "zonal"\nself.drag = 1\ndef f():\n    """drag in a docstring"""\n'
        '    return mutual_p + third_body_mass + dragon + "the drag of air"\n'
    )
    found = [what for _, what in named_kinds(ast.parse(source), {"zonal", "drag", "mutual", "third_body"})]
    assert found == ["zonal", "drag", "mutual_p", "third_body_mass"]


def probes(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, name) of every ``getattr(self, "name", default)``: a class asking whether its host
    (or itself) has an attribute, instead of declaring it."""
    found = []
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "hasattr")
            and node.args
            and isinstance(node.args[0], ast.Name)
            and node.args[0].id == "self"
            and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)
            and (node.func.id == "hasattr" or len(node.args) == 3)
        ):
            found.append((node.lineno, node.args[1].value))
    return found


def test_no_class_probes_itself_or_its_host_for_an_attribute():
    """A mixin that probes its host with getattr is a sign the job is in the wrong class: every
    attribute a class reads is declared (in __init__ or as a class attribute)."""
    assert probes(
        ast.parse('getattr(self, "x", 0)\nhasattr(self, "y")\ngetattr(self, name)\ngetattr(o, "z", 1)\n')
    ) == [
        (1, "x"),
        (2, "y"),
    ]
    bad = []
    for path in modules({"emorbit": REPO / "emorbit"}).values():
        rel = path.relative_to(REPO).as_posix()
        bad += [f"{rel}:{line}: {name}" for line, name in probes(ast.parse(path.read_text()))]
    assert not bad, "probes of self for an attribute:\n" + "\n".join(bad)


def test_every_mutant_still_finds_its_code():
    """Each mutant of scripts/mutants.py changes text that occurs exactly once in its file: a
    refactoring that moves the code it breaks must move the mutant with it."""
    import importlib.util
    import sys

    spec = importlib.util.spec_from_file_location("emorbit_mutants", REPO / "scripts" / "mutants.py")
    mutants = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mutants  # its dataclass looks its module up
    spec.loader.exec_module(mutants)
    stale = [
        f"{m.name}: {m.path} holds its text {n} times"
        for m in mutants.MUTANTS
        if (n := (REPO / m.path).read_text().count(m.old) if (REPO / m.path).is_file() else 0) != 1
    ]
    assert not stale, "\n".join(stale)


def test_house_count_reads_a_revision_as_the_tests_read_the_tree():
    """scripts/house_count.py (the closing notes' counts) sees this tree's house as the tests
    above do: three floors, no upward arrow, no cycle, no effect kind named outside the effects."""
    if subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True).returncode:
        pytest.skip("not a git checkout")
    sys.path.insert(0, str(REPO / "scripts"))
    try:
        import house_count
    finally:
        sys.path.remove(str(REPO / "scripts"))
    got = house_count.count("HEAD")
    assert got["modules"] >= 150 and got["arrows"] > got["modules"]
    assert (got["floors"], got["upward arrows"], got["cycles"]) == (3, 0, 0)
    assert got["effect kinds"] >= 5 and got["kind references outside the effects"] == 0
