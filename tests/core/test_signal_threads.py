"""Signals and grouped writes when another thread writes files (a figure pool's thread).

The command line turns SIGTERM into :func:`hammerstein.core.files.interrupt`, called in the
main thread. A write by another thread (``safe_write`` of a copied figure, run by the
process pool's management thread) used to share the main thread's count of open
:func:`deferred_signals` blocks: the signal was then held for a block the main thread never
closes, and raised in the figure thread, whose figure it failed: a run sent SIGTERM
while a copied figure was being written could end without ``interrupted``.
"""

import signal
import threading

import pytest

from hammerstein.core.files import (all_or_nothing, deferred_signals, interrupt, reset_interrupt,
                                    safe_write)


@pytest.fixture(autouse=True)
def _forget_the_signal():
    yield
    reset_interrupt()                          # as the command line does when it ends


def _in_thread(body):
    """Run ``body(entered, release)`` in a thread; returns (thread, entered, release, errors)."""
    entered, release, errors = threading.Event(), threading.Event(), []

    def run():
        try:
            body(entered, release)
        except BaseException as exc:  # noqa: BLE001 - the test reads it
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    assert entered.wait(10)
    return thread, release, errors


def test_another_threads_block_does_not_hold_the_main_threads_signal():
    def body(entered, release):
        with deferred_signals():
            entered.set()
            release.wait(10)

    thread, release, errors = _in_thread(body)
    try:
        with pytest.raises(KeyboardInterrupt) as info:
            interrupt(signal.SIGTERM)          # as the handler does, in the main thread
        assert info.value.signum == signal.SIGTERM
    finally:
        release.set()
        thread.join(10)
    assert errors == []                        # nor is it raised in the other thread


def test_the_main_threads_block_still_holds_it_until_its_end():
    with pytest.raises(KeyboardInterrupt):
        with deferred_signals():
            interrupt(signal.SIGINT)           # held: the block goes on
            reached = True
    assert reached


def test_another_threads_write_is_not_part_of_the_main_threads_group(tmp_path):
    # the main thread's all_or_nothing block fails: its file is not written, but a figure
    # thread's write made meanwhile is its own and lands
    def body(entered, release):
        safe_write(tmp_path / "figure.png", b"png")
        entered.set()

    with pytest.raises(OSError):
        with all_or_nothing():
            safe_write(tmp_path / "drive.csv", "t,u\n")
            thread, _, errors = _in_thread(body)
            thread.join(10)
            assert (tmp_path / "figure.png").read_bytes() == b"png"
            raise OSError("disk full")
    assert errors == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figure.png"]


def test_a_swallowed_interruption_is_raised_again_before_the_next_file(tmp_path):
    # compiled code calling back into Python may clear the exception the handler raised there;
    # the command goes on, but it creates or renames nothing more
    try:
        interrupt(signal.SIGTERM)
    except KeyboardInterrupt:
        pass                                   # swallowed
    with pytest.raises(KeyboardInterrupt) as info:
        safe_write(tmp_path / "report.md", "x")
    assert info.value.signum == signal.SIGTERM
    assert list(tmp_path.iterdir()) == []
    reset_interrupt()                          # the command is over: the next one writes
    safe_write(tmp_path / "report.md", "x")
    assert (tmp_path / "report.md").read_text() == "x"
