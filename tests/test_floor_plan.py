"""The floor plan of the source (docs/ARCHITECTURE.md): no import cycle anywhere, counting the imports
inside functions and under ``TYPE_CHECKING``; the controller's rooms by subject, with names that say
what they hold; handlers typed by the Controller protocol; the mode written by the state machine
alone."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

import xarm_emu

SRC = Path(xarm_emu.__file__).resolve().parent
CONTROLLER = SRC / "controller"
VAGUE_NAMES = {"extras", "misc", "motion2", "utils", "helpers", "base"}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in SRC.rglob("*.py")}


def _targets(node: ast.Import | ast.ImportFrom, module: str, is_package: bool,
             known: dict[str, Path]) -> Iterator[str]:
    """The project's modules an import statement loads (a name imported from a package that is a
    module of its own counts as that module)."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        if node.level:
            base = module.split(".") if is_package else module.split(".")[:-1]
            base = base[: len(base) - (node.level - 1)]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        names = [f"{source}.{a.name}" if f"{source}.{a.name}" in known else source for a in node.names]
    for name in names:
        while name and name not in known:
            name = name.rpartition(".")[0]
        if name and name != module:
            yield name


def import_graph() -> dict[str, set[str]]:
    """Module -> the project's modules it imports, wherever the import stands (top level, inside a
    function, under ``if TYPE_CHECKING``)."""
    known = _modules()
    graph: dict[str, set[str]] = {}
    for module, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        is_package = path.name == "__init__.py"
        graph[module] = {t for node in ast.walk(tree) if isinstance(node, ast.Import | ast.ImportFrom)
                         for t in _targets(node, module, is_package, known)}
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_graph_sees_imports_inside_functions_and_type_checking() -> None:
    graph = import_graph()
    # register 19's handler module imports the state machine at the top; the physics package
    # imports its engine's component only inside attach() and under TYPE_CHECKING
    assert "xarm_emu.controller.core.state_machine" in graph["xarm_emu.controller.handlers.state"]
    assert "xarm_emu.controller.physics.component" in graph["xarm_emu.controller.physics"]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_anywhere() -> None:
    assert cycles(import_graph()) == []


def test_the_controller_stands_in_rooms() -> None:
    """At most 12 modules directly in controller/ (files and room folders alike)."""
    direct = [p.stem for p in CONTROLLER.glob("*.py") if p.name != "__init__.py"]
    rooms = [p.name for p in CONTROLLER.iterdir() if (p / "__init__.py").exists()]
    assert {"core", "devices", "applications", "handlers"} <= set(rooms)
    assert len(direct) + len(rooms) <= 12, sorted(direct + rooms)


def _one_apart(a: str, b: str) -> bool:
    """Whether ``b`` comes from ``a`` by changing, adding or removing one character."""
    if a == b or abs(len(a) - len(b)) > 1:
        return False
    if len(a) == len(b):
        return sum(x != y for x, y in zip(a, b, strict=True)) == 1
    short, long = sorted((a, b), key=len)
    return any(long[:i] + long[i + 1:] == short for i in range(len(long)))


def test_module_names_say_what_they_hold() -> None:
    assert _one_apart("state", "states") and _one_apart("io", "i0") and not _one_apart("io", "ion2")
    for package in [CONTROLLER, *(p.parent for p in CONTROLLER.rglob("__init__.py"))]:
        names = sorted({p.stem for p in package.glob("*.py") if p.name != "__init__.py"}
                       | {p.name for p in package.iterdir() if (p / "__init__.py").exists()})
        assert not VAGUE_NAMES & set(names), package
        close = [(a, b) for i, a in enumerate(names) for b in names[i + 1:] if _one_apart(a, b)]
        assert close == [], package


def test_no_controller_typed_any() -> None:
    offenders = [f"{p.relative_to(SRC)}:{n}" for p in CONTROLLER.rglob("*.py")
                 for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                 if "ctl: Any" in line]
    assert offenders == []


#: A write of register 19's mode: to the controller (``ctl``, the state machine's ``holder``) or its
#: state (``data``, ``d``); a device's own mode (``self.mode`` of a gripper) is another register.
_MODE_WRITE = re.compile(r"\b(ctl|holder|data|d)\.mode\s*(=|\+=|-=)(?!=)")


@pytest.mark.parametrize("path", sorted(CONTROLLER.rglob("*.py")),
                         ids=lambda p: str(p.relative_to(CONTROLLER)))
def test_only_the_state_machine_writes_the_mode(path: Path) -> None:
    writes = [n for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
              if _MODE_WRITE.search(line)]
    if path.relative_to(CONTROLLER) == Path("core/state_machine.py"):
        assert writes, "fire_mode writes the mode"
    else:
        assert writes == []


def _lines(n: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """A function's lines, its decorators included."""
    start = min([n.lineno, *(d.lineno for d in n.decorator_list)])
    return (n.end_lineno or n.lineno) - start + 1


def test_functions_fit_on_a_screen() -> None:
    """No function in the source is longer than 80 lines, decorators included (long ones are named
    steps)."""
    long = [f"{p.relative_to(SRC)}:{n.lineno} {n.name} ({_lines(n)} lines)"
            for p in SRC.rglob("*.py")
            for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef) and _lines(n) > 80]
    assert long == []


#: The machinery every control period runs through: the box's step, the controller's, the planner's.
MACHINERY = ("emulator.py", "controller.py", "core/executor.py", "core/jump.py")


def _functions(path: Path) -> dict[str, ast.FunctionDef]:
    """The functions and methods of a module by qualified name (``Class.method``)."""
    found: dict[str, ast.FunctionDef] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, ast.FunctionDef):
                found[f"{prefix}{child.name}"] = child
                visit(child, f"{prefix}{child.name}.")

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return found


def test_the_machinery_fits_on_a_page() -> None:
    """No function of the machinery (:data:`MACHINERY`) is longer than 60 lines, decorators
    included."""
    long = [f"{name} in {module} ({_lines(fn)} lines)" for module in MACHINERY
            for name, fn in _functions(CONTROLLER / module).items() if _lines(fn) > 60]
    assert long == []


def _loops(fn: ast.FunctionDef) -> int:
    """The loop statements of a function (``for``, ``while``; a comprehension over its parts aside)."""
    return sum(isinstance(n, ast.For | ast.While) for n in ast.walk(fn))


def test_the_jump_is_one_walk() -> None:
    """The jump over idle periods walks the periods it skips in one loop (core/jump.py; the clock
    alone, for a call with nothing due in it, is one sum), the box's step in one loop over the
    periods of a call (each jumped or run in full); the box keeps no jump or tick of its own."""
    jump = _functions(CONTROLLER / "core/jump.py")
    assert (_loops(jump["jump"]), _loops(jump["tick"])) == (1, 1)
    box = _functions(CONTROLLER / "emulator.py")
    assert _loops(box["Emulator.step"]) == 1
    assert not {"Emulator._jump", "Emulator._tick"} & set(box)
