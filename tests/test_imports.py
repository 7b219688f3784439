"""No import cycles among the project's modules, counting imports inside functions too.

An import inside a function only hides a cycle until that function runs (and makes
the import order decide what works), so the graph here has an edge for every
``import`` / ``from ... import`` anywhere in a module, except under
``if TYPE_CHECKING:`` (never executed). ``from pkg import name`` points at the
submodule ``pkg.name`` when there is one, else at ``pkg``; a package's
``__init__`` being run on the way to a submodule is not an edge (it is the package
re-exporting its own modules, not a dependency of the importer).
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("blendvoca", "benchmark", "leaderboard", "baselines")


def project_modules(packages=PACKAGES) -> dict[str, tuple[Path, bool]]:
    """``{"pkg.mod": (file, is_package)}`` for every module of ``packages``."""
    modules = {}
    for package in packages:
        for path in sorted((ROOT / package).rglob("*.py")):
            if "node_modules" in path.parts or "__pycache__" in path.parts:
                continue
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            is_package = parts[-1] == "__init__"
            modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imported_modules(name: str, modules: dict) -> dict[str, list[tuple[int, bool]]]:
    """Project modules ``name`` imports: ``{module: [(line, inside a function), ...]}``."""
    path, is_package = modules[name]
    package = name if is_package else name.rpartition(".")[0]
    found: list[tuple[str, int, bool]] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking(child):
                for other in child.orelse:
                    visit_statement(other, in_function)
                continue
            visit_statement(child, in_function)

    def visit_statement(node: ast.AST, in_function: bool) -> None:
        inner = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        if isinstance(node, ast.Import):
            found.extend((alias.name, node.lineno, inner) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                found.append((submodule if submodule in modules else source, node.lineno, inner))
        visit(node, inner)

    visit(ast.parse(path.read_text(encoding="utf-8")), False)
    edges: dict[str, list[tuple[int, bool]]] = {}
    for target, line, inner in found:
        while target and target not in modules:  # "blendvoca.io.mesh.read_ply" -> "blendvoca.io.mesh"
            target = target.rpartition(".")[0]
        if target and target != name:
            edges.setdefault(target, []).append((line, inner))
    return edges


def import_cycles(packages=PACKAGES) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    modules = project_modules(packages)
    graph = {name: sorted(imported_modules(name, modules)) for name in modules}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def connect(v: str) -> None:
        # Iterative Tarjan: the graph is deep enough to hit the recursion limit.
        work = [(v, iter(graph[v]))]
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(graph[child])))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))

    for name in sorted(graph):
        if name not in index:
            connect(name)
    return sorted(cycles)


def describe(cycle: list[str], packages=PACKAGES) -> str:
    """The edges inside one cycle, ``a:12 -> b (in a function)``, one per line."""
    modules = project_modules(packages)
    members = set(cycle)
    lines = []
    for name in cycle:
        for target, sites in sorted(imported_modules(name, modules).items()):
            if target in members:
                lines += [f"  {name}:{line} -> {target}{' (in a function)' if inner else ''}" for line, inner in sites]
    return "\n".join(lines)


def test_the_graph_sees_imports_inside_functions(tmp_path, monkeypatch):
    package = tmp_path / "cyc"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from cyc.b import g\n\ndef f():\n    return g()\n")
    (package / "b.py").write_text("def g():\n    from cyc import a\n    return a\n")
    (package / "c.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from cyc.a import f\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert import_cycles(("cyc",)) == [["cyc.a", "cyc.b"]]
    assert "cyc.b:2 -> cyc.a (in a function)" in describe(["cyc.a", "cyc.b"], ("cyc",))


def test_no_import_cycle_in_blendvoca_benchmark_and_leaderboard():
    packages = ("blendvoca", "benchmark", "leaderboard")
    cycles = import_cycles(packages)
    assert not cycles, "import cycles:\n" + "\n".join(describe(c, packages) for c in cycles)


def test_no_import_cycle_through_baselines():
    cycles = [c for c in import_cycles() if any(m.split(".")[0] == "baselines" for m in c)]
    assert not cycles, "import cycles:\n" + "\n".join(describe(c) for c in cycles)


# --- The layering: docs/architecture.md, "Who may import whom" -------------------------------------

#: Every import may go to the rooms of the rows above its own (all of them, or only the listed
#: ones) and to the rooms before it in its own row. Row by row as docs/architecture.md's table,
#: which mirrors this one (:func:`test_the_architecture_table_lists_the_rooms_of_the_test`).
ABOVE = ("*",)
ROOMS = (
    (("blendvoca.runtime",), ()),  # the standard library and third-party libraries only
    (("blendvoca.errors", "blendvoca.cli"), ABOVE),
    (("blendvoca.registry", "blendvoca.names", "blendvoca.io", "blendvoca.assets", "blendvoca.rig",
      "blendvoca.rig_regions"), ABOVE),
    (("blendvoca.runtime.processes", "blendvoca.runtime.staging"), ABOVE),
    (("blendvoca.format",), ABOVE),
    (("blendvoca.vocaset", "blendvoca.synthetic", "blendvoca.retarget", "blendvoca.fit", "blendvoca.export",
      "blendvoca.blender"), ABOVE),
    (("blendvoca.builder",), ABOVE),
    (("blendvoca.datasets",), ABOVE),
    # the build's commands run the build on what the rows above read or generate
    (("blendvoca.builder.__main__", "blendvoca.build", "blendvoca.synthetic.calibrate"), ABOVE),
    (("benchmark.methods",), ("blendvoca",)),
    (("benchmark.data", "benchmark.metrics", "benchmark.features", "benchmark.results", "benchmark.runs",
      "benchmark.render", "benchmark.lipsync", "benchmark.evaluation"),
     ("blendvoca", "benchmark.methods")),
    (("benchmark.protocol",), ABOVE),
    (("benchmark.run_figure",), ABOVE),  # the figure beside each result, drawn after the protocol stored it
    (("benchmark.run", "benchmark.generate", "benchmark.rescore", "benchmark.sanity", "benchmark.testing",
      "benchmark.study"), ABOVE),
    (("blendvoca.live",), ABOVE),  # live output: its --method animates through benchmark.generate
    (("baselines.wav2vec2", "baselines.vq", "baselines.common"), ("blendvoca", "benchmark.methods")),
    (("baselines.*",), ("blendvoca", "benchmark.methods", "baselines.wav2vec2", "baselines.vq", "baselines.common")),
    (("leaderboard",), ABOVE),
)

#: Imports the table allows by name (each is named in its row of docs/architecture.md): importer, imported.
EXCEPTIONS = {
    ("baselines.said.train", "benchmark.data"): "the SAiD training command opens a build",
}


def _within(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def room_of(module: str) -> tuple[int, int, str] | None:
    """``(row, position in the flattened table, room)`` of a module (the most specific room), None
    for the four packages' own ``__init__``."""
    best, position = None, 0
    for row, (rooms, _) in enumerate(ROOMS):
        for room in rooms:
            if room.endswith(".*"):  # one room per subpackage: baselines.said, baselines.cdface, ...
                parent = room[:-2]
                if module.startswith(parent + ".") and (best is None or best[3] <= len(parent)):
                    best = (row, position, ".".join(module.split(".")[:2]), len(parent))
            elif _within(module, room) and (best is None or best[3] < len(room) + 1):
                best = (row, position, room, len(room) + 1)
            position += 1
    return None if best is None else best[:3]


