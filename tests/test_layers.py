"""Layers that point one way: gmcpt/ is a stack of folders, one a stage, and a module imports only its own layer
and the layers below it (:data:`LAYERS`, docs/design.md "Layers"); the import graph of gmcpt/ and mitsuba_plugins/
has no cycle; the completion methods and the GAN never reach the dataset builder or the renderer.

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
    assert "gmcpt.render.kernels" in reached(graph, {"gmcpt.evaluation.scenes"})  # -> dataset face -> builder
    assert "gmcpt.cli.batch" in graph["gmcpt.cli"]                       # import_module(SUBCOMMANDS[...])
    assert "gmcpt" not in graph["gmcpt.completion.learned"]             # its own package runs first


#: The layers, lowest first: a folder (a stage) stands for its modules, a top-level module for itself. A module
#: imports modules of its own layer and of the layers below, never of a layer above.
LAYERS = (
    ("gmcpt.errors", "gmcpt.limits", "gmcpt.seeds", "gmcpt.frame"),  # the faces every stage uses
    ("gmcpt.runtime",),           # the process: LLVM, variant, plugins, signals, threads, device, progress, Ray
    ("gmcpt.image",),             # one image alone: working domain, fills, OIDN, metrics
    ("gmcpt.io",),                # files: safe writes, EXR, outputs, film, video, training examples
    ("gmcpt.lowrank", "gmcpt.gan"),  # the completion's two engines: PAWNNM and the generator
    ("gmcpt.completion",),        # the methods, by name
    ("gmcpt.render",),            # scenes and kernels
    ("gmcpt.sampling",),          # where the samples go: strategies, budget, costs, masks, dense, adaptive
    ("gmcpt.temporal",),          # sequences
    ("gmcpt.pipeline",),          # one frame end to end
    ("gmcpt.dataset",),           # the GAN's training data
    ("gmcpt.evaluation",),        # measuring the methods
    ("gmcpt.regress",),           # golden-image suites
    ("gmcpt.cli",),               # every entry point
    ("gmcpt", "gmcpt.__main__"),  # the package's face: what ``import gmcpt`` sets up
    ("mitsuba_plugins",),         # the masked_path integrator, over the whole library
)
#: The most modules the top of gmcpt/ holds: the package's faces; every other module lives in a stage folder.
MOST_TOP_MODULES = 8


def layer_of(module: str) -> int | None:
    """Index in :data:`LAYERS` of ``module`` (the longest entry that names it or a package holding it)."""
    best, depth = None, -1
    for index, entries in enumerate(LAYERS):
        for entry in entries:
            names = module == entry or (entry != "gmcpt" and module.startswith(entry + "."))
            if names and entry.count(".") > depth:
                best, depth = index, entry.count(".")
    return best


def test_every_module_has_a_layer():
    assert not sorted(module for module in import_graph() if layer_of(module) is None)
    assert layer_of("gmcpt.cli.render") > layer_of("gmcpt.render.kernels") > layer_of("gmcpt.completion.learned")
    assert layer_of("gmcpt") > layer_of("gmcpt.cli") and layer_of("gmcpt.errors") == 0


def test_imports_run_one_way_between_layers():
    """No module imports a module of a higher layer, inside a function or not."""
    wrong = sorted(f"{module} ({LAYERS[layer_of(module)][0]}) -> {target} ({LAYERS[layer_of(target)][0]})"
                   for module, targets in import_graph().items() for target in targets
                   if layer_of(target) > layer_of(module))
    assert not wrong, "\n".join(wrong)


def test_the_top_of_the_package_holds_only_its_faces():
    """At most :data:`MOST_TOP_MODULES` modules sit at the top of gmcpt/, each in :data:`LAYERS` by name; every
    folder of gmcpt/ with modules is a package named there (a new stage needs its place in the order)."""
    top = sorted(path.stem for path in (ROOT / "gmcpt").glob("*.py"))
    assert len(top) <= MOST_TOP_MODULES, top
    named = {entry for entries in LAYERS for entry in entries}
    assert not [name for name in top if name != "__init__" and f"gmcpt.{name}" not in named]
    folders = sorted(path.parent.name for path in (ROOT / "gmcpt").glob("*/*.py"))
    assert not [folder for folder in folders if f"gmcpt.{folder}" not in named]
    assert all((ROOT / "gmcpt" / folder / "__init__.py").is_file() for folder in folders)


ENGINES = ("gmcpt.completion", "gmcpt.gan", "gmcpt.lowrank")
RENDERING = ("gmcpt.dataset", "gmcpt.render")


def test_completion_never_reaches_the_dataset_or_the_renderer():
    """The completion methods and their engines (the GAN's training included: it reads the examples' files,
    :mod:`gmcpt.io.examples`, not the builder) run without the renderer or the dataset builder."""
    graph = import_graph()
    start = {module for module in graph if module.startswith(ENGINES)}
    wrong = sorted(module for module in reached(graph, start)
                   if module in RENDERING or module.startswith(tuple(folder + "." for folder in RENDERING)))
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


#: The private names one module still imports from another: (importer, module, name) -> why. Each is a debt, not a
#: design: a helper another module came to need, to be made public (or moved) when its importer is next changed.
PRIVATE_IMPORTS: dict = {}


def private_imports(modules: dict | None = None) -> set[tuple[str, str, str]]:
    """(importer, module, name) for every ``from module import _name`` (inside functions too) of one project module
    from another, and every ``module._name`` read through a project module the importer bound by name
    (``from . import report``; ``import a.b as c``): a private function or class crossing modules. An alias
    (``import x as _x``) is no private name."""
    modules, found = modules or _modules(), set()
    private = lambda name: name.startswith("_") and not name.startswith("__")  # noqa: E731
    for name, (path, is_package) in modules.items():
        package = name if is_package else name.rpartition(".")[0]
        tree, bound = ast.parse(path.read_text(), str(path)), {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                base = package.split(".")[:len(package.split(".")) - node.level + 1] if node.level else []
                module = ".".join(base + ([node.module] if node.module else []))
                found.update((name, module, alias.name) for alias in node.names
                             if private(alias.name) and module in modules and module != name)
                bound.update({alias.asname or alias.name: f"{module}.{alias.name}" for alias in node.names
                              if f"{module}.{alias.name}" in modules})
            elif isinstance(node, ast.Import):
                bound.update({alias.asname: alias.name for alias in node.names
                              if alias.asname and alias.name in modules})
        found.update((name, bound[node.value.id], node.attr) for node in ast.walk(tree)
                     if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                     and node.value.id in bound and private(node.attr) and bound[node.value.id] != name)
    return found


def test_no_private_name_crosses_modules():
    """No module imports another's private function or class (a name starting with ``_``), except the
    :data:`PRIVATE_IMPORTS` listed with their reason; a listed one that is gone leaves the list too."""
    found = private_imports()
    assert ("gmcpt", "gmcpt.runtime.interrupts", "startup") not in found  # ``startup as _startup``: a public name
    assert not sorted(found - PRIVATE_IMPORTS.keys()), "a private name crosses modules: make it public"
    assert not sorted(PRIVATE_IMPORTS.keys() - found), "no longer imported: drop it from PRIVATE_IMPORTS"


def test_the_private_name_check_sees_both_ways_a_name_crosses(tmp_path):
    (tmp_path / "a.py").write_text("from gmcpt.b import _hidden, shown\n")
    (tmp_path / "c.py").write_text("def f():\n    from . import b\n    return b._inner()\n")
    (tmp_path / "b.py").write_text("def _hidden(): pass\ndef _inner(): pass\ndef shown(): pass\n")
    modules = {f"gmcpt.{name}": (tmp_path / f"{name}.py", False) for name in "abc"}
    assert private_imports(modules) == {("gmcpt.a", "gmcpt.b", "_hidden"), ("gmcpt.c", "gmcpt.b", "_inner")}
