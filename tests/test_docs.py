"""The documentation says what the code does: README's examples run, the scene keys and the
benchmark tables on the site are generated from the parser and from the recorded run, the
HDF5 page names what a run file holds, the architecture page names every module, and the
site builds with ``mkdocs build --strict`` (which fails on a broken link)."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from test_house import history_lines, modules

from emorbit.bodies.coupled import Structure
from emorbit.bodies.pointmasses import PointMasses
from emorbit.bodies.rigid import GRAVITY_MODELS, RigidBodies
from emorbit.bodies.rigid_input import SHAPE_PARAMETERS
from emorbit.errors import InputError
from emorbit.integrators import METHODS
from emorbit.scene import BODY_KINDS, KEYS, SCHEMA, list_scenes, load_scene, parse_scene

REPO = Path(__file__).resolve().parent.parent
DOCS = REPO / "docs"
README = (REPO / "README.md").read_text(encoding="utf-8")


def _script(name: str):
    """A generator script of scripts/, imported as a module."""
    spec = importlib.util.spec_from_file_location(name, REPO / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _page(name: str) -> str:
    return (DOCS / name).read_text(encoding="utf-8")


def _blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", text, re.S)


def _section(text: str, heading: str) -> str:
    """The text under ``heading`` up to the next heading of the same level."""
    level = heading.split(" ", 1)[0]
    start = text.index(heading + "\n")
    rest = text[start + len(heading) + 1 :]
    end = re.search(rf"^{level} ", rest, re.M)
    return rest[: end.start()] if end else rest


# -- the scenes page ---------------------------------------------------------------------
def test_scenes_page_lists_exactly_the_keys_the_parser_accepts():
    gen = _script("docs_scene_keys")
    page = _page("scenes.md")
    region = page.split(gen.BEGIN, 1)[1].split(gen.END, 1)[0]
    titles = {title: table for table, title in gen.TITLES.items()}
    found, required = {}, {}
    for part in region.split("\n### ")[1:]:
        title, body = part.split("\n", 1)
        table = titles[title.strip()]
        found[table] = re.findall(r"^\| `([a-z_0-9]+)` \|", body, re.M)
        required[table] = re.findall(r"^\| `([a-z_0-9]+)` \| yes \|", body, re.M)
    assert list(found) == list(SCHEMA)
    for table, keys in SCHEMA.items():
        assert found[table] == list(keys), table
        assert required[table] == [k for k, req in keys.items() if req], table


def test_scenes_page_is_generated_from_the_parser():
    gen = _script("docs_scene_keys")
    page = _page("scenes.md")
    assert gen.render(page) == page, "run: python scripts/docs_scene_keys.py"


def test_scene_keys_agree_with_the_bodies():
    """What KEYS says about shapes, meshes and gravity models is what the bodies accept."""
    from emorbit.bodies.meshes import MESH_KINDS, mesh_from_parameters

    keys = {table: {k.name: k for k in ks} for table, ks in KEYS.items()}
    rigid = keys["body.rigid"]
    assert [f'"{s}"' for s in SHAPE_PARAMETERS] == rigid["shape"].allowed.split(", ")
    for name, key in rigid.items():
        takers = tuple(s for s, params in SHAPE_PARAMETERS.items() if name in params)
        assert key.applies == takers, name
    assert rigid["gravity"].allowed == ", ".join(f'"{g}"' for g in GRAVITY_MODELS)
    elastic = keys["body.elastic"]
    assert elastic["mesh"].allowed == ", ".join(f'"{m}"' for m in MESH_KINDS)
    for name, key in elastic.items():
        for mesh in MESH_KINDS:
            if mesh in key.applies or not key.applies:
                continue
            with pytest.raises(InputError, match="not a parameter of mesh"):
                mesh_from_parameters(mesh, {name: 1}, True, "body[0]")
    for mesh in MESH_KINDS:  # every mesh parameter is documented as one
        for name in ("size", "elements", "start", "end", "file", "mesh_unit"):
            if mesh in elastic[name].applies:
                try:
                    mesh_from_parameters(mesh, {name: "nowhere.h5"}, True, "body[0]")
                except InputError as exc:
                    assert "not a parameter" not in str(exc), (mesh, name)
    assert keys["body.point"]["kind"].allowed == ", ".join(f'"{k}"' for k in BODY_KINDS)


def test_every_shipped_scene_is_on_the_scenes_page():
    page = _page("scenes.md")
    for name in list_scenes():
        assert f"| `{name}` |" in page, name


def test_scenes_page_names_every_rigid_shape():
    from emorbit.bodies.shapes import SHAPES

    section = _section(_page("scenes.md"), "## A rigid body")
    (comment,) = re.findall(r'^shape = "box" +# (.*)$', section, re.M)
    assert comment.split(" | ") == list(SHAPES)
    shapes = " ".join(section[section.index("Shapes: ") :].split("\n\n")[0].split())
    assert [name for name in SHAPES if f"`{name}` (" not in shapes] == []


def test_the_elastic_example_is_the_shipped_boom_scene():
    """The scenes page's bus-and-boom example is complete: the shipped scene that
    tests/test_elastic.py runs."""
    (block,) = _blocks(_section(_page("scenes.md"), "## An elastic body"), "toml")
    assert parse_scene(block).data == load_scene("satellite-flexible-boom").data


def test_the_nadir_pointing_recipe_stays_nadir_pointing():
    """The recipe's body keeps its x axis on the direction to the centre over one orbit:
    within 1.3e-10 rad (measured), checked to 1e-9 rad; it turns at n = sqrt(GM / a^3)."""
    import numpy as np

    from emorbit.bodies.rotations import quaternion_to_matrix

    rigid = _section(_page("scenes.md"), "## A rigid body")
    (block,) = _blocks(_section(rigid, "### A nadir-pointing start"), "toml")
    scene = parse_scene(block)
    sim = scene.build()
    n = float(scene.data["body"][0]["angular_velocity"][2].split()[0])
    assert n == pytest.approx(np.sqrt(sim.gm / 7e6**3), rel=1e-15)
    res = sim.run(t_end=scene.t_end, every=1, progress=False).si
    assert res.time[-1] >= 2 * np.pi / n  # one orbit
    x = res.positions["sat"]
    axis = np.array([quaternion_to_matrix(q)[:, 0] for q in res.attitudes["sat"]])
    off = np.linalg.norm(np.cross(axis, -x / np.linalg.norm(x, axis=1)[:, None]), axis=1)  # sin of the angle
    assert off.max() < 1e-9 and np.all(np.einsum("ij,ij->i", axis, x) < 0)


def test_no_page_says_bodies_feel_only_the_field():
    """Point masses feel the effects a scene names, and with ``mutual`` every body attracts
    every other: no page may say otherwise."""
    stale = ("the field and nothing else", "bodies do not attract each other.", "and bodies do not attract")
    for path in [REPO / "README.md", *sorted(DOCS.glob("*.md"))]:
        text = " ".join(path.read_text(encoding="utf-8").split())
        assert not [phrase for phrase in stale if phrase in text], path.name
    scenes = " ".join(_page("scenes.md").split())
    assert 'with `kind = "mutual"` every body attracts every other' in scenes


def test_complete_scenes_and_sweeps_on_the_pages_parse():
    from emorbit.sweep import parse_sweep

    count = 0
    for path in sorted(DOCS.glob("*.md")):
        for block in _blocks(path.read_text(encoding="utf-8"), "toml"):
            if block.lstrip().startswith("[sweep]"):
                parse_sweep(block, str(REPO / "sweep.toml"))
                count += 1
            elif "[integrator]" in block:
                parse_scene(block)
                count += 1
    assert count >= 3


# -- README ---------------------------------------------------------------------------------
def test_readme_has_the_two_commands():
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    test_command = (
        'python3 -m venv .venv && .venv/bin/pip install -e ".[test]"'
        " && .venv/bin/python -m pytest -n auto --dist loadfile && .venv/bin/python scripts/mutants.py"
    )
    assert test_command in ci and f"    {test_command}\n" in README
    assert f"    {test_command}\n" in _page("getting-started.md")  # the same command on the site
    assert "    python3 -m venv .venv && .venv/bin/pip install . && .venv/bin/emorbit run paper-ellipse" in README
    assert len(README.splitlines()) <= 200


def test_readme_script_runs(tmp_path, monkeypatch, capsys):
    (code,) = _blocks(README, "python")
    assert len(code.strip().splitlines()) <= 15
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    energy, a, a_unit, newton, t_end, t_unit = capsys.readouterr().out.split()  # Quantities print their unit
    assert float(energy) < 1e-12
    assert abs(float(a) - 6.0000135) < 1e-4 and a_unit == "m"
    assert float(newton) > 0
    assert abs(float(t_end) - 100 * 46.4758) < 1e-6 and t_unit == "s"


def test_readme_scene_runs(tmp_path):
    (text,) = _blocks(README, "toml")
    assert len(text.strip().splitlines()) <= 15
    scene = parse_scene(text)
    result = scene.build().run(t_end=scene.t_end, every=100, output=tmp_path / "paper.h5")
    assert abs(result.relative_energy_error()).max() < 1e-12
    paper = load_scene("paper-ellipse")
    assert scene.dt == paper.dt and scene.t_end == paper.t_end


def test_readme_methods_table_is_what_the_code_says():
    """Methods x body kinds: a body kind runs a method where its system has a kernel for it;
    "conserves" is the Method's own list."""
    systems = {"point masses": PointMasses, "rigid bodies": RigidBodies, "elastic bodies": Structure}
    for text in (README, _page("index.md")):
        rows = re.findall(r"^\| `(\w+)` \| (.+) \|$", text, re.M)
        table = {m: [c.strip() for c in cells.split("|")] for m, cells in rows if m in METHODS}
        assert list(table) == list(METHODS)
        for method, cells in table.items():
            for cell, system in zip(cells, systems.values()):
                assert (cell == "yes") == (method in system.METHODS), (method, cell)
            said = cells[-1]
            assert ("energy" in said) == ("energy" in METHODS[method].conserves), method
            assert ("angular momentum" in said) == ("angular_momentum" in METHODS[method].conserves), method


