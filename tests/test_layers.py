"""Layers that point one way: the import graph of gmcpt/ and mitsuba_plugins/ has no cycle, and
inference (completion/, the GAN's inference modules) never reaches the dataset builder or the renderer.

The graph is read from the source with ``ast``: every ``import`` and ``from ... import``,
those inside functions included, and ``importlib.import_module`` (of a literal name, else of
every project module a string in that file names). Importing ``a.b.c`` runs ``a`` and ``a.b``
too, so it is an edge to each of them, except to the importer's own enclosing packages, which
are already running. A package's ``__init__`` (its face) has edges to the submodules it imports.
"""
import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("gmcpt", "mitsuba_plugins")


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package ``__init__``)."""
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            is_package = parts[-1] == "__init__"
            modules[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return modules


def _imported_names(tree: ast.AST, package: str) -> set[str]:
    """Every dotted name the module imports (relative imports resolved against ``package``)."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            names.add(module)
            names.update(f"{module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module" and node.args:
            if isinstance(node.args[0], ast.Constant):
                names.add(node.args[0].value)
            else:  # a name looked up in a table: any module the file names could be the one
                names.update(constant.value for constant in ast.walk(tree) if isinstance(constant, ast.Constant)
                             and isinstance(constant.value, str) and constant.value.startswith(PACKAGES))
    return names


def import_graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports (see the module docstring)."""
    modules = _modules()
    graph = {}
    for name, (path, is_package) in modules.items():
        package = name if is_package else name.rpartition(".")[0]
        targets = set()
        for imported in _imported_names(ast.parse(path.read_text(), str(path)), package):
            parts = imported.split(".")
            targets.update(".".join(parts[:n]) for n in range(1, len(parts) + 1) if ".".join(parts[:n]) in modules)
        enclosing = {".".join(name.split(".")[:n]) for n in range(1, name.count(".") + 1)}
        graph[name] = targets - enclosing - {name}
    return graph


def reached(graph: dict[str, set[str]], start: set[str]) -> set[str]:
    """Every module importing ``start`` can run, ``start`` included."""
    seen, todo = set(), list(start)
    while todo:
        node = todo.pop()
        if node not in seen:
            seen.add(node)
            todo.extend(graph.get(node, ()))
    return seen


def find_cycle(graph: dict[str, set[str]]) -> list[str]:
    """One cycle of ``graph`` as a path that ends where it starts, or [] if there is none."""
    state, path = {}, []

    def visit(node):
        state[node] = "open"
        path.append(node)
        for target in sorted(graph[node]):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state and (cycle := visit(target)):
                return cycle
        state[node] = "done"
        path.pop()
        return []

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return []


def test_the_graph_sees_imports_inside_functions_and_parent_packages():
    graph = import_graph()
    assert "gmcpt.gan.weights" in graph["gmcpt.completion.check"]     # inside check_weights
    assert {"gmcpt", "gmcpt.completion"} <= graph["mitsuba_plugins.masked_path"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]


def test_the_graph_follows_package_faces_and_importlib_tables():
    graph = import_graph()
    assert "gmcpt.dataset.build" in graph["gmcpt.dataset"]             # the face's own import
    assert "gmcpt.render" in reached(graph, {"gmcpt.gan.data"})        # training data -> dataset -> renderer
    assert "gmcpt.batch" in graph["gmcpt.cli"]                          # import_module(SUBCOMMANDS[...])
    assert "gmcpt" not in graph["gmcpt.completion.learned"]             # its own package runs first


INFERENCE = {"gmcpt.gan", "gmcpt.gan.infer", "gmcpt.gan.inputs", "gmcpt.gan.model", "gmcpt.gan.weights"}
RENDERING = ("gmcpt.dataset", "gmcpt.render", "gmcpt.scene")


def test_inference_never_reaches_the_dataset_or_the_renderer():
    graph = import_graph()
    start = INFERENCE | {module for module in graph if module.startswith("gmcpt.completion")}
    wrong = sorted(module for module in reached(graph, start)
                   if module in RENDERING or module.startswith(RENDERING[0] + "."))
    assert not wrong


def test_no_import_cycle():
    cycle = find_cycle(import_graph())
    assert not cycle, " -> ".join(cycle)


def test_the_gan_package_never_imports_the_completion_methods():
    graph = import_graph()
    wrong = {(module, target) for module, targets in graph.items() if module.startswith("gmcpt.gan")
             for target in targets if target == "gmcpt.completion" or target.startswith("gmcpt.completion.")}
    assert not wrong


def test_the_library_never_imports_its_mitsuba_plugin():
    graph = import_graph()
    wrong = {(module, target) for module, targets in graph.items() if module.split(".")[0] == "gmcpt"
             for target in targets if target.split(".")[0] == "mitsuba_plugins"}
    assert not wrong


def test_seed_constants_live_in_the_seeds_module():
    """A random stream's offset or seed is a named constant of ``gmcpt.seeds``: a module-level ``..._SEED...``
    assignment or a large literal beside a seed elsewhere would be a stream nobody can see next to the others."""
    import re

    found = []
    for path in sorted((ROOT / "gmcpt").rglob("*.py")):
        if path.name == "seeds.py":
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#")[0]
            if re.match(r"(?![A-Z_]*LIMIT)[A-Z_]*SEEDS?(_[A-Z]+)*\s*=", code) or re.search(r"seed\w*\s*\+\s*(0x[0-9A-Fa-f]+|\d{2,})", code):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)
