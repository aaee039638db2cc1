"""Count the house at git revisions: modules, import arrows, floors, upward arrows, cycles and
the references to effect kinds outside the effects packages.

The house's floors are the layers of docs/architecture.md: the kernels (``emorbit.kernels``),
the model (the rest of ``emorbit``) and the tools (``emorbit.bench``, ``emorbit.sweep``,
``emorbit.cli``, ``emorbit.plot`` and ``emorbit.validation``). An arrow is one module importing
another of emorbit's (imports inside functions included, as :mod:`tests.test_house` reads them);
an upward arrow goes from a lower floor to a higher one (a kernel importing the model, the model
importing a tool). An effect-kind reference is a string literal equal to an effect kind, or an
identifier with a kind among its snake_case words, in a module outside ``emorbit/effects/``,
``emorbit/kernels/effects/`` and the tools (tests/test_house.py's rule).

Usage::

    python scripts/house_count.py c2083c8 HEAD

Each revision is read from git (``git archive``) into a temporary folder; the working tree is
not touched.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))

import test_house as house  # noqa: E402  (the graph and the kind rule the tests use)

#: the top floor: what the model may not import, and the plots
TOOLS = house.ABOVE_MODEL + ("emorbit.plot",)


def floor(module: str) -> int:
    """0 for the kernels, 2 for the tools, 1 for the model."""
    if house._within(module, ("emorbit.kernels",)):
        return 0
    return 2 if house._within(module, TOOLS) else 1


def count(rev: str) -> dict:
    """The house's figures at ``rev``."""
    with tempfile.TemporaryDirectory() as folder:
        archive = subprocess.run(["git", "archive", rev], cwd=REPO, capture_output=True, check=True).stdout
        tar = Path(folder) / "tree.tar"
        tar.write_bytes(archive)
        with tarfile.open(tar) as t:
            t.extractall(folder, filter="data")
        root = Path(folder)
        roots = {"emorbit": root / "emorbit"}
        if (root / "validation").is_dir():
            roots["emorbit.validation"] = root / "validation"
        mods = house.modules(roots)
        edges = house.internal_edges(house.imports(mods), mods)
        arrows = [(a, b) for a, targets in edges.items() for b in targets]
        kinds = house.effect_kinds(root / "emorbit" / "effects")
        refs, files = 0, 0
        for path in sorted((root / "emorbit").rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            if rel.startswith(house.EFFECT_HOMES + house.TOOLS):
                continue
            found = [
                f for f in house.named_kinds(ast.parse(path.read_text()), kinds) if f[1] not in house.SURFACE_PROPERTIES
            ]
            refs += len(found)
            files += bool(found)
        return {
            "modules": len(mods),
            "lines": sum(len(p.read_text().splitlines()) for p in mods.values()),
            "floors": len({floor(m) for m in mods}),
            "arrows": len(arrows),
            "upward arrows": sum(floor(a) < floor(b) for a, b in arrows),
            "cycles": len(house.cycles(edges)),
            "effect kinds": len(kinds),
            "kind references outside the effects": refs,
            "files with them": files,
        }


def main(argv: list[str]) -> int:
    revs = argv or ["HEAD"]
    rows = {rev: count(rev) for rev in revs}
    keys = list(next(iter(rows.values())))
    print(f"{'':40s}" + "".join(f"{rev:>12s}" for rev in revs))
    for key in keys:
        print(f"{key:40s}" + "".join(f"{rows[rev][key]:>12d}" for rev in revs))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