# -- the benchmarks page ------------------------------------------------------------------
def test_benchmark_tables_are_generated_from_the_recorded_run():
    gen = _script("docs_bench_table")
    with open(gen.JSON) as f:
        data = json.load(f)
    page = _page("benchmarks.md")
    assert gen.render(page, data) == page, "run: python scripts/docs_bench_table.py"
    assert data.get("date") and data["machine"]["cpu"] and data["load_average"]["before"]
    for figure in data.get("work_precision", {}).get("figures", []):
        assert (DOCS / "data" / Path(figure).name).is_file(), figure


def test_benchmark_targets_on_the_page_are_the_runners():
    from emorbit.bench.runner import TARGETS

    rows = _section(_page("benchmarks.md"), "## Targets")
    shown = {
        "ensemble_vs_rebound": ("em on all threads", ">= {:g}x"),
        "scene_vs_bare": ("a point-mass scene", ">= {:g}x"),
        "single_vs_rebound": ("em on one orbit", "<= {:g}x"),
        "warm_startup_s": ("warm-cache", "<= {:g} s"),
    }
    assert set(shown) == set(TARGETS)
    for name, limit in TARGETS.items():
        what, form = shown[name]
        (row,) = [r for r in rows.splitlines() if r.startswith(f"| {what}")]
        assert row.endswith(f"| {form.format(100 * limit if '%' in form else limit)} |"), (name, row)


