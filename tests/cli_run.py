"""``hammerstein ARGS`` run in a directory by the CLI's ``main()`` in this process.

One helper for the tests that drive the command line and read what it printed
(faster than a subprocess: the compiled kernels and imports stay loaded).
"""

import contextlib
import io
import subprocess

from hammerstein.cli.main import main


def run_cli(*args, cwd):
    """Run ``hammerstein ARGS`` (each argument as ``str``) with ``cwd`` as the directory.

    Parameters
    ----------
    *args : object
        The command line after ``hammerstein``.
    cwd : str or pathlib.Path
        The working directory of the run.

    Returns
    -------
    subprocess.CompletedProcess
        ``returncode``, ``stdout`` and ``stderr`` as a subprocess would give them.
    """
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return subprocess.CompletedProcess(args, code, out.getvalue(), err.getvalue())
