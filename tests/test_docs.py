"""The documentation builds: `mkdocs build --strict` (mkdocs.yml, warnings are errors) into a
temporary directory, and its API reference (mkdocstrings, `docs/reference/`) has an entry
for every public name: `jaxlpm.__all__` and the `__all__` of each public submodule. The
build reads the source statically (griffe: it imports neither jaxlpm nor JAX), needs no
network, and takes a few seconds. The docs tools come with the `test` extra (and the
`docs` one): without them the test fails, it is not skipped."""

import re
import subprocess
import sys
from importlib import import_module
from pathlib import Path
from types import ModuleType

import jaxlpm

ROOT = Path(__file__).resolve().parent.parent
# the public submodules, each with its page docs/reference/<name>.md
SUBMODULES = ("batch", "verify", "nlp", "solution", "collocation", "dynamics", "orbits", "io",
              "plot")


def test_docs_build_strict(tmp_path):
    site = tmp_path / "site"
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--clean",
         "--config-file", str(ROOT / "mkdocs.yml"), "--site-dir", str(site)],
        cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    warnings = [line for line in result.stderr.splitlines() if "WARNING" in line]
    assert not warnings, "\n".join(warnings)
    # the reference was generated from the docstrings, not left as `::: name` directives
    reference = (site / "reference" / "problems" / "index.html").read_text()
    assert 'id="jaxlpm.EnergyOptimalTransfer"' in reference
    assert ":::" not in reference
    for page in ("getting-started", "concepts", "accuracy", "mei2010",
                 "tutorials/eccentric-rendezvous", "tutorials/sensitivity-study",
                 "tutorials/monte-carlo-j2"):
        assert (site / page / "index.html").is_file(), page

    # every public name has its entry: jaxlpm.__all__ and each public submodule's __all__
    ids = set()
    for html in (site / "reference").rglob("*.html"):
        ids.update(re.findall(r'id="(jaxlpm[\w.]*)"', html.read_text()))
    public = [(jaxlpm, name) for name in jaxlpm.__all__]
    for module in SUBMODULES:
        mod = import_module(f"jaxlpm.{module}")
        public += [(mod, name) for name in mod.__all__]
    missing = []
    for mod, name in public:
        obj = getattr(mod, name)
        # a name may be documented where it is defined: `jaxlpm.batch.sweep` is a function
        # and also the submodule defining it, so its entry is jaxlpm.batch.sweep.sweep
        where = {f"{mod.__name__}.{name}",
                 f"{getattr(obj, '__module__', '')}.{getattr(obj, '__qualname__', '')}"}
        if isinstance(obj, ModuleType) and (site / "reference" / name / "index.html").is_file():
            continue                                    # a submodule with its own page
        if not where & ids:
            missing.append(f"{mod.__name__}.{name}")
    assert not missing, f"not in the API reference (docs/reference/*.md): {missing}"
