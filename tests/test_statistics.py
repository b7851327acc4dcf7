"""Campaign statistics against scipy's independent implementations."""

from __future__ import annotations

import math

import pytest
from scipy import stats

from validation.statistics import mcnemar_exact, paired, sign_test, wilson


@pytest.mark.parametrize(("k", "n"), [(0, 5), (3, 8), (26, 27), (27, 27), (64, 72), (1, 1000)])
def test_wilson_interval_matches_scipy(k: int, n: int) -> None:
    """Oracle: scipy.stats.binomtest(k, n).proportion_ci(method="wilson"); 1e-12 (the same closed form,
    evaluated in another order)."""
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert wilson(k, n) == pytest.approx((ci.low, ci.high), abs=1e-12)


@pytest.mark.parametrize(("b", "c"), [(0, 0), (3, 8), (6, 2), (0, 7), (10, 10), (1, 30)])
def test_exact_mcnemar_is_the_two_sided_binomial_test(b: int, c: int) -> None:
    """Oracle: scipy's exact two-sided binomial test of b successes in b + c trials at p = 1/2 (the
    exact McNemar test); 1e-12."""
    expected = 1.0 if b + c == 0 else stats.binomtest(b, b + c, 0.5).pvalue
    assert mcnemar_exact(b, c) == pytest.approx(expected, abs=1e-12)


def test_paired_counts_only_shared_runs() -> None:
    a = {("x", 0): True, ("x", 1): True, ("x", 2): False, ("y", 0): False, ("z", 9): True}
    b = {("x", 0): True, ("x", 1): False, ("x", 2): True, ("y", 0): False}
    p = paired(a, b)
    assert (p.both, p.only_a, p.only_b, p.neither) == (1, 1, 1, 1)
    assert "within noise" in p.reading("A", "B")


@pytest.mark.parametrize("n", [1, 3, 25, 200])
def test_wilson_bounds_are_exact_at_none_and_all(n: int) -> None:
    """Closed form: the interval of 0/n starts at 0 and that of n/n ends at 1, exactly (the rate's
    error bars are then never negative)."""
    assert wilson(0, n)[0] == 0.0 and wilson(n, n)[1] == 1.0


def test_sign_test_counts_the_runs_each_way_and_matches_scipy() -> None:
    """Eight shared runs: A lower on 6, higher on 1, one tie; a NaN run and a run only A has are left
    out. Oracle: scipy's exact two-sided binomial test of 6 in 7 at 1/2 (the sign test drops ties),
    1e-12; the median of the differences in closed form (their sorted middle pair). Read the other way
    (higher is better) the counts swap."""
    a = {("x", i): v for i, v in enumerate([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, math.nan])} | {("y", 0): 0.0}
    b = {("x", i): v for i, v in enumerate([2.0, 4.0, 3.5, 5.0, 5.5, 7.0, 6.0, 8.0, 1.0])}
    t = sign_test(a, b, lower_is_better=True)
    assert (t.a_better, t.b_better, t.ties) == (6, 1, 1)
    assert t.p_value == pytest.approx(stats.binomtest(6, 7, 0.5).pvalue, abs=1e-12)
    assert t.median_difference == pytest.approx(-0.75)  # the differences sorted: -2 -1 -1 -1 -.5 -.5 0 1
    flipped = sign_test(a, b, lower_is_better=False)
    assert (flipped.a_better, flipped.b_better) == (1, 6) and flipped.p_value == t.p_value
    assert math.isnan(sign_test({}, b, True).median_difference) and sign_test({}, b, True).p_value == 1.0
