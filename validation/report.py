"""What a campaign's rows say: per scenario family and controller the success rate with its 95%
Wilson interval (a markdown table and a figure), the paired counts and exact McNemar test of two
controllers on the same runs, the sign test of their hull distances and task errors on those runs,
the paired counts of rare failures and their precursors (near misses, Mode III's hand-backs), the
failures by kind (hull contacts by the plane touched), and the whole-step times per mode. `uvms compare A B` reads two
result folders the same way."""

from __future__ import annotations

import math
import re
import statistics
from collections.abc import Sequence
from itertools import combinations
from pathlib import Path
from typing import Any

from validation.statistics import Paired, mcnemar_exact, paired, sign_test, wilson

MODES = ("I", "II", "III")
SUCCESS = "success"
COLUMNS = ("scenario", "controller", "seed", "verdict", "modes", "min_hull_distance", "hull_contact_impulse",
           "ee_peak_contact_force", "link_contact_impulse", "fallbacks", "switches", "overruns")


def _fmt(v: Any) -> str:
    if isinstance(v, str):
        try:
            v = int(v) if v.lstrip("-").isdigit() else float(v)
        except ValueError:
            return v
    return f"{v:.3f}" if isinstance(v, float) else str(v)


def _ok(r: dict[str, Any]) -> bool:
    return r.get("verdict") == SUCCESS


def rate(rows: Sequence[dict[str, Any]]) -> tuple[int, int, float, float]:
    """Successes, runs and the 95% Wilson interval of the rate."""
    k, n = sum(map(_ok, rows)), len(rows)
    return (k, n, *wilson(k, n))


def _rate_text(rows: Sequence[dict[str, Any]]) -> str:
    k, n, lo, hi = rate(rows)
    return f"{k}/{n} ({100 * lo:.0f}-{100 * hi:.0f}%)" if n else "-"


UNFINISHED = ("error", "timeout", "worker died")  # verdicts of runs that did not finish (validation.campaign)


def hull_planes(row: dict[str, Any]) -> tuple[str, ...]:
    """The planes a hull-contact run's reason names (validation.closed_loop.judge), in the order of
    their first touch; () when it names none (older results)."""
    m = re.match(r"the hull touched the (.+?) with ", str(row.get("reason", "")))
    return tuple(m.group(1).split(" and the ")) if m else ()


