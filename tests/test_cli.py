"""The command line checks its output paths before computing: an unwritable --out or --json
exits with status 2 and a one-line message naming the path, and the case runner or the sweep
is never called (they are replaced by functions that fail the test if they run)."""

import jax
import pytest

jax.config.update("jax_enable_x64", True)

import jaxlpm.batch  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.cli import main  # noqa: E402


class Computed(Exception):
    """Raised by the stand-ins for the computation: reaching it."""


def computing(*args, **kwargs):
    raise Computed


@pytest.fixture
def no_computation(monkeypatch):
    monkeypatch.setattr(mei2010, "reproduce", computing)
    monkeypatch.setattr(jaxlpm.batch, "sweep", computing)      # what the CLI imports


SWEEP = ["sweep", "mei2010", "--e", "0.1", "--points", "9", "--no-progress"]


# argv from (a regular file f, an existing directory d); the message that must end stderr
@pytest.mark.parametrize("argv, message", [
    (["reproduce", "mei2010", "--out", "{f}/figs"], "--out {f}/figs: {f} is not a directory"),
    (["reproduce", "mei2010", "--out", "{f}"], "--out {f}: it is not a directory"),
    (["reproduce", "mei2010", "--out", "{d}/figs", "--json", "{d}"],
     "--json {d}: it is a directory"),
    (["reproduce", "mei2010", "--json", "{f}/r.json"], "--json {f}/r.json: {f} is not a directory"),
    (SWEEP + ["--out", "{f}/sweep"], "--out {f}/sweep: {f} is not a directory"),
], ids=["reproduce-out-under-file", "reproduce-out-is-file", "reproduce-json-is-dir",
        "reproduce-json-under-file", "sweep-out-under-file"])
def test_unwritable_output_refused_before_computing(argv, message, tmp_path, capsys,
                                                    no_computation):
    paths = dict(f=tmp_path / "file", d=tmp_path / "dir")
    paths["f"].write_text("x")
    paths["d"].mkdir()
    with pytest.raises(SystemExit) as exc:
        main([a.format(**paths) for a in argv])
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.err.endswith(f": error: cannot write {message.format(**paths)}\n")
    assert captured.err.count("\n") == 1 and captured.out == ""


@pytest.mark.parametrize("argv", [
    ["reproduce", "mei2010", "--out", "{t}/new/figs", "--json", "{t}/other/r.json"],
    SWEEP + ["--out", "{t}/new/sweep"],
], ids=["reproduce", "sweep"])
def test_writable_new_paths_reach_the_computation(argv, tmp_path, no_computation):
    """Directories that do not exist yet under a writable one pass the check (which creates
    nothing: a sweep refused later for bad arguments leaves no directory)."""
    with pytest.raises(Computed):
        main([a.format(t=tmp_path) for a in argv])
    assert list(tmp_path.iterdir()) == []
