"""The core's layout, read from its source: one package per pipeline stage, imports that follow the
pipeline (no cycles; the scene model imports no ray code; the ray layer imports no meshing code;
the helpers import no stage), every package saying its one job, and the README's knob table made
from the knob table."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from core.settings import knob_table

CORE = Path(__file__).resolve().parents[2] / "core"
README = CORE.parent / "README.md"
STAGES = ("scene", "mesh", "transport", "rays", "solve", "reconstruct", "util")


def module_name(path: Path) -> str:
    parts = path.relative_to(CORE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports() -> dict[str, set[str]]:
    """{module: the core modules it imports}, relative imports resolved, packages as their
    ``__init__``; ``from . import x`` counts as importing the module x where x is one."""
    modules = {module_name(path): path for path in CORE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                target = f"{base}.{node.module}" if node.module else base
                for alias in node.names:
                    found.add(f"{target}.{alias.name}" if f"{target}.{alias.name}" in modules else target)
            elif isinstance(node, ast.Import):
                found |= {alias.name for alias in node.names if alias.name.startswith("core")}
        graph[name] = {module for module in found if module in modules and module != name}
    return graph


def cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph``, or None (depth-first search)."""
    state, path = {}, []

    def visit(node):
        state[node] = "open"
        path.append(node)
        for child in sorted(graph[node]):
            if state.get(child) == "open":
                return path[path.index(child):] + [child]
            if child not in state and (found := visit(child)):
                return found
        state[node] = "done"
        path.pop()
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_the_graph_is_read_and_a_cycle_would_be_found():
    """The reader sees the imports it must judge, and the cycle search finds a planted cycle."""
    graph = imports()
    assert "core.mesh.discretize" in graph["core.bake"] and "core.util.geometry" in graph["core.mesh.discretize"]
    assert cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_no_import_cycles():
    assert cycle(imports()) is None


@pytest.mark.parametrize("package, forbidden", [
    ("core.scene", ("rays", "mesh", "transport", "solve", "reconstruct")),
    ("core.rays", ("mesh", "transport", "solve", "reconstruct")),
    ("core.util", ("scene", "rays", "mesh", "transport", "solve", "reconstruct")),
    ("core.settings", ("scene", "rays", "mesh", "transport", "solve", "reconstruct", "util")),
])
def test_lower_layers_import_no_higher_one(package, forbidden):
    graph = imports()
    for module, imported in graph.items():
        if module == package or module.startswith(package + "."):
            bad = sorted(target for target in imported if target.split(".")[1] in forbidden)
            assert not bad, f"{module} imports {bad}"


@pytest.mark.parametrize("stage", STAGES)
def test_each_stage_package_says_its_job(stage):
    docstring = ast.get_docstring(ast.parse((CORE / stage / "__init__.py").read_text()))
    assert docstring and len(docstring.split(".")[0]) < 200, docstring


def test_the_readme_knob_table_is_the_generated_one():
    """The README's knob table is ``python -m core knobs``'s output, between its markers."""
    text = README.read_text()
    start = text.index("<!-- knobs:")
    body = text[text.index("\n", start) + 1: text.index("<!-- /knobs -->")]
    assert body.strip() == knob_table().strip()


def note_templates() -> list[tuple[str, str]]:
    """Each note the add-on can add to a bake's report (string arguments of ``notes.append`` and
    strings assigned to ``note``), as (where, its text with "{}" for each formatted value)."""
    found = []
    for path in sorted((CORE.parent / "radiosity_addon").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            texts = []
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "append":
                owner = node.func.value
                if getattr(owner, "attr", getattr(owner, "id", None)) == "notes":
                    texts = node.args
            elif isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "note" for t in node.targets):
                texts = [node.value]
            for text in texts:
                parts = text.values if isinstance(text, ast.JoinedStr) else [text]
                template = "".join(part.value if isinstance(part, ast.Constant) else "{}" for part in parts)
                found.append((f"{path.name}:{text.lineno}", template))
    return found


def test_every_note_of_the_report_is_in_the_reading_table():
    """docs/reading.md lists what a bake reads and approximates with the words its report uses:
    each note the add-on can write contains a phrase quoted in that table, and each quoted phrase
    is in a note (or in an error the table says is one)."""
    table = (CORE.parent / "docs" / "reading.md").read_text()
    phrases = re.findall(r'"([^"]+)"', table)
    notes = note_templates()
    assert len(notes) > 15  # the parse finds them
    assert not [where for where, template in notes if not any(phrase in template for phrase in phrases)]
    sources = "".join(path.read_text() for path in (CORE.parent / "radiosity_addon").glob("*.py"))
    assert not [phrase for phrase in phrases if phrase not in sources and
                not any(phrase in template for _, template in notes)]
