"""Run many ``python -m hammerstein`` processes for the price of one interpreter start.

Started by the ``forked_cli`` fixture of ``tests/cli/conftest.py`` as
``python forked_cli.py`` with a JSON list of jobs on stdin; prints one JSON
list of results on stdout. This interpreter imports the CLI, every command
module and the numerical stack they load (numpy, scipy, pandas, matplotlib,
numba, python-control) ONCE; each job is then a forked child that sets up its
standard file descriptors, then runs ``runpy.run_module("hammerstein",
run_name="__main__")`` - exactly what ``python -m hammerstein ARGS`` runs -
and ends with the console script's own ``os._exit(status)``. The properties
these jobs check are those of the process (its real file descriptors 1 and 2,
closed or full, a reader leaving early, exit status after ``os._exit``,
several processes updating one file); what is not reproduced is the
interpreter's start-up (environment variables read by the dependencies at
import time), which ``tests/cli/test_issue22.py`` checks in fresh processes.

A job is a dict: ``argv`` (list of str), ``stdout`` and ``stderr`` each one of
``"pipe"`` (captured), ``"closed"`` (fd closed before the command starts, as
``os.close`` in the process), ``"full"`` (``/dev/full``), ``"head"`` (stdout
only: a pipe whose reader takes 10 bytes and closes it), ``group`` (jobs of
one group run at the same time; groups run one after the other), ``cwd`` and
``warnings`` (a :func:`warnings.simplefilter` action, as ``PYTHONWARNINGS``),
``signal`` (a signal number sent once the directory ``out`` holds an entry
whose name starts with ``prefix``, i.e. a report is in progress, while the
process is held stopped (SIGSTOP, then SIGCONT) so that it cannot finish between
the look and the signal; with ``workers``: once the process also has child
processes, the figure workers;
the child starts with the signal's default disposition, or ignoring it with
``ignored``, as under ``nohup``).
A result is a dict ``status`` (exit status, or -signal), ``stdout``,
``stderr`` (text captured, else None), for a ``signal`` job ``signalled``
(False when the command ended before) and ``workers`` (the child processes
seen before the signal) and ``workers_alive`` (those of them still running,
not zombies, up to 20 s after the command ended).
"""

import gc
import json
import os
import runpy
import signal
import sys
import tempfile
import time
import traceback
import warnings

import control

from hammerstein.cli.main import build_parser

build_parser()          # every command module, hence everything the commands import
control.ss              # python-control is a lazy module: `list` uses it (DC gains)

# What is imported above lives as long as every child: out of the collector's reach (as in
# the figure workers, hammerstein/report/render.py), a child's collections do not walk, and
# so do not copy, the inherited pages of the whole numerical stack again.
gc.collect()
gc.freeze()

STATUS_IF_RETURNED = 99  # the console script ends with os._exit and never returns


def _child(job, out, err, head):
    os.chdir(job.get("cwd") or os.getcwd())
    for fd, how, path in ((1, job.get("stdout", "pipe"), out), (2, job.get("stderr", "pipe"), err)):
        if how == "closed":
            os.close(fd)
        elif how == "full":
            target = os.open("/dev/full", os.O_WRONLY)
            os.dup2(target, fd)
            os.close(target)
        elif how == "head":
            os.dup2(head[1], fd)
        else:
            target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
            os.dup2(target, fd)
            os.close(target)
    if head is not None:
        os.close(head[0])
        os.close(head[1])
    if job.get("warnings"):
        warnings.simplefilter(job["warnings"])
    if "signal" in job and job["signal"] != signal.SIGKILL:
        # as started from a terminal: the signal's default disposition, whatever this process
        # inherited (under `nohup` or a CI runner SIGHUP is ignored, and the command rightly
        # keeps ignoring it: it would finish with 0 instead of being interrupted)
        signal.signal(job["signal"], signal.SIG_IGN if job.get("ignored") else signal.SIG_DFL)
    sys.argv = ["hammerstein", *job["argv"]]
    runpy.run_module("hammerstein", run_name="__main__", alter_sys=True)


