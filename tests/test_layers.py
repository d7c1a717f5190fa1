"""The import graph of the project's own packages: imports only go down the layers, and no module cycle.

Every import is read with `ast`, at module level and inside functions alike (a function-level import is
still a dependency; hiding it does not remove it). The picture behind LAYERS: docs/architecture.md.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("agent", "swarmhost", "coordinator", "perception", "ros2link", "fluidswarm", "research")

# Lowest first, each entry a package (a folder): a module belongs to the layer of its innermost listed folder
# (agent/sph/ is physics, agent/ around it the compiled records); a module may import from its own layer and the
# layers below.
LAYERS: list[tuple[str, tuple[str, ...]]] = [
    # agent/'s own modules: the compiled boundary records (agent/native/python, known by its stub
    # agent/_native.pyi), their import (records) and the fill law's typed wrapper (fill)
    ("compiled", ("agent",)),
    ("physics", ("agent.sph",)),
    ("protocol", ("agent.protocol",)),
    ("perception", ("perception",)),
    # the link to a ROS 2 system: rmw_zenoh's format, a node, the messages' codec, an image topic as perception's
    # frame stream; below the coordinator (its camera) and the recorder (its bridge), which both use it
    ("ros2 link", ("ros2link",)),
    ("control", ("coordinator.control",)),
    ("processes", ("swarmhost", "coordinator", "fluidswarm.recording")),
    (
        "orchestration",
        ("fluidswarm.orchestration",),
    ),
    # the command line; a lower package's subcommand registration (perception/commands.py) stays in its folder's
    # layer: the command line imports it, it imports nothing above its folder
    ("application", ("fluidswarm",)),
    # the research tools, outside the wheel (research/__init__.py): they may use every package, none uses them
    ("research", ("research",)),
]


def layer_of(module: str) -> int:
    best, level = -1, None
    for rank, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (module == p or module.startswith(p + ".")) and len(p) > best:
                best, level = len(p), rank
    assert level is not None, f"{module}: no layer in tests/test_layers.py LAYERS (and docs/architecture.md)"
    return level


def modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        # a compiled module is known by its stub (agent/_native.pyi); a stub beside a .py is the .py's
        for path in sorted(p for p in (REPO / package).rglob("*.py*") if p.suffix in (".py", ".pyi")):
            if "native" in path.relative_to(REPO).parts or path.with_suffix(".py") in found.values():
                continue
            name = ".".join(path.relative_to(REPO).with_suffix("").parts)
            found[name.removesuffix(".__init__")] = path
    return found


def imports(name: str, path: Path, known: dict[str, Path]) -> list[tuple[str, int]]:
    """(imported project module, line) for every import statement of the module, at any depth."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(parts + ([base] if base else []))
            # `from pkg import mod` depends on pkg.mod; `from mod import name` on mod
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
        else:
            continue
        for t in targets:
            while t and t not in known:  # `import a.b.c` of a function: the module that holds it
                t = t.rpartition(".")[0]
            if t and t != name:
                out.append((t, node.lineno))
    return out


def graph() -> tuple[dict[str, Path], dict[str, list[tuple[str, int]]]]:
    known = modules()
    return known, {name: imports(name, path, known) for name, path in known.items()}


def test_every_module_has_a_layer():
    known, _ = graph()
    assert len(known) > 50  # the walk found the packages
    for name in known:
        layer_of(name)


def test_every_layer_entry_names_a_module():
    """LAYERS lists what exists: a module or package moved or deleted leaves no entry behind."""
    known, _ = graph()
    stale = [p for _, prefixes in LAYERS for p in prefixes if p not in known]
    assert not stale, f"tests/test_layers.py LAYERS names modules that do not exist: {stale}"


def test_every_layer_entry_is_a_folder():
    """No exception list: LAYERS names packages (folders), never a module inside one, so every module is in its
    folder's layer, and a module changes layer only by changing folder."""
    known, _ = graph()
    modules = [p for _, prefixes in LAYERS for p in prefixes if p in known and known[p].name != "__init__.py"]
    assert not modules, f"tests/test_layers.py LAYERS names modules, not folders: {modules}"


def test_imports_only_go_down_the_layers():
    known, edges = graph()
    upward = []
    for name, targets in edges.items():
        for target, line in targets:
            if layer_of(target) > layer_of(name):
                upward.append(
                    f"{known[name].relative_to(REPO)}:{line}: {name} ({LAYERS[layer_of(name)][0]}) "
                    f"imports {target} ({LAYERS[layer_of(target)][0]})"
                )
    assert not upward, "imports up the layers:\n" + "\n".join(sorted(set(upward)))


