"""The fast blank-line check of the table reader finds exactly the lines _BLANK removes."""

from hypothesis import given, strategies as st

from hammerstein.io.datafiles import _BLANK, _BLANK_AFTER

_line = st.text(alphabet=" \t\r1,.#x", max_size=6).map(str.encode)


@given(st.lists(_line, max_size=12), st.booleans())
def test_fast_check_agrees_with_the_multiline_pattern(lines, final_newline):
    raw = b"\n".join(lines) + (b"\n" if final_newline else b"")
    assert bool(_BLANK.match(raw) or _BLANK_AFTER.search(raw)) == bool(_BLANK.search(raw))
