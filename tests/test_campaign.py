"""Campaigns lose nothing and decide: rows written as runs finish, a resume after SIGKILL that runs
every run exactly once, a dying worker or a run past its timeout recorded as that run's failure,
the same rows on a Dask cluster as on the local pool, and the paired test of two result folders."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import psutil
import pytest

from validation import results
from validation.campaign import campaign
from validation.cli import main
from validation.mismatch import DEFAULT
from validation.scenarios import get
from validation.summary import Summary

ROOT = Path(__file__).resolve().parent.parent
PD = "examples.pd_station_keeper:PDStationKeeper"
SHORT = replace(get("avoid-wall"), duration=0.3)  # s: a run of a few steps


def _keys(rows: list[dict]) -> list[results.Key]:
    return [results.key(r) for r in rows]


def _without_timings(row: dict) -> dict:
    return {k: v for k, v in row.items() if k not in results.TIMING_FIELDS}


def test_dying_workers_are_recorded_and_every_other_run_is_unchanged(tmp_path) -> None:
    """Two controllers that take their process down (a segfault; SIGKILL, as the OOM killer sends it)
    run beside the PD example and the braking baseline. Each crashing run is its own row, "worker
    died" with the signal; every other row equals, timings aside, the same runs in a campaign without
    the crashers (the oracle: the crash costs nobody else anything); each good run has its summary."""
    crashers = ["tests.crashing_controllers:Segfaulting", "tests.crashing_controllers:Killed"]
    rows = campaign([SHORT], [PD, crashers[0], "braking", crashers[1]], workers=2, out=tmp_path / "with", seeds=2)
    alone = campaign([SHORT], [PD, "braking"], workers=2, out=tmp_path / "alone", seeds=2)
    assert sorted(_keys(rows)) == sorted({*_keys(rows)})  # every run once
    died = {r["controller"]: r for r in rows if r["verdict"] == "worker died"}
    assert set(died) == set(crashers) and len([r for r in rows if r["verdict"] == "worker died"]) == 4
    assert "SIGSEGV" in died[crashers[0]]["reason"] and "SIGKILL" in died[crashers[1]]["reason"]
    good = [_without_timings(r) for r in rows if r["controller"] not in crashers]
    assert good == [_without_timings(r) for r in alone]
    for r in rows:
        path = results.summary_path(tmp_path / "with", results.key(r))
        assert path.is_file() == (r["controller"] not in crashers)
        if path.is_file():
            assert Summary.read(path).verdict == r["verdict"]
    assert (tmp_path / "with" / "success.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_run_past_its_timeout_is_stopped_and_recorded(tmp_path) -> None:
    """A controller whose step never returns, with a 10 s timeout (a few-step run of the others takes
    well under a second once its process has imported the testbed, which the timeout does not
    count): its row is "timeout", the braking run beside it succeeds."""
    rows = campaign([SHORT], ["tests.crashing_controllers:Hanging", "braking"], workers=2, out=tmp_path, timeout=10)
    by = {r["controller"]: r for r in rows}
    assert by["tests.crashing_controllers:Hanging"]["verdict"] == "timeout"
    assert "10 s" in by["tests.crashing_controllers:Hanging"]["reason"]
    assert by["braking"]["verdict"] == "success"


def _run_processes(pid: int) -> set[int]:
    """The pids of a campaign's run processes (validation.isolated) among its children; one that
    exits while being looked at (a zombie, or gone) is skipped: it ended on its own."""
    found = set()
    for child in psutil.Process(pid).children():
        with contextlib.suppress(psutil.ZombieProcess, psutil.NoSuchProcess):
            if "validation.isolated" in " ".join(child.cmdline()):
                found.add(child.pid)
    return found


def test_a_campaign_killed_halfway_resumes_with_every_run_exactly_once(tmp_path) -> None:
    """`uvms campaign` of 16 runs is sent SIGKILL once 5 rows are on disk; a line cut short is added as
    a kill in mid-write would leave it; `--resume` then finishes. Every run has exactly one row and a
    summary whose verdict is the row's; the killed campaign's run processes exit on their own; its
    manifest (written at the start) is kept in the resumed one's."""
    out = tmp_path / "c"
    argv = ["campaign", "--scenarios", "avoid-wall", "--set", "duration=0.3", "--controllers", f"braking,{PD}",
            "--seeds", "8", "--workers", "2", "--out", str(out)]
    proc = subprocess.Popen([sys.executable, "-m", "validation.cli", *argv], cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline, children = time.monotonic() + 300, set()
    while len(results.read_rows(out)) < 5:
        assert proc.poll() is None and time.monotonic() < deadline, "the campaign ended before 5 rows"
        children |= _run_processes(proc.pid)
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    kept = results.read_rows(out)
    assert 5 <= len(kept) < 16
    assert json.loads((out / "manifest.json").read_text())["settings"]["status"] == "running"  # kept by the kill
    with (out / results.CSV).open("a") as fh:
        fh.write("avoid-wall,braking,7,succ")  # the cut line of a run that is not done
    gone = time.monotonic() + 10
    while any(psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE for p in children):
        assert time.monotonic() < gone, "a run process outlived its killed campaign by 10 s"
        time.sleep(0.2)
    assert main([*argv, "--resume"]) == 0
    rows = results.read_rows(out)
    expected = {("avoid-wall", c, s) for c in ("braking", PD) for s in range(8)}
    assert sorted(_keys(rows)) == sorted(expected)  # each exactly once
    assert all(r in rows for r in kept)  # the rows from before the kill are kept as they were
    for r in rows:
        assert Summary.read(results.summary_path(out, results.key(r))).verdict == r["verdict"]
    done = json.loads((out / "manifest.json").read_text())
    assert done["settings"]["runs_done_before"] == len(kept) and done["settings"]["status"] == "finished"
    assert done["settings"]["earlier"]["settings"]["status"] == "running" and done["wall_time_s"] > 0


def test_resume_refuses_another_campaign_and_a_new_one_refuses_old_results(tmp_path) -> None:
    """A folder holds one campaign: a fresh start into it, or a resume with other settings, is one
    line naming what differs and what is allowed (no run starts); a bad cluster address writes
    nothing."""
    campaign([SHORT], ["braking"], workers=1, out=tmp_path)
    with pytest.raises(ValueError, match="already holds a campaign's results; allowed: --resume"):
        campaign([SHORT], ["braking"], workers=1, out=tmp_path)
    with pytest.raises(ValueError, match="other mismatch, seeds; allowed"):
        campaign([SHORT], ["braking"], workers=1, out=tmp_path, mismatch=DEFAULT, seeds=2, resume=True)
    with pytest.raises(ValueError, match="holds no campaign"):
        campaign([SHORT], ["braking"], workers=1, out=tmp_path / "empty", resume=True)
    with pytest.raises(ValueError, match="allowed: local:N with N >= 1"):
        campaign([SHORT], ["braking"], workers=1, out=tmp_path / "bad-cluster", cluster="local:0")
    assert not (tmp_path / "bad-cluster").exists()  # so the corrected command can use the folder


@pytest.mark.slow
def test_a_dask_cluster_gives_the_local_pools_rows(tmp_path) -> None:
    """A real Dask LocalCluster of 2 worker processes, reached through `uvms campaign --cluster ADDRESS`
    like any cluster, runs wall-headon (Mode I, II and III of the switching NMPC) and avoid-wall, 2 s
    each, with the switching NMPC and the braking baseline on two seeds of the default mismatch:
    every row and every summary equals, timings aside, the local pool's on the same seeds (runs are
    deterministic given their data, whichever process or host runs them)."""
    from distributed import LocalCluster

    argv = ["campaign", "--scenarios", "wall-headon,avoid-wall", "--set", "duration=2.0", "--controllers",
            "switching,braking", "--seeds", "2", "--first-seed", "7"]
    assert main([*argv, "--workers", "2", "--out", str(tmp_path / "local")]) == 0
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        assert main([*argv, "--cluster", cluster.scheduler_address, "--out", str(tmp_path / "dask")]) == 0
    local, dask = (sorted(results.read_rows(tmp_path / f), key=results.key) for f in ("local", "dask"))
    assert len(local) == 8 and [_without_timings(r) for r in dask] == [_without_timings(r) for r in local]
    assert {r["verdict"] for r in local} <= {"success", "hull contact", "arm contact", "tip overload"}
    assert any("III" in r["modes"] for r in local)
    for r in local:
        a, b = (Summary.read(results.summary_path(tmp_path / f, results.key(r))) for f in ("local", "dask"))
        assert a.without_timings() == b.without_timings()
    engine = json.loads((tmp_path / "dask" / "manifest.json").read_text())["settings"]["engine"]
    assert engine["engine"] == "dask distributed" and engine["workers"] == 2


def _folder(path: Path, verdicts: dict[tuple[str, int], str], controller: str,
            values: dict[str, list[float]] | None = None) -> Path:
    """A results.csv of these runs' verdicts; `values`: a column's value per run, in the runs' order."""
    path.mkdir()
    with (path / results.CSV).open("w") as fh:
        fh.write(",".join(results.FIELDS) + "\n")
        for i, ((scenario, seed), v) in enumerate(verdicts.items()):
            row = {f: "" for f in results.FIELDS} | {"scenario": scenario, "controller": controller, "seed": seed,
                                                     "verdict": v} | {c: x[i] for c, x in (values or {}).items()}
            fh.write(",".join(str(row[f]) for f in results.FIELDS) + "\n")
    return path


def test_compare_gives_the_paired_counts_and_the_exact_mcnemar_p(tmp_path, capsys) -> None:
    """Two folders on 12 runs: A succeeds on all, B on the first 4; 2 more runs only A has. Paired:
    4 both, 8 only A, 0 only B; the exact McNemar p is 2 * 0.5**8 = 0.0078 (closed form), read as
    "A is better"; the unpaired runs are named. Then 3 against 3 discordant: within noise."""
    runs = [("wall-headon", s) for s in range(6)] + [("wall-oblique", s) for s in range(6)]
    a = _folder(tmp_path / "A", {**dict.fromkeys(runs, "success"), ("extra", 0): "success", ("extra", 1): "success"},
                "switching")
    b = _folder(tmp_path / "B", {r: "success" if i < 4 else "hull contact" for i, r in enumerate(runs)}, "mode1-only")
    assert main(["compare", str(a), str(b)]) == 0
    text = capsys.readouterr().out
    assert "4 / 8 / 0 / 0" in text and "p = 0.0078" in text and "A: switching is better" in text
    assert "2 runs of A and 0 of B have no partner" in text
    c = _folder(tmp_path / "C", {r: "success" if i < 9 else "hull contact" for i, r in enumerate(runs)}, "x")
    d = _folder(tmp_path / "D", {r: "success" if (i < 6 or i >= 9) else "hull contact" for i, r in enumerate(runs)},
                "y")
    assert main(["compare", str(c), str(d)]) == 0
    assert "within noise (p = 1)" in capsys.readouterr().out


def test_compare_gives_the_sign_test_of_the_task_errors_and_hull_distances(tmp_path, capsys) -> None:
    """Twelve runs in two families, every run a success in both folders: A's final task error is
    lower on 11 (0.01 m against 0.05 m) and equal on one; its hull distance higher on 4, lower on 8.
    Closed forms: the sign test of 11 against 0 is 2 * 0.5**11 = 0.00098, of 4 against 8 it is
    0.39 (2 * P[Bin(12, 1/2) <= 4] = 2 * 794 / 4096); the medians and differences as written."""
    runs = [("current-steady", s) for s in range(6)] + [("current-gust", s) for s in range(6)]
    ok = dict.fromkeys(runs, "success")
    a = _folder(tmp_path / "A", ok, "observer", {"final_task_error": [0.01] * 11 + [0.05],
                                                  "min_hull_distance": [0.3] * 4 + [0.1] * 8})
    b = _folder(tmp_path / "B", ok, "switching", {"final_task_error": [0.05] * 12, "min_hull_distance": [0.2] * 12})
    assert main(["compare", str(a), str(b)]) == 0
    text = capsys.readouterr().out
    assert "| final task error [m] | all | 0.010 | 0.050 | -0.040 | 11 / 0 / 1 | 0.00098 |" in text
    assert "| final task error [m] | current-gust | 0.010 | 0.050 | -0.040 | 5 / 0 / 1 | 0.062 |" in text
    assert "| hull's smallest distance [m] | all | 0.100 | 0.200 | -0.100 | 4 / 8 / 0 | 0.39 |" in text


def test_the_success_plot_draws_rates_of_none_and_all(tmp_path) -> None:
    """Families at 0/3 and 3/3 (where the Wilson bounds meet the rate up to rounding) plot without
    error, as a PNG."""
    from validation import report

    rows = [{"scenario": f, "controller": "c", "seed": s, "verdict": v} for f, v in (("none", "hull contact"),
                                                                                   ("all", "success"))
            for s in range(3)]
    path = report.plot(rows, tmp_path / "success.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_counts_rare_failures_and_their_precursors_on_the_same_runs(tmp_path, capsys) -> None:
    """Ten thrusters-dead runs: A's hull within 5 cm in runs 0-1, B's in runs 0-9 (hull contacts in
    runs 8-9 of B); Mode III handed back in A's run 0 and every B run. Paired near misses 0 only A
    against 8 only B: 2 * 0.5**8 = 0.0078 (closed form); hull contacts 0 / 2: p = 0.5; hand-backs
    0 / 9: 2 * 0.5**9 = 0.0039. An event neither has (arm-link contact) is left out."""
    runs = [("thrusters-dead", s) for s in range(10)]
    a = _folder(tmp_path / "A", dict.fromkeys(runs, "success"), "spin", {
        "min_hull_distance": [0.01, 0.04] + [0.2] * 8, "hull_contact_impulse": [0.0] * 10,
        "link_contact_impulse": [0.0] * 10, "modes": ["II > III > II"] + ["II > III"] * 9})
    b = _folder(tmp_path / "B", {r: "success" if i < 8 else "hull contact" for i, r in enumerate(runs)}, "default", {
        "min_hull_distance": [0.03] * 8 + [-0.001] * 2, "hull_contact_impulse": [0.0] * 8 + [4.0, 9.0],
        "link_contact_impulse": [0.0] * 10, "modes": ["II > III > II"] * 10})
    assert main(["compare", str(a), str(b)]) == 0
    text = capsys.readouterr().out
    assert "| hull within 5 cm | thrusters-dead | 2 | 10 | 0 / 8 | 0.0078 |" in text
    assert "| hull contact | thrusters-dead | 0 | 2 | 0 / 2 | 0.5 |" in text
    assert "| Mode III handed back to Mode II | thrusters-dead | 1 | 10 | 0 / 9 | 0.0039 |" in text
    assert "| arm-link contact | thrusters-dead" not in text


def test_compare_reads_an_older_campaigns_fewer_columns(tmp_path, capsys) -> None:
    """A results.csv of an older campaign (no latency, timing or reason columns) is read for its
    scenario, controller, seed and verdict: 3 only A against 0 gives p = 2 * 0.5**3 = 0.25."""
    for name, verdicts in (("A", ["success"] * 3), ("B", ["hull contact"] * 3)):
        (tmp_path / name).mkdir()
        (tmp_path / name / results.CSV).write_text("scenario,controller,seed,verdict,modes\n" + "".join(
            f"wall-headon,{name.lower()},{s},{v},I\n" for s, v in enumerate(verdicts)))
    assert main(["compare", str(tmp_path / "A"), str(tmp_path / "B")]) == 0
    out = capsys.readouterr().out
    assert "0 / 3 / 0 / 0" in out and "p = 0.25" in out


def test_results_md_sums_each_modes_overruns_over_the_runs() -> None:
    """Under a latency, results.md gives per mode the overran steps over all steps of a controller's
    runs (closed form: 1 + 2 of 4 + 6 in Mode II is 3 of 10, 30%); a mode no run entered is "-",
    and without a latency the table is left out."""
    from validation import report

    rows = [{"scenario": "wall-headon", "controller": "c", "seed": s, "verdict": "success", "latency": "0.05:strict",
             "steps_I": 5, "overruns_I": 0, "steps_II": n, "overruns_II": k, "steps_III": "", "overruns_III": ""}
            for s, (n, k) in enumerate(((4, 1), (6, 2)))]
    md = report.markdown(rows)
    assert "| I | 0 of 10 (0%) |" in md and "| II | 3 of 10 (30%) |" in md and "| III | - |" in md
    assert "overran" not in report.markdown([{**r, "latency": "none"} for r in rows])


def test_results_md_counts_failures_by_kind_and_hull_contacts_by_the_plane_touched() -> None:
    """Reasons written by the closed loop's own verdict (validation.closed_loop.judge) are read back
    per plane: of five thrusters-dead runs, one touches the seafloor, one the wall and then the
    seafloor, one an arm link and one succeeds, and the fifth is a timeout: hull contact 2 (seafloor
    2, wall 1), arm-link contact 1, tip overload 0, not finished 1. All successes: no table."""
    from validation import report
    from validation.closed_loop import judge

    verdicts = [judge(4.0, 300.0, 0.0, 50.0, 200.0, ("seafloor",)), judge(9.0, 400.0, 0.0, 50.0, 200.0,
                ("wall", "seafloor")), judge(0.0, 0.0, 1.0, 50.0, 200.0), judge(0.0, 0.0, 0.0, 50.0, 200.0)]
    rows = [{"scenario": "thrusters-dead", "controller": "c", "seed": s, "verdict": o.value, "reason": why}
            for s, (o, why) in enumerate(verdicts)]
    rows.append({"scenario": "thrusters-dead", "controller": "c", "seed": 4, "verdict": "timeout", "reason": ""})
    assert report.hull_planes(rows[1]) == ("wall", "seafloor")
    md = report.markdown(rows)
    assert "| thrusters-dead | c | 2 (seafloor 2, wall 1) | 1 | 0 | 1 |" in md
    assert "| all | c | 2 (seafloor 2, wall 1) | 1 | 0 | 1 |" in md
    assert "by kind" not in report.markdown([rows[3]])