# -- the HDF5 page ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def run_files(tmp_path_factory):
    """A short run file of each kind of system: free points, free rigid bodies, a structure
    with bars and rigid bodies, a structure with tetrahedra."""
    folder = tmp_path_factory.mktemp("layout")
    out = []
    for name, t_end in (
        ("paper-ellipse", "4.64758 s"),
        ("rigid-box-paper-ellipse", "4.64758 s"),
        ("tethered-satellites", "40 s"),
        ("elastic-bar-tumbling", "0.2 s"),
    ):
        scene = load_scene(name).with_overrides(t_end=t_end)
        path = folder / f"{name}.h5"
        scene.build().run(t_end=scene.t_end, every=scene.output_every, output=path, keep=False)
        out.append(path)
    return out


def test_hdf5_page_names_every_dataset_and_attribute(run_files):
    page = _page("hdf5.md")
    named = set(re.findall(r"`([^`\s]+)`", page))
    missing = set()
    for path in run_files:
        with h5py.File(path, "r") as f:
            bodies = set(f["bodies"])

            def visit(name, obj, bodies=bodies):
                parts = name.split("/")
                if parts[0] == "bodies" and len(parts) > 1 and parts[1] in bodies:
                    parts[1] = "<name>"
                shown = "/".join(parts)
                if isinstance(obj, h5py.Dataset):
                    if parts[0] in ("checkpoint", "final_state"):
                        shown = "/".join(parts[1:])  # the state arrays: <system>/<array>
                    else:
                        shown = "/" + shown
                        assert obj.attrs.get("unit") is not None, name
                    if shown not in named:
                        missing.add(shown)
                for attr in obj.attrs:
                    if attr not in named and attr != "unit":
                        missing.add(f"{name}@{attr}")

            f.visititems(visit)
            missing.update(f"/@{a}" for a in f.attrs if a not in named)
    assert not missing, f"not on docs/hdf5.md: {sorted(missing)}"


def test_hdf5_page_units_are_the_files(run_files):
    rows = dict(re.findall(r"^\| `(/[^`]+)` \| [^|]+ \| ([^|]+?) \|", _page("hdf5.md"), re.M))
    for path in run_files:
        with h5py.File(path, "r") as f:
            for name in ("time", "invariants/energy", "invariants/momentum", "invariants/angular_momentum"):
                assert rows[f"/{name}"] == f[name].attrs["unit"], name
            for body, g in f["bodies"].items():
                for q, ds in g.items():
                    if isinstance(ds, h5py.Dataset):
                        assert rows[f"/bodies/<name>/{q}"] == ds.attrs["unit"], (body, q)


