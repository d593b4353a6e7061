"""The package's rooms and the import rule (docs/architecture.md): every import inside
hpddo, at the top of a module or inside a function, points to its own room or to a room
below it, and no modules import each other in a circle."""
import ast
import pathlib

from conftest import ROOT

PACKAGE = ROOT / "tools" / "hpddo"

# room -> level; a module may import its own room and the rooms of a lower level
LEVELS = {
    "foundations": 0,   # hpddo (resource_root), schema, bench, interrupt: the declarations
    "logs": 1,
    "model": 2,
    "ripple": 3,        # above model: the board counter's Ra tracker runs the model's physics, and a
    #                     trained model's M2 may be the prior; below evaluation, which scores against it
    "evaluation": 4,
    "twin": 4,
    "diagnosis": 5,
    "reports": 6,
    "pipeline": 7,
    "regenerate": 7,
    "studies": 8,
    "cli": 9,
}
FOUNDATIONS = {"hpddo", "hpddo.schema", "hpddo.bench", "hpddo.interrupt", "hpddo.progress"}


def module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def room(module: str) -> str:
    if module in FOUNDATIONS:
        return "foundations"
    if module == "hpddo.__main__":
        return "cli"
    return module.split(".")[1]


def modules() -> dict:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def defined(path: pathlib.Path) -> set:
    """The names a module binds at its top level."""
    out = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            out.add(node.name)
        elif isinstance(node, ast.Assign):
            out |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            out |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return out


def imports(path: pathlib.Path, name: str, known: dict) -> set:
    """The hpddo modules path imports (a name imported from a package counts as the
    package's module when it is one, else the package itself)."""
    pkg = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("hpddo"):
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                if sub in known:
                    out.add(sub)
                elif mod in known and known[mod].name == "__init__.py" and a.name not in defined(known[mod]):
                    out.add(sub)  # a module that is not there (test_every_import_...)
                else:
                    out.add(mod)
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("hpddo")}
    out.discard(name)
    return out


def graph() -> dict:
    known = modules()
    return {name: imports(path, name, known) for name, path in known.items()}


def test_every_module_lives_in_a_room():
    for name in modules():
        assert room(name) in LEVELS, f"{name} is in no room of docs/architecture.md"


def test_imports_point_down_or_stay_in_their_room():
    bad = []
    for name, deps in graph().items():
        here = room(name)
        for d in deps:
            there = room(d)
            if there != here and LEVELS[there] >= LEVELS[here]:
                bad.append(f"{name} ({here}) imports {d} ({there})")
    assert not bad, "\n".join(sorted(bad))


def test_no_import_circle():
    g = graph()
    index, low, stack, on, circles, counter = {}, {}, [], set(), [], [0]

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in g:
                continue
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
                circles.append(sorted(comp))

    for v in g:
        if v not in index:
            visit(v)
    assert not circles, circles


def test_every_room_says_what_it_holds_and_may_import():
    for r in LEVELS:
        init = PACKAGE / r / "__init__.py"
        if init.exists():
            doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
            assert "May import" in doc or r in ("cli",), f"{init}: no 'May import' line"


def test_every_import_inside_hpddo_names_a_module_that_exists():
    """A module moved to another room and an import left at its old place fail here, not
    when the one function that imports it lazily runs."""
    known = modules()
    missing = sorted(f"{name} imports {d}" for name, deps in graph().items() for d in deps if d not in known)
    assert not missing, "\n".join(missing)