def _failures_text(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Per family (and all) and controller, the failed runs by kind: hull contacts with the runs per
    plane touched (a run touching two planes counts under each), arm-link contacts, tip overloads
    and runs that did not finish. Empty when every run succeeded."""
    if all(map(_ok, rows)):
        return []
    out = []
    for f in [*_names(rows, "scenario"), None]:
        for c in _names(rows, "controller"):
            mine = [r for r in rows if r["controller"] == c and f in (None, r["scenario"])]
            hull = [r for r in mine if r.get("verdict") == "hull contact"]
            planes = [p for r in hull for p in hull_planes(r)]
            where = ", ".join(f"{p} {planes.count(p)}" for p in sorted(set(planes)))
            counts = [sum(r.get("verdict") == v for r in mine) for v in ("arm contact", "tip overload")]
            unfinished = sum(r.get("verdict") in UNFINISHED for r in mine)
            out.append(f"| {f or 'all'} | {c} | {len(hull)}{f' ({where})' if where else ''} | {counts[0]} | "
                       f"{counts[1]} | {unfinished} |")
    return ["", "Failed runs by kind (hull contacts with the runs per plane the hull touched):", "",
            "| scenario | controller | hull contact | arm-link contact | tip overload | not finished |",
            "|---|---|---|---|---|---|", *out]


def _names(rows: Sequence[dict[str, Any]], field: str) -> list[str]:
    return list(dict.fromkeys(str(r[field]) for r in rows))


def pair(rows_a: Sequence[dict[str, Any]], rows_b: Sequence[dict[str, Any]]) -> Paired:
    """Paired counts of two sets of rows on the runs (scenario, seed) they share."""
    a, b = ({(str(r["scenario"]), int(r["seed"])): _ok(r) for r in rows} for rows in (rows_a, rows_b))
    return paired(a, b)


def _paired_line(a: str, b: str, p: Paired) -> str:
    return f"- {a} vs {b}: {p.both} / {p.only_a} / {p.only_b} / {p.neither}; {p.reading(a, b)}"


MEASURES = (("min_hull_distance", "hull's smallest distance [m]", False),
            ("final_task_error", "final task error [m]", True))  # (column, name, lower is better)


def _value(r: dict[str, Any], column: str) -> float:
    try:
        return float(r.get(column) or "nan")
    except ValueError:
        return math.nan


def _measures_text(rows: Sequence[dict[str, Any]], a: str, b: str) -> list[str]:
    """Per measure and family (and all), the two controllers' medians and the sign test on shared runs."""
    families = [*_names(rows, "scenario"), None]
    out = []
    for column, name, lower in MEASURES:
        if not any(math.isfinite(_value(r, column)) for r in rows if r["controller"] in (a, b)):
            continue
        for f in families:
            sel = {c: {(str(r["scenario"]), int(r["seed"])): _value(r, column) for r in rows
                       if r["controller"] == c and f in (None, r["scenario"])} for c in (a, b)}
            t = sign_test(sel[a], sel[b], lower)
            med = [statistics.median(v) if (v := [x for x in sel[c].values() if math.isfinite(x)]) else math.nan
                   for c in (a, b)]
            out.append(f"| {name} | {f or 'all'} | {med[0]:.3f} | {med[1]:.3f} | {t.median_difference:+.3f} | "
                       f"{t.a_better} / {t.b_better} / {t.ties} | {t.p_value:.2g} |")
    if not out:
        return []
    return ["", f"Paired measures, {a} against {b} on the same runs: each one's median, the median of the "
            "difference (first - second), the runs where the first is better / the second / neither, and the "
            "exact two-sided sign test:", "", "| measure | scenario | first | second | difference | "
            "first / second / tie | p |", "|---|---|---|---|---|---|---|", *out]


NEAR_MISS = 0.05  # m: a hull this close to a plane (or touching) counts as a near miss

EVENTS = (  # (name, predicate on a row): rare failures and their more frequent precursors
    ("hull contact", lambda r: _value(r, "hull_contact_impulse") > 0.0),
    (f"hull within {100 * NEAR_MISS:.0f} cm", lambda r: _value(r, "min_hull_distance") < NEAR_MISS),
    ("arm-link contact", lambda r: _value(r, "link_contact_impulse") > 0.0),
    ("tip overload (verdict)", lambda r: r.get("verdict") == "tip overload"),
    ("Mode III handed back to Mode II", lambda r: "III > II" in str(r.get("modes", ""))),
)


def _events_text(rows: Sequence[dict[str, Any]], a: str, b: str) -> list[str]:
    """Per event and family (and all), how many runs of each controller have it, the runs where only
    one of the two does, and the exact two-sided McNemar test of those discordant runs."""
    out = []
    for name, has in EVENTS:
        for f in [*_names(rows, "scenario"), None]:
            sel = {c: {(str(r["scenario"]), int(r["seed"])): bool(has(r)) for r in rows
                       if r["controller"] == c and f in (None, r["scenario"])} for c in (a, b)}
            keys = sorted(set(sel[a]) & set(sel[b]))
            n_a, n_b = (sum(sel[c][k] for k in keys) for c in (a, b))
            if not n_a and not n_b:
                continue
            only_a = sum(sel[a][k] and not sel[b][k] for k in keys)
            only_b = sum(sel[b][k] and not sel[a][k] for k in keys)
            out.append(f"| {name} | {f or 'all'} | {n_a} | {n_b} | {only_a} / {only_b} | "
                       f"{mcnemar_exact(only_a, only_b):.2g} |")
    if not out:
        return []
    return ["", f"Paired events, {a} against {b} on the same runs: how many runs of each have it, the runs where "
            f"only the first / only the second does, and the exact McNemar test (a near miss: the hull's smallest "
            f"distance under {100 * NEAR_MISS:.0f} cm, contacts included):", "",
            "| event | scenario | first | second | only first / only second | p |", "|---|---|---|---|---|---|", *out]


PAIRED_HEAD = ("Paired on the same runs (scenario, seed): both succeed / only the first / only the second / "
               "neither, and the exact McNemar test:")


def statistics_text(rows: Sequence[dict[str, Any]]) -> str:
    """The rates per family and controller, and the paired tests of every two controllers."""
    controllers, families = _names(rows, "controller"), _names(rows, "scenario")
    lines = ["Success (only the end-effector tip touched: zero contact impulse on the hull and on every other arm "
             "link, and the tip's peak force within the jaws' limit) per scenario family, with the 95% Wilson "
             "interval of the rate:", "",
             "| scenario | " + " | ".join(controllers) + " |", "|" + "---|" * (len(controllers) + 1)]
    lines += [f"| {f} | " + " | ".join(_rate_text([r for r in rows if r["scenario"] == f and r["controller"] == c])
                                       for c in controllers) + " |" for f in families]
    lines += ["| all | " + " | ".join(_rate_text([r for r in rows if r["controller"] == c]) for c in controllers)
              + " |"]
    failures = [r for r in rows if r.get("verdict") in UNFINISHED]
    if failures:
        lines += ["", f"{len(failures)} runs did not finish (error, timeout or worker died); they count as "
                  "failures above."]
    lines += _failures_text(rows)
    if len(controllers) > 1:
        lines += ["", PAIRED_HEAD, ""]
        for a, b in combinations(controllers, 2):
            p = pair([r for r in rows if r["controller"] == a], [r for r in rows if r["controller"] == b])
            lines.append(_paired_line(a, b, p))
        for a, b in combinations(controllers, 2):
            lines += _measures_text(rows, a, b)
            lines += _events_text(rows, a, b)
    return "\n".join(lines) + "\n"


def markdown(rows: Sequence[dict[str, Any]]) -> str:
    """results.md: the delay, every run's row, the statistics and the step times."""
    controllers = _names(rows, "controller")
    delays = sorted({str(r.get("latency", "none")) for r in rows} - {"none", ""})
    lines = [f"Computation delay: {', '.join(delays)} (validation.closed_loop: the plant does not wait for the "
             "controller).", ""] if delays else []
    lines += ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(_fmt(r.get(c, "")) for c in COLUMNS) + " |" for r in rows]
    lines += ["", statistics_text(rows).rstrip("\n")]

    def p95(c: str, m: str) -> str:
        ms = [float(r[f"step_p95_{m}_ms"]) for r in rows if r["controller"] == c and r.get(f"step_p95_{m}_ms") not in
              (None, "")]
        return f"{statistics.median(ms):.0f} ({max(ms):.0f})" if ms else "-"

    lines += ["", "Whole-step time per mode (certificate, guesses, solve), each run's p95 [ms]: the median over the "
              "runs (the largest):", "", "| mode | " + " | ".join(controllers) + " |",
              "|" + "---|" * (len(controllers) + 1)]
    lines += [f"| {m} | " + " | ".join(p95(c, m) for c in controllers) + " |" for m in MODES]
    if delays:
        def overran(c: str, m: str) -> str:
            mine = [r for r in rows if r["controller"] == c and r.get(f"steps_{m}") not in (None, "")]
            steps, late = (sum(int(r[f"{k}_{m}"]) for r in mine) for k in ("steps", "overruns"))
            return f"{late} of {steps} ({100 * late / steps:.0f}%)" if steps else "-"

        lines += ["", "Steps that overran the latency, per mode, over the runs:", "",
                  "| mode | " + " | ".join(controllers) + " |", "|" + "---|" * (len(controllers) + 1)]
        lines += [f"| {m} | " + " | ".join(overran(c, m) for c in controllers) + " |" for m in MODES]
    return "\n".join(lines) + "\n"