# -- the architecture page --------------------------------------------------------------------
def test_architecture_tree_names_every_module():
    (tree,) = _blocks(_section(_page("architecture.md"), "## The tree"), "text")
    listed, stack = set(), []
    for line in tree.splitlines():
        m = re.match(r"^( *)(\S+)", line)
        depth = len(m.group(1)) // 2
        stack[depth:] = [m.group(2)]
        if m.group(2).endswith(".py"):
            listed.add("".join(stack))
    files = {str(path.relative_to(REPO)) for path in modules().values()}
    assert listed == files, {"not on the page": sorted(files - listed), "not in the tree": sorted(listed - files)}


# -- every page -----------------------------------------------------------------------------------
def test_docs_say_what_is_true_now():
    """No dates, sessions, internal issue numbers or commit hashes; the benchmark run's date
    is its own record."""
    found = {}
    for path in [REPO / "README.md", *sorted(DOCS.rglob("*.md"))]:
        text = path.read_text(encoding="utf-8")
        text = re.sub(r"^\| date \(UTC\) \|.*$", "", text, flags=re.M)
        if lines := history_lines(text):
            found[str(path.relative_to(REPO))] = lines
    assert not found, found


def _mkdocs(config: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(config), "--site-dir", str(site)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )


#: the HTML elements a page may hold without attributes; any other bare <name> was text
#: that Markdown passed through as a tag (``invariants/work_<label>``)
HTML_ELEMENTS = set(
    "a abbr article aside b blockquote body br caption code dd del details div dl dt em figcaption figure footer "
    "h1 h2 h3 h4 h5 h6 head header hr html i img ins kbd li main mark nav ol p pre s script section small span "
    "strong style sub summary sup table tbody td tfoot th thead title tr tt u ul".split()
)


def site_defects(site: Path) -> list[str]:
    """What the built pages show where their source was not Markdown: an RST literal block's
    ``::`` left in a paragraph, a pipe's escape shown as ``\\|``, text read as an HTML tag."""
    found = []
    for page in sorted(site.rglob("*.html")):
        text = page.read_text(encoding="utf-8")
        where = page.relative_to(site)
        found += [f"{where}: '::' ends a paragraph" for _ in re.finditer(r"::</p>", text)]
        found += [f"{where}: {m.group(0)!r} shows its backslash" for m in re.finditer(r".{0,30}\\\|", text)]
        found += [
            f"{where}: {m.group(0)!r} became a tag"
            for m in re.finditer(r".{0,30}<([A-Za-z_][\w-]*)>", text)
            if m.group(1).lower() not in HTML_ELEMENTS
        ]
    return found


def test_site_builds_in_strict_mode(tmp_path):
    """The site builds, and its pages show no Markdown left unconverted (:func:`site_defects`):
    the effects page's formulas are code blocks, its tables' pipes plain, its <label> text."""
    done = _mkdocs(REPO / "mkdocs.yml", tmp_path / "site")
    assert done.returncode == 0, done.stderr[-4000:]
    assert (tmp_path / "site" / "api" / "emorbit" / "index.html").is_file()
    assert "emorbit.Simulation.run" in (tmp_path / "site" / "api" / "emorbit" / "index.html").read_text()
    assert site_defects(tmp_path / "site") == []
    effects = (tmp_path / "site" / "effects" / "index.html").read_text(encoding="utf-8")
    assert "invariants/work_&lt;label&gt;" in effects and "<code>V = -GM m / r, r = |x - c|</code>" in effects
    assert re.search(r"<pre>.*V = \(GM m / r\) sum_\{n=2\}\^\{N\}", effects)


def test_the_effects_page_carries_no_rst():
    """scripts/docs_effects.py writes Markdown: an RST literal block (``::`` and its indented
    lines) as a code block, pipes in code spans as they are, ``<label>`` in code or escaped."""
    page = _script("docs_effects").markdown()
    assert not [line for line in page.splitlines() if line.rstrip().endswith("::")]
    for formula in ("V = (GM m / r) sum_{n=2}^{N} J_n (R / r)^n P_n(z / r)", "F_ij = -G m_i m_j (d0 + d1)"):
        assert f"```text\n{formula}" in page, formula
    assert not [span for span in re.findall(r"`[^`]*`", page) if "\\|" in span]
    outside = re.sub(r"`[^`]*`", "", page)
    assert "<label>" not in outside and "`invariants/work_<label>`" in page


def test_strict_build_fails_on_a_broken_link(tmp_path):
    """The site's own configuration (inherited) turns a link to a missing page into an error."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# x\n\nSee [the missing page](missing.md) and [an anchor](#nowhere).\n")
    config = tmp_path / "mkdocs.yml"
    config.write_text(f"INHERIT: {REPO / 'mkdocs.yml'}\ndocs_dir: docs\nnav:\n  - index.md\n")
    done = _mkdocs(config, tmp_path / "site")
    assert done.returncode != 0
    assert "missing.md" in done.stderr