def layering_violations(packages=PACKAGES) -> list[str]:
    """``importer:line -> imported`` for every import (module or function level) against :data:`ROOMS`."""
    modules = project_modules(packages)
    found = []
    for name in sorted(modules):
        importer = room_of(name)
        if importer is None:
            continue
        row, position, room = importer
        allowed = ROOMS[row][1]
        for target, sites in sorted(imported_modules(name, modules).items()):
            imported = room_of(target)
            if imported is None or imported[2] == room:
                continue
            down = imported[1] < position and (
                imported[0] == row or allowed == ABOVE or any(_within(target, p) for p in allowed))
            excused = any(_within(name, a) and _within(target, b) for a, b in EXCEPTIONS)
            if not (down or excused):
                found += [f"{name}:{line} -> {target}{' (in a function)' if inner else ''}" for line, inner in sites]
    return found


def test_every_module_has_a_room():
    modules = project_modules()
    homeless = [name for name in modules if room_of(name) is None and name not in PACKAGES]
    assert not homeless, f"modules in no room of ROOMS (add them to it and to docs/architecture.md): {homeless}"


def test_imports_only_go_down_the_architecture_table():
    violations = layering_violations()
    assert not violations, "imports against docs/architecture.md's table:\n" + "\n".join(violations)


def test_the_layering_check_catches_an_upward_import(tmp_path, monkeypatch):
    for package, files in {"blendvoca": {"fit/__init__.py": "", "fit/a.py": "def f():\n    import benchmark.run\n",
                                         "names.py": "from blendvoca.fit import a\n"},
                           "benchmark": {"run.py": "", "methods.py": "import blendvoca.names\n"},
                           "baselines": {"said/__init__.py": "from baselines.cdface import x\n",
                                         "cdface/__init__.py": "", "cdface/x.py": "from baselines.common import y\n",
                                         "common/__init__.py": "", "common/y.py": "from benchmark import run\n"},
                           "leaderboard": {}}.items():
        for path, text in {"__init__.py": "", **files}.items():
            (tmp_path / package / path).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / package / path).write_text(text)
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert layering_violations() == [
        "baselines.common.y:1 -> benchmark.run",
        "baselines.said:1 -> baselines.cdface.x",
        "blendvoca.fit.a:2 -> benchmark.run (in a function)",
        "blendvoca.names:1 -> blendvoca.fit.a",
    ]


def test_the_architecture_table_lists_the_rooms_of_the_test():
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split("## Who may import whom", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| `")]
    documented = [tuple(name.replace("<method>", "*") for name in re.findall(r"`([^`]+)`", row.split(" | ")[0]))
                  for row in rows]
    assert documented == [rooms for rooms, _ in ROOMS]
    for importer, imported in EXCEPTIONS:
        assert f"`{importer}`" in section and f"`{imported}`" in section, (importer, imported)
