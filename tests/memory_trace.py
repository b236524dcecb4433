"""The memory a writer takes, for the tests of the writers that work by blocks of rows."""

from __future__ import annotations

import tracemalloc


class ByteCounter:
    """A file-like sink that keeps only the number of bytes written to it."""

    size = 0

    def write(self, b):
        """Count ``b``'s length [bytes or characters]."""
        self.size += len(b)


def traced_write(write):
    """Run ``write(sink)`` on a :class:`ByteCounter` under tracemalloc.

    Parameters
    ----------
    write : callable
        ``write(sink)``; its return value is passed on.

    Returns
    -------
    result : object
        What ``write`` returned.
    size : int
        Bytes written to the sink.
    peak : int
        The peak of the memory traced while it ran [bytes].
    """
    sink = ByteCounter()
    tracemalloc.start()
    try:
        result = write(sink)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return result, sink.size, peak
