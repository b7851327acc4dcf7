"""Statistics that decide: success rates with Wilson intervals, the exact McNemar test of two
controllers' successes on the same runs (scenario and seed), and the exact sign test of a measure
of theirs (a distance, an error) on the same runs."""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass

Z95 = 1.959963984540054  # the standard normal's 97.5% quantile


def wilson(successes: int, runs: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval (95% by default) of a binomial rate; (0, 1) for no runs."""
    if runs == 0:
        return 0.0, 1.0
    if not 0 <= successes <= runs:
        raise ValueError(f"{successes} successes in {runs} runs; allowed: 0 <= successes <= runs")
    p, n = successes / runs, runs
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    lo = 0.0 if successes == 0 else max(0.0, centre - half)  # exact at the ends (they are 0 and 1 in closed form)
    hi = 1.0 if successes == runs else min(1.0, centre + half)
    return lo, hi


@dataclass(frozen=True)
class Paired:
    """Two controllers on the same runs: how many both succeed, only A, only B, neither; and the
    exact (binomial) McNemar p-value of the discordant pairs (two-sided)."""

    both: int
    only_a: int
    only_b: int
    neither: int

    @property
    def p_value(self) -> float:
        return mcnemar_exact(self.only_a, self.only_b)

    def reading(self, a: str, b: str, alpha: float = 0.05) -> str:
        """In words: which is better, or that the difference is within noise."""
        if self.p_value > alpha:
            return f"{a} and {b} differ by {abs(self.only_a - self.only_b)} runs: within noise (p = {self.p_value:.2g})"
        better = a if self.only_a > self.only_b else b
        return f"{better} is better (p = {self.p_value:.2g})"


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value for b and c discordant pairs: twice the binomial(b + c, 1/2)
    tail at min(b, c), capped at 1."""
    n, k = b + c, min(b, c)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


@dataclass(frozen=True)
class SignTest:
    """A measure of two controllers on the same runs: how many runs favour A, favour B or tie, the
    median of A's value minus B's, and the exact two-sided sign test of the runs that do not tie."""

    a_better: int
    b_better: int
    ties: int
    median_difference: float  # A - B, in the measure's unit (nan: no shared run)

    @property
    def p_value(self) -> float:
        return mcnemar_exact(self.a_better, self.b_better)  # the same binomial(n, 1/2) test


def sign_test(a: dict[tuple, float], b: dict[tuple, float], lower_is_better: bool) -> SignTest:
    """The sign test over the runs (keys) where both controllers have a finite value."""
    keys = [k for k in sorted(set(a) & set(b)) if math.isfinite(a[k]) and math.isfinite(b[k])]
    d = [a[k] - b[k] for k in keys]
    better = [x < 0 if lower_is_better else x > 0 for x in d]
    ties = sum(x == 0 for x in d)
    median = statistics.median(d) if d else math.nan
    return SignTest(sum(better), len(d) - ties - sum(better), ties, median)


def paired(a: dict[tuple, bool], b: dict[tuple, bool]) -> Paired:
    """Paired counts over the runs (keys, e.g. (scenario, seed)) that both controllers have."""
    keys = sorted(set(a) & set(b))
    return Paired(sum(a[k] and b[k] for k in keys), sum(a[k] and not b[k] for k in keys),
                  sum(b[k] and not a[k] for k in keys), sum(not a[k] and not b[k] for k in keys))
