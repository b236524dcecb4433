"""``identify --model auto`` says when its two best classes tie.

An outside Bouc-Wen stage scored 0.628 % with Preisach and with the generalised PI; the
same stage recorded again with other noise chose the generalised PI (0.622 against 0.628),
and a 30 µm circle's error went from 7.75 to 13.8 %. A choice within the records' noise
is named as such, with how to decide.
"""

import pytest

from hammerstein.identification.identification_pipeline import AUTO_TIE, auto_tie_note


@pytest.mark.parametrize("second, tie", [
    (0.6284, True),                         # the stage's own scores (0.628 printed)
    (0.628 * (1 + AUTO_TIE) * 0.999, True),
    (0.628 * (1 + AUTO_TIE) * 1.001, False),
    (0.70, False),
])
def test_a_second_class_within_the_tie_share_is_named(second, tie):
    note = auto_tie_note({"generalized": second, "preisach": 0.628, "classical": 5.0})
    assert (note is not None) == tie
    if tie:
        # the best first, the runner-up second, never the third
        assert note.startswith("model auto: preisach and generalized score within 2 %")
        assert "classical" not in note and "--model" in note


def test_one_class_has_no_tie():
    assert auto_tie_note({"preisach": 0.6}) is None