def _start(i, job, work):
    out, err = os.path.join(work, f"{i}.out"), os.path.join(work, f"{i}.err")
    head = os.pipe() if job.get("stdout") == "head" else None
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        try:
            _child(job, out, err, head)
        except BaseException:   # noqa: BLE001 - reported through the exit status and stderr
            traceback.print_exc()
        os._exit(STATUS_IF_RETURNED)
    if head is not None:
        os.close(head[1])
    return pid, out, err, head


def _children(pid):
    kids = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    stat_ = fh.read()
            except OSError:
                continue
            if int(stat_.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(d))
    return kids


def _running(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _state(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return "Z"


def _frozen_in_progress(pid, out, prefix):
    """Stop the process (SIGSTOP) and tell whether its report is still in progress.

    While it is stopped it can neither finish nor rename its temporary, so a signal queued
    now lands in the middle of the report; without /proc the look is taken as it is.
    """
    os.kill(pid, signal.SIGSTOP)
    if os.path.isdir(f"/proc/{pid}"):
        deadline = time.monotonic() + 10
        while _state(pid) not in ("T", "t", "Z", "X") and time.monotonic() < deadline:
            time.sleep(0.001)
        if _state(pid) in ("Z", "X"):
            return False
    return os.path.isdir(out) and any(n.startswith(prefix) for n in os.listdir(out))


def _exited(pid):
    done, wait_status = os.waitpid(pid, os.WNOHANG)
    return (done != 0), wait_status


def _signal(job, pid):
    """Send the job's signal once its report is in progress; returns (result fields, status or None)."""
    deadline = time.monotonic() + 120
    out, prefix, workers = job["out"], job["prefix"], []
    while time.monotonic() < deadline:
        done, wait_status = _exited(pid)
        if done:
            return {"signalled": False, "workers": [], "workers_alive": []}, wait_status
        busy = os.path.isdir(out) and any(n.startswith(prefix) for n in os.listdir(out))
        if busy and job.get("workers"):
            workers = _children(pid)
        if busy and (workers or not job.get("workers")):
            break
        time.sleep(0.005)
    if job["signal"] != signal.SIGKILL and not _frozen_in_progress(pid, out, prefix):
        # the command ended (or renamed its report) between the look and the signal: on a busy
        # machine this window is real, and a signal to a finished process proves nothing
        os.kill(pid, signal.SIGCONT)
        _, wait_status = os.waitpid(pid, 0)
        return {"signalled": False, "workers": workers, "workers_alive": []}, wait_status
    os.kill(pid, job["signal"])
    if job["signal"] != signal.SIGKILL:
        os.kill(pid, signal.SIGCONT)   # the signal is pending: it is taken on continuing
    _, wait_status = os.waitpid(pid, 0)
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and any(_running(w) for w in workers):
        time.sleep(0.05)
    alive = [w for w in workers if _running(w)]
    for w in alive:
        os.kill(w, signal.SIGKILL)     # the defect: do not leave them behind
    return {"signalled": True, "workers": workers, "workers_alive": alive}, wait_status


def _read(path):
    try:
        with open(path, encoding="utf-8", errors="backslashreplace") as fh:
            return fh.read()
    except FileNotFoundError:
        return None


def main():
    jobs = json.load(sys.stdin)
    work = tempfile.mkdtemp(prefix="forked-cli-")
    results = [None] * len(jobs)
    for group in sorted({job.get("group", i) for i, job in enumerate(jobs)}, key=str):
        members = [i for i, job in enumerate(jobs) if job.get("group", i) == group]
        started = {i: _start(i, jobs[i], work) for i in members}
        for i, (pid, out, err, head) in started.items():
            if head is not None:   # the reader takes 10 bytes and leaves
                os.read(head[0], 10)
                os.close(head[0])
            extra, wait_status = {}, None
            if "signal" in jobs[i]:
                extra, wait_status = _signal(jobs[i], pid)
            if wait_status is None:
                _, wait_status = os.waitpid(pid, 0)
            results[i] = {"status": os.waitstatus_to_exitcode(wait_status),
                          "stdout": _read(out), "stderr": _read(err), **extra}
            for path in (out, err):
                if os.path.exists(path):
                    os.remove(path)
    os.rmdir(work)
    print(json.dumps(results))


if __name__ == "__main__":
    main()
