"""No module of the package writes a file except through the output guard.

Every file a command writes goes through :func:`hammerstein.core.files.safe_write` (a
temporary in the same directory, fsync, rename; inputs and places outside ``--out``
refused). This test walks the package's source with :mod:`ast` and fails on any other way
to write, rename, link or copy a file:

- ``open(path, mode)`` / ``Path.open(mode)`` with ``w``, ``a``, ``x`` or ``+`` (or a mode that is not a constant),
  ``os.open`` with a writing flag, ``os.fdopen`` for writing;
- ``Path.write_text`` / ``write_bytes`` / ``touch`` / ``symlink_to`` / ``hardlink_to``,
  ``Path.rename`` / ``Path.replace`` (one argument);
- ``os.replace`` / ``rename`` / ``renames`` / ``link`` / ``symlink`` / ``truncate``,
  ``shutil.copy*`` / ``move``;
- writers given a path rather than a file object: ``DataFrame.to_csv(path)`` (or
  ``path_or_buf=``), ``savefig(path)``, ``np.save*`` / ``savetxt``, ``ndarray.tofile``,
  PIL ``Image.save(path)``, the report's ``save(fig, path)``, ``zipfile.ZipFile(path, 'w')``.

A file object is recognised by its name (:data:`FILE_OBJECTS`: what ``safe_write`` hands
to a writer, or an in-memory buffer). The allow-list below names the only places that may
do otherwise, each with its reason.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hammerstein"

#: Names of file objects (a ``safe_write`` writer's argument, an in-memory buffer).
FILE_OBJECTS = {"fh", "buf", "buffer", "png", "stream"}

#: (module path relative to the package, function) -> why it may write directly.
ALLOWED = {
    ("core/files.py", "*"): "the output guard itself",
    ("report/figures.py", "save"): "writes the file object it is given (a safe_write handle or "
                                   "a buffer); its calls are checked here",
    ("report/replication.py", "fig08_identified_figure"): "draws into the buffer its caller "
                                                          "passes (README's figure)",
    ("cli/main.py", "_fill_standard_fds"): "reopens file descriptors 0-2, not a file",
    ("cli/main.py", "_silence_stdout"): "points fd 1 at /dev/null, not a file",
    ("export/fmu.py", "compile_binary"): "writes the compiler's sources into the temporary "
                                         "build directory it made (removed after); a failure is "
                                         "said as the FMU's, never as that directory's file",
    ("cli/_common.py", "_reader_gone"): "points a stream whose reader has gone at /dev/null, "
                                        "not a file",
}

_WRITE_FLAGS = {"O_WRONLY", "O_RDWR", "O_CREAT", "O_APPEND", "O_TRUNC"}
_PATH_METHODS = {"write_text", "write_bytes", "touch", "symlink_to", "hardlink_to"}
_OS_CALLS = {"replace", "rename", "renames", "link", "symlink", "truncate"}
_PATH_FIRST = {"to_csv", "savefig", "tofile", "to_parquet", "to_excel", "to_pickle", "save",
               "savetxt", "savez", "savez_compressed", "to_hdf"}


def _name(node):
    """``a.b.c`` of a Name/Attribute chain, or None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return None


def _is_file_object(node):
    return isinstance(node, ast.Name) and node.id in FILE_OBJECTS


def _mode(call, index):
    """The mode argument (positional ``index`` or ``mode=``), or '' when absent."""
    for kw in call.keywords:
        if kw.arg == "mode":
            return kw.value
    return call.args[index] if len(call.args) > index else ""


def _writes_mode(mode):
    if mode == "":
        return False
    if isinstance(mode, ast.Constant) and isinstance(mode.value, str):
        return any(c in mode.value for c in "wax+")
    return True          # not a constant: cannot be shown to read