def find_cycles(edges: dict[str, list[tuple[str, object]]], where: bool = False) -> list[str]:
    """Every cycle a depth-first walk of `edges` (name -> [(target, where)]) meets, as `a -> b -> a`, with the
    closing edge's `where` (file:line) when asked."""
    state: dict[str, int] = {}  # 1 on the current path, 2 done
    cycles: list[str] = []

    def visit(name: str, path: list[str]) -> None:
        state[name] = 1
        for target, at in edges.get(name, []):
            if state.get(target) == 1:
                cycles.append(" -> ".join(path[path.index(target) :] + [target]) + (f" ({at})" if where else ""))
            elif target not in state:
                visit(target, path + [target])
        state[name] = 2

    for name in sorted(edges):
        if name not in state:
            visit(name, [name])
    return cycles


def test_no_import_cycle():
    _, edges = graph()
    cycles = find_cycles(edges)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def grouped(edges: dict[str, list[tuple[str, int]]], group) -> dict[str, list[tuple[str, object]]]:
    """The import graph of groups of modules (`group`: module -> its group), each edge with the import behind it."""
    out: dict[str, list[tuple[str, object]]] = {}
    for name, targets in edges.items():
        for target, line in targets:
            if group(name) != group(target):
                out.setdefault(group(name), []).append((group(target), f"{name} -> {target}:{line}"))
    return out


def test_no_folder_cycle():
    """Folders (packages) import each other in no loop either: each can be read, and moved, above the ones it uses."""
    known, edges = graph()
    cycles = find_cycles(grouped(edges, lambda m: m if known[m].name == "__init__.py" else m.rpartition(".")[0]), True)
    assert not cycles, "folders that import each other:\n" + "\n".join(cycles)


def test_no_package_cycle():
    """The top-level packages (agent, perception, ros2link, coordinator, swarmhost, fluidswarm) import each other in
    no loop: each installs and reads on top of the ones it uses (coordinator <-> fluidswarm was the last loop, through
    coordinator/camera.py's ROS 2 source, until the ROS 2 link left fluidswarm/ for ros2link/)."""
    _, edges = graph()
    cycles = find_cycles(grouped(edges, lambda m: m.partition(".")[0]), True)
    assert not cycles, "packages that import each other:\n" + "\n".join(cycles)


def test_the_checker_sees_function_level_and_relative_imports(tmp_path):
    """The graph must not miss an import hidden in a function (the agent ↔ coordinator cycle hid there)."""
    pkg = tmp_path / "agent"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from coordinator.control import route\n    from . import b\n")
    (pkg / "b.py").write_text("")
    known = {
        "agent": pkg / "__init__.py",
        "agent.a": pkg / "a.py",
        "agent.b": pkg / "b.py",
        "coordinator.control.route": Path("route.py"),
        "coordinator.control": Path("__init__.py"),
    }
    assert imports("agent.a", pkg / "a.py", known) == [("coordinator.control.route", 2), ("agent.b", 3)]
    assert layer_of("coordinator.control.route") > layer_of("agent.protocol.wire") > layer_of("agent.sph.kernel")


RUST_SRC = REPO / "agent" / "native" / "src"


def rust_modules() -> dict[str, list[tuple[str, str]]]:
    """Each top-level module of the agent crate (src/X.rs with its folder src/X/) → (module it names through
    `crate::`, file:line). A `crate::` path anywhere counts, in a `use` or inline: both are dependencies."""
    out: dict[str, list[tuple[str, str]]] = {}
    for path in sorted(RUST_SRC.rglob("*.rs")):
        rel = path.relative_to(RUST_SRC)
        module = rel.parts[0].removesuffix(".rs")
        if module in ("lib", "main", "router_main"):  # the crate roots: they declare the modules
            continue
        deps = out.setdefault(module, [])
        for n, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("//", 1)[0]
            for m in re.finditer(r"\bcrate::([a-z_][a-z0-9_]*)", code):
                if m.group(1) != module:
                    deps.append((m.group(1), f"{rel}:{n}"))
    return out


def test_no_rust_module_cycle():
    edges = rust_modules()
    assert {"agent", "command", "fill", "sph", "wire"} <= set(edges)  # the walk found the crate
    cycles = find_cycles(edges, where=True)
    assert not cycles, "module cycles in agent/native/src:\n" + "\n".join(cycles)
