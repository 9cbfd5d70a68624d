"""Words and numbers as people read them: plurals, and no sign on a figure that rounds to zero."""

import math

from mimucap.core.wording import fixed, plural


def test_plurals():
    assert [plural(n, "marker") for n in (0, 1, 2)] == ["0 markers", "1 marker", "2 markers"]
    assert plural(2, "analysis", "analyses") == "2 analyses"


def test_no_minus_zero():
    assert fixed(-0.004, 2) == "0.00" and fixed(-0.04, 1) == "0.0" and fixed(-0.06, 1) == "-0.1"
    assert fixed(math.nan, 1) == "–" and fixed(None, 1) == "–" and fixed(12.345, 0) == "12"