def problem(call):
    """Why ``call`` writes a file directly, or None."""
    func = call.func
    full = _name(func) or ""
    attr = func.attr if isinstance(func, ast.Attribute) else None
    if full in ("open", "io.open", "codecs.open"):
        if _writes_mode(_mode(call, 1)):
            return f"{full}() for writing"
    elif attr == "open" and full not in ("os.open", "tarfile.open"):       # Path.open(mode)
        if _writes_mode(_mode(call, 0)):
            return "Path.open() for writing"
    elif full == "os.open":
        flags = {n.attr if isinstance(n, ast.Attribute) else getattr(n, "id", None)
                 for arg in call.args[1:2] for n in ast.walk(arg)}
        if flags & _WRITE_FLAGS:
            return "os.open() with a writing flag"
    elif full == "os.fdopen":
        if _writes_mode(_mode(call, 1)):
            return "os.fdopen() for writing"
    elif full.startswith("os.") and attr in _OS_CALLS:
        return f"os.{attr}()"
    elif full.startswith("shutil.") and (attr.startswith("copy") or attr == "move"):
        return f"shutil.{attr}()"
    elif full in ("zipfile.ZipFile", "ZipFile", "tarfile.open"):
        if call.args and not _is_file_object(call.args[0]) and _writes_mode(_mode(call, 1)):
            return f"{full}() on a path for writing"
    elif attr in _PATH_METHODS:
        return f".{attr}()"
    elif attr in ("rename", "replace") and len(call.args) == 1 and not call.keywords:
        return f"Path.{attr}()"
    elif attr in _PATH_FIRST or full == "save":
        index = 1 if full == "save" or full.endswith("plots.save") else 0
        target = call.args[index] if len(call.args) > index else None
        for kw in call.keywords:
            if kw.arg in ("path_or_buf", "fname", "fp", "file", "path"):
                target = kw.value
        if target is not None and not _is_file_object(target):
            return f"{full or attr}() given a path"
    return None


def scan(source, filename="<source>"):
    """``(function, line, why)`` of every direct write in ``source``."""
    found = []

    def visit(node, function):
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) \
                else function
            if isinstance(child, ast.Call):
                why = problem(child)
                if why:
                    found.append((function, child.lineno, why))
            visit(child, name)

    visit(ast.parse(source, filename), "<module>")
    return found


def test_no_module_writes_a_file_outside_the_guard():
    offences = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        for function, line, why in scan(path.read_text(encoding="utf-8"), str(path)):
            if (rel, "*") in ALLOWED or (rel, function) in ALLOWED:
                continue
            offences.append(f"hammerstein/{rel}:{line} ({function}): {why}")
    assert not offences, ("write through hammerstein.core.files.safe_write instead:\n"
                          + "\n".join(offences))


def test_the_allow_list_names_existing_functions():
    """An entry whose function is gone (renamed, removed) must go too."""
    for rel, function in ALLOWED:
        text = (PACKAGE / rel).read_text(encoding="utf-8")
        assert function == "*" or f"def {function}(" in text, (rel, function)


@pytest.mark.parametrize("snippet", [
    "open(p, 'w')", "open(p, mode='ab')", "open(p, m)", "open(p, 'r+')", "p.open('w')",
    "io.open(p, 'x')",
    "os.open(p, os.O_WRONLY | os.O_CREAT)", "os.fdopen(fd, 'wb')",
    "Path(p).write_text('x')", "p.write_bytes(b'')", "p.touch()", "p.symlink_to(q)",
    "os.replace(a, b)", "os.rename(a, b)", "os.link(a, b)", "shutil.copy(a, b)",
    "shutil.copyfile(a, b)", "shutil.move(a, b)", "tmp.replace(target)", "p.rename(q)",
    "frame.to_csv(directory / 'm.csv', index=False)", "frame.to_csv(path_or_buf=p)",
    "fig.savefig('a.png')", "np.savetxt(path, a)", "np.save(p, a)", "a.tofile(p)",
    "image.save(path, format='png')", "save(fig, d / 'c.png')", "plots.save(fig, path)",
    "zipfile.ZipFile(p, 'w')",
])
def test_each_way_of_writing_is_caught(snippet):
    assert scan(f"def f():\n    {snippet}\n"), snippet


@pytest.mark.parametrize("snippet", [
    "open(p)", "open(p, 'rb')", "p.open()", "p.open('rb')", "tarfile.open(p)", "os.open(p, os.O_RDONLY | os.O_NONBLOCK)",
    "frame.to_csv(index=False)", "fig.savefig(fh, format='png')", "np.savetxt(buf, a)",
    "save(fig, buffer)", "zipfile.ZipFile(buf, 'w')", "zipfile.ZipFile(p)",
    "text.replace('a', 'b')", "frame.rename(columns=m)", "safe_write(p, lambda fh: save(f, fh))",
])
def test_reads_and_guarded_writes_pass(snippet):
    assert not scan(f"def f():\n    {snippet}\n"), snippet