def plot(rows: Sequence[dict[str, Any]], path: Path) -> Path:
    """success.png: the success rate per scenario family, one colour per controller, with the 95%
    Wilson interval as error bars."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    controllers, families = _names(rows, "controller"), _names(rows, "scenario")
    width = 0.8 / max(1, len(controllers))
    fig, ax = plt.subplots(figsize=(max(6.0, 1.1 * len(families) + 2), 4.0))
    x = np.arange(len(families))
    for i, c in enumerate(controllers):
        stats = [rate([r for r in rows if r["scenario"] == f and r["controller"] == c]) for f in families]
        k, n, lo, hi = (np.array(v, dtype=float) for v in zip(*stats, strict=True))
        p = np.divide(k, n, out=np.full_like(k, np.nan), where=n > 0)
        ax.bar(x + (i - (len(controllers) - 1) / 2) * width, p, width, label=c,
               yerr=np.nan_to_num(np.vstack([p - lo, hi - p])), capsize=3)
    ax.set_xticks(x, families, rotation=30, ha="right")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("success rate (95% Wilson interval)")
    ax.legend(fontsize="small", loc="lower left")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def compare(folder_a: Path, folder_b: Path) -> str:
    """Two result folders on the same scenarios and seeds: each one's rates, and the paired test.
    Folders of one controller each are paired with each other; otherwise each controller present
    in both is paired with its namesake."""
    from validation.results import read_rows

    rows_a, rows_b = read_rows(folder_a), read_rows(folder_b)
    for folder, rows in ((folder_a, rows_a), (folder_b, rows_b)):
        if not rows:
            raise ValueError(f"{folder} holds no results.csv rows; allowed: the --out folder of a uvms campaign")
    ca, cb = _names(rows_a, "controller"), _names(rows_b, "controller")
    if len(ca) == 1 and len(cb) == 1:
        pairs = [(ca[0], cb[0])]
    else:
        pairs = [(c, c) for c in ca if c in cb]
        if not pairs:
            raise ValueError(f"{folder_a} ({', '.join(ca)}) and {folder_b} ({', '.join(cb)}) share no controller; "
                             "allowed: folders of one controller each, or with controllers of the same name")
    name_a, name_b = Path(folder_a).name or str(folder_a), Path(folder_b).name or str(folder_b)
    lines = []
    for a, b in pairs:
        sel_a = [{**r, "controller": f"{name_a}: {a}"} for r in rows_a if r["controller"] == a]
        sel_b = [{**r, "controller": f"{name_b}: {b}"} for r in rows_b if r["controller"] == b]
        runs_a, runs_b = ({(r["scenario"], r["seed"]) for r in s} for s in (sel_a, sel_b))
        lines += [statistics_text([*sel_a, *sel_b]).rstrip("\n")]
        unpaired = len(runs_a ^ runs_b)
        if unpaired:
            lines += ["", f"{len(runs_a - runs_b)} runs of {name_a} and {len(runs_b - runs_a)} of {name_b} have no "
                      "partner on the same scenario and seed; the paired test leaves them out."]
        lines.append("")
    return "\n".join(lines)
