"""User strings in messages and reports, and the names the project writes (behind :mod:`hammerstein.core.files`).

:func:`escape` and :func:`markdown_escape` quote what a user wrote (control
characters made visible, long strings cut); :func:`name_problem` and
:func:`c_name_problem` check names that become file names or C identifiers
(ISO/IEC 9899:1999, Sections 6.4.1-6.4.2).
"""

from __future__ import annotations

import re



# -- user strings in messages and reports -------------------------------------------------
#: Longest excerpt of a user string quoted in a message (characters).
EXCERPT = 200


def escape(text, limit=EXCERPT):
    """A user string made safe to print on one terminal line.

    Control characters (escape sequences, NUL, newlines, DEL, C1 controls,
    bidirectional overrides) become Python-style escapes (``\\x1b``,
    ``\\n``) and a long string is cut to ``limit`` characters with the
    number left out, so a file name or a value can neither forge a line
    nor drive the terminal.

    Parameters
    ----------
    text : object
        Converted with ``str``.
    limit : int or None
        Longest excerpt (characters); None: no cut.

    Returns
    -------
    str

    Examples
    --------
    >>> escape("a\\x1b]0;owned\\x07b\\nerror: x")
    'a\\\\x1b]0;owned\\\\x07b\\\\nerror: x'
    >>> escape("x" * 300, limit=5)
    'xxxxx... (295 more characters)'
    """
    s = str(text)
    cut = ""
    if limit is not None and len(s) > limit:
        cut, s = f"... ({len(s) - limit} more characters)", s[:limit]
    if s.isprintable():
        return s + cut
    out = []
    for ch in s:
        if ch.isprintable() or ch == " ":
            out.append(ch)
        else:
            code = ord(ch)
            out.append({"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(ch) or
                       (f"\\x{code:02x}" if code < 0x100 else
                        f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"))
    return "".join(out) + cut


def markdown_escape(text, limit=None):
    """A user string made safe for one line of Markdown (report.md).

    :func:`escape` first (no control characters or newlines), then the
    characters Markdown or HTML would interpret (``\\ ` * _ { } [ ] < > ( )
    # + - ! | ~``) are backslash-escaped.

    Parameters
    ----------
    text : object
    limit : int or None
        As :func:`escape`.

    Returns
    -------
    str

    Examples
    --------
    >>> markdown_escape("<script>*x*</script>")
    '\\\\<script\\\\>\\\\*x\\\\*\\\\</script\\\\>'
    """
    s = escape(text, limit)
    return "".join("\\" + ch if ch in "\\`*_{}[]<>()#+-!|~" else ch for ch in s)


def markdown_text(text, limit=None):
    """A user string made safe for a Markdown heading or running text, read as written.

    :func:`escape` first, then only the characters that act inside a line
    are backslash-escaped (``\\ ` * _ [ ] < > ~ |``): emphasis, code, links,
    HTML and strikethrough. ``-``, ``+``, ``(``, ``)``, ``#`` and ``!`` are
    left as they are (they act only at the start of a line, which a heading
    or a sentence never gives them, or after a ``[`` that is escaped), so a
    title such as "2-DOF (realistic-2dof)" reads as written in the source.

    Parameters
    ----------
    text : object
    limit : int or None
        As :func:`escape`.

    Returns
    -------
    str

    Examples
    --------
    >>> markdown_text("Fig. 9: 50-200 Hz (2-DOF)")
    'Fig. 9: 50-200 Hz (2-DOF)'
    >>> markdown_text("<b>*x*</b>")
    '\\\\<b\\\\>\\\\*x\\\\*\\\\</b\\\\>'
    """
    s = escape(text, limit)
    return "".join("\\" + ch if ch in "\\`*_[]<>~|" else ch for ch in s)




#: Longest name of a signal, model or C prefix turned into a file name [characters].
MAX_NAME_CHARS = 100


def name_problem(name, what="name", limit=MAX_NAME_CHARS):
    """Why ``name`` cannot become (part of) a file name (one line), or None.

    Refused: an empty name, ``.`` or ``..``, a path separator (``/``,
    ``\\``), a control character (newline, escape, NUL, DEL, C1, and the
    bidirectional overrides), or more than ``limit`` characters.

    Parameters
    ----------
    name : str
    what : str
        What the name is, for the message (``"--inputs name"``).
    limit : int
        Longest name [characters].

    Returns
    -------
    str or None

    Examples
    --------
    >>> name_problem("x") is None
    True
    >>> name_problem("../evil", "--inputs name")
    "--inputs name '../evil': a path separator ('/'); expected a plain name"
    """
    s = str(name)
    if not s.strip() or s in (".", ".."):
        return f"{what} '{escape(s)}': expected a non-empty name (not '.' or '..')"
    if len(s) > limit:
        return f"{what} '{escape(s, 40)}': {len(s)} characters; expected at most {limit}"
    for sep in ("/", "\\"):
        if sep in s:
            return f"{what} '{escape(s)}': a path separator ({sep!r}); expected a plain name"
    if not s.isprintable():
        bad = next(c for c in s if not c.isprintable())
        return (f"{what} '{escape(s)}': a control character ({escape(bad)}); "
                f"expected printable characters")
    return None


#: Identifiers a C prefix may not be: the C keywords and the names the standard library owns.
C_RESERVED = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else",
    "enum", "extern", "float", "for", "goto", "if", "inline", "int", "long", "register",
    "restrict", "return", "short", "signed", "sizeof", "static", "struct", "switch", "typedef",
    "union", "unsigned", "void", "volatile", "while", "bool", "true", "false", "alignas",
    "alignof", "static_assert", "thread_local", "noreturn", "complex", "imaginary", "main",
    "errno", "assert", "setjmp", "longjmp", "offsetof", "va_arg", "va_start", "va_end",
    "va_copy", "va_list", "NULL", "EOF", "FILE", "stdin", "stdout", "stderr", "size_t",
    "ptrdiff_t", "math_errhandling", "INFINITY", "NAN", "HUGE_VAL", "signal", "raise", "exit",
    "abort", "malloc", "free", "memcpy", "memset", "printf", "sin", "cos", "exp", "log", "pow",
    "sqrt", "fabs", "floor", "ceil", "round", "fmin", "fmax", "tanh"}
#: Base names of the C standard headers (and of the FMI headers an FMU includes).
C_HEADERS = {
    "assert", "complex", "ctype", "errno", "fenv", "float", "inttypes", "iso646", "limits",
    "locale", "math", "setjmp", "signal", "stdalign", "stdarg", "stdatomic", "stdbit",
    "stdbool", "stdckdint", "stddef", "stdint", "stdio", "stdlib", "stdnoreturn", "string",
    "tgmath", "threads", "time", "uchar", "wchar", "wctype", "unistd", "fcntl", "strings",
    "fmi2Functions", "fmi2FunctionTypes", "fmi2TypesPlatform", "fmi3Functions"}
_C_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,39}")


def c_name_problem(name, what="--name"):
    """Why ``name`` cannot be the prefix and file stem of exported C code (one line), or None.

    It must be a C identifier of 1-40 letters, digits or ``_`` not starting
    with a digit; not a keyword or a name the C library owns
    (:data:`C_RESERVED`: ``main``, ``errno``, ...); not reserved to the
    implementation (starting with ``__`` or ``_`` and a capital letter);
    and not the base name of a standard header (:data:`C_HEADERS`, compared
    without case: ``math.h`` would shadow ``<math.h>``).

    Parameters
    ----------
    name : str
    what : str
        The option, for the message.

    Returns
    -------
    str or None

    Examples
    --------
    >>> c_name_problem("piezo_x") is None
    True
    >>> c_name_problem("math").startswith("--name: 'math' is the name of the C standard header")
    True
    """
    if not isinstance(name, str) or not _C_IDENT.fullmatch(name):
        return (f"{what}: expected a C identifier of 1-40 letters, digits "
                f"or '_' not starting with a digit, found '{escape(name, 60)}'")
    if name in C_RESERVED:
        return (f"{what}: {name!r} is a C keyword or a name the C library owns; "
                f"choose another prefix (e.g. {name}_comp)")
    if name.startswith("__") or re.match(r"_[A-Z]", name):
        return (f"{what}: {name!r} is reserved to the C implementation (it starts with '__' or "
                f"'_' and a capital letter); choose another prefix")
    if name.lower() in {h.lower() for h in C_HEADERS}:
        return (f"{what}: {name!r} is the name of the C standard header <{name.lower()}.h>, which "
                f"{name}.h would shadow; choose another prefix (e.g. {name}_comp)")
    return None
