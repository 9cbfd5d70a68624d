"""A clinical test's reference and start, in the words the result page and the report print."""

from __future__ import annotations

from mimucap.session.recorded.clinical_test_results import reference_text, start_text

TUG_REFERENCE = {"key": "total_s", "mean": 9.2, "ci95_low": 8.2, "ci95_high": 10.2, "group": "adults 70-79 years",
                 "statistic": "mean and 95% confidence interval (s)", "source": "Bohannon 2006"}


def test_a_confidence_interval_reads_as_one_range():
    assert reference_text("total_s", TUG_REFERENCE) == "mean 9.2 s, 95 % CI 8.2 s to 10.2 s (adults 70-79 years)"
    assert reference_text("walk_out_s", TUG_REFERENCE) == ""  # the reference is of the total time
    percentiles = {"key": "total_s", "p25": 8.0, "p75": 11.0, "group": "adults"}
    assert reference_text("total_s", percentiles) == "25th percentile 8.0 s, 75th percentile 11.0 s (adults)"


def test_where_the_test_was_timed_from_reads_as_a_phrase():
    assert start_text("sensors: the start of rising from the chair") == \
        "the start of rising from the chair, found by the sensors"
    assert start_text("marker 'test start'") == "the marker 'test start'"
