"""Import layers: the module import graph of armctl has no circles where packages meet.

The graph is built from the source (every ``import armctl...`` and ``from armctl... import``,
including function-local and ``TYPE_CHECKING`` ones), so an import hidden from the run time
still counts.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from pathlib import Path

import armctl

ROOT = Path(armctl.__file__).resolve().parent


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(name: str, modules: set[str]) -> str | None:
    """The armctl module that ``name`` refers to (a module, or a name inside one)."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the armctl modules it imports, from every import statement in its source.

    ``from armctl.a import b`` counts as an import of ``armctl.a.b`` when that is a module, else
    of ``armctl.a``; relative imports are resolved against the importing module.
    """
    root = root.resolve()
    files = {_module_name(p, root): p for p in sorted(root.rglob("*.py"))}
    modules = set(files)
    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")
                    anchor = anchor[:len(anchor) - (node.level - 1)]
                    base = ".".join([*anchor, base] if base else anchor)
                targets = [f"{base}.{a.name}" for a in node.names] or [base]
            for t in targets:
                dep = _resolve(t, modules)
                if dep is not None and dep != mod:
                    deps.add(dep)
        graph[mod] = deps
    return graph


def cycles(graph: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """The import circles: strongly connected components of more than one module.

    Returns:
        Each circle's modules, sorted; circles sorted by their first module.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:  # Tarjan's algorithm (graphs here are a few hundred nodes)
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def _within(graph: Mapping[str, Iterable[str]], prefixes: tuple[str, ...]) -> dict[str, set[str]]:
    """The subgraph of the modules under any of ``prefixes``."""
    def inside(m: str) -> bool:
        return any(m == p or m.startswith(p + ".") for p in prefixes)

    return {m: {d for d in deps if inside(d)} for m, deps in graph.items() if inside(m)}


def test_cycle_finder_finds_a_planted_circle() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert cycles(graph) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_graph_sees_hidden_imports() -> None:
    graph = import_graph()
    assert "armctl.servo_tables" in graph["armctl.config.bus"]
    assert "armctl.servo.mapping" in graph["armctl.servo.arm_bus"]
    assert "armctl.servo.sim.bus" in graph["armctl.servo.simulated_arm"]


def test_no_import_cycles_in_servo_and_config() -> None:
    graph = _within(import_graph(), ("armctl.servo", "armctl.servo_tables", "armctl.config"))
    assert cycles(graph) == []


def test_config_and_tables_do_not_import_the_servo_package() -> None:
    graph = import_graph()
    for mod in (m for m in graph if m.split(".")[1:2] in (["servo_tables"], ["config"])):
        up = {d for d in graph[mod] if d == "armctl.servo" or d.startswith("armctl.servo.")}
        assert not up, f"{mod} imports {sorted(up)}"


def test_simulator_imports_tables_and_codec_only_from_servo() -> None:
    # ... and the registry of the families' rules, which the simulator asks instead of branching
    # (the simulator names no vendor package itself)
    graph = import_graph()
    allowed = {"armctl.servo.codec", "armctl.servo.vendor_rules"}
    for mod, deps in graph.items():
        if mod == "armctl.servo.sim" or mod.startswith("armctl.servo.sim."):
            servo = {d for d in deps if d.startswith("armctl.servo.")
                     and not d.startswith("armctl.servo.sim")}
            assert servo <= allowed, f"{mod} imports {sorted(servo - allowed)}"


def test_servo_tables_are_a_leaf() -> None:
    graph = import_graph()
    tables = [m for m in graph if m.split(".")[:2] == ["armctl", "servo_tables"]]
    assert "armctl.servo_tables.dynamixel" in tables
    for mod in tables:
        outside = {d for d in graph[mod] if d.split(".")[:2] != ["armctl", "servo_tables"]}
        assert outside <= {"armctl.errors"}, f"{mod} imports {sorted(outside)}"


#: The layers of docs/architecture.md, bottom to top: a package imports only lower layers.
LAYERS: tuple[frozenset[str], ...] = (
    frozenset({"errors", "typing"}),
    frozenset({"spatial", "clock", "atomic_write", "servo_tables"}),
    frozenset({"config"}),
    frozenset({"kinematics"}),
    frozenset({"collision"}),
    frozenset({"ik"}),
    frozenset({"arm"}),
    frozenset({"motion"}),
    frozenset({"servo", "render"}),
    frozenset({"robot"}),
    frozenset({"panel"}),
    frozenset({"cli"}),
    frozenset({"__main__"}),
)


def _layer_of(module: str) -> int | None:
    """The layer of an armctl module, or None for the package root ``armctl`` itself."""
    parts = module.split(".")
    if len(parts) < 2:
        return None
    for i, layer in enumerate(LAYERS):
        if parts[1] in layer:
            return i
    raise AssertionError(f"{module} belongs to no layer: add its package to LAYERS and to "
                         "docs/architecture.md")


def layer_violations(graph: Mapping[str, Iterable[str]]) -> list[str]:
    """Imports that point up or sideways between packages (same layer, other package)."""
    bad = []
    for mod, deps in graph.items():
        lm = _layer_of(mod)
        if lm is None:
            continue
        for dep in deps:
            ld = _layer_of(dep)
            if ld is None:
                continue
            same_package = mod.split(".")[1] == dep.split(".")[1]
            if not same_package and ld >= lm:
                bad.append(f"{mod} -> {dep}")
    return sorted(bad)


def test_layer_check_finds_an_upward_import() -> None:
    graph = {"armctl.config.x": {"armctl.robot.session"}, "armctl.robot.session": set(),
             "armctl.servo.a": {"armctl.render.b"}, "armctl.render.b": set(),
             "armctl.cli.c": {"armctl.robot.session", "armctl.cli.d"}, "armctl.cli.d": set()}
    assert layer_violations(graph) == ["armctl.config.x -> armctl.robot.session",
                                       "armctl.servo.a -> armctl.render.b"]


def test_every_import_points_down_the_layers() -> None:
    assert layer_violations(import_graph()) == []


def test_no_import_cycles_anywhere() -> None:
    assert cycles(import_graph()) == []


def test_the_architecture_doc_names_every_layer() -> None:
    doc = (ROOT.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    for layer in LAYERS:
        for package in layer - {"__main__"}:
            assert f"armctl.{package}" in doc, f"docs/architecture.md does not name {package}"
