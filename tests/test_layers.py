"""The package's layering (DESIGN.md §2): imports go only downward, and the NLP engine knows no
orbits. Read from the source with `ast`, so a new upward import fails here, not in review."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "jaxlpm"
BOTTOM = {"constants", "status", "linalg", "implicit", "_validation", "_cpu_runtime",
          "compilation", "mapping"}
# each layer may import itself, the bottom layer and what is listed (transitively closed)
ALLOWED = {
    "collocation": set(),
    "orbits": set(),
    "nlp": {"collocation"},
    "dynamics": {"orbits"},
    "solution": {"dynamics", "orbits", "collocation"},
    "problems": {"solution", "nlp", "dynamics", "orbits", "collocation"},
    "solvers": {"problems", "solution", "nlp", "dynamics", "orbits", "collocation"},
    "verify": {"problems", "solution", "nlp", "dynamics", "orbits", "collocation"},
}
BELOW_CASES = {"solvers", "verify", "problems", "solution", "nlp", "dynamics", "orbits",
               "collocation"}
ALLOWED["batch"] = BELOW_CASES
ALLOWED["io"] = BELOW_CASES
ALLOWED["plot"] = BELOW_CASES
ALLOWED["design"] = BELOW_CASES | {"batch"}
ALLOWED["cases"] = set(ALLOWED) | {"batch"}


def _layer(module: str) -> str:
    return module.split(".")[0]


def _imports(path: Path):
    """jaxlpm modules imported by a source file, as dotted names relative to the package."""
    rel = path.relative_to(PACKAGE).with_suffix("")
    here = list(rel.parts[:-1]) if rel.name != "__init__" else list(rel.parts[:-1])
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - (node.level - 1)] if node.level > 1 else here
                mod = ".".join(base + ([node.module] if node.module else []))
                if not mod:                  # `from . import x` at the package root
                    for alias in node.names:
                        yield alias.name
                    continue
                yield mod
            elif node.module and node.module.startswith("jaxlpm"):
                yield node.module.removeprefix("jaxlpm").lstrip(".")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("jaxlpm."):
                    yield alias.name.removeprefix("jaxlpm.")


def test_imports_go_only_downward():
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        layer = _layer(str(path.relative_to(PACKAGE).with_suffix("")).replace("/", "."))
        if layer not in ALLOWED:
            continue                          # the top: __init__, cli
        for mod in _imports(path):
            target = _layer(mod)
            if target and target != layer and target not in BOTTOM | ALLOWED[layer]:
                wrong.append(f"{path.relative_to(PACKAGE)} imports jaxlpm.{mod}")
    assert not wrong, "\n".join(wrong)


def test_the_nlp_engine_imports_no_orbital_mechanics():
    nlp = sorted((PACKAGE / "nlp").rglob("*.py"))
    assert nlp, "the engine package is missing"
    imported = {_layer(m) for p in nlp for m in _imports(p)}
    assert not imported & {"orbits", "dynamics", "problems", "solvers", "verify", "batch",
                           "cases", "constants"}, imported
