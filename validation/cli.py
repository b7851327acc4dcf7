"""`uvms`: the testbed's command line.

  uvms scenarios                                   list the scenarios (name, tags, description)
  uvms controllers                                 list the controller presets, one line each
  uvms build [--scenarios A,B] [--controllers C,D] [--ctl key=value ...] [--workers K]
                                                   compile what those runs need, ahead, in parallel
  uvms run NAME [--set key=value ...] [--controller C] [--ctl key=value ...] [--mismatch M]
               [--seed N] [--out DIR] [--video FILE] [--record FILE] [--plots DIR] [--latency L [--strict]]
                                                   run one in closed loop against MuJoCo
  uvms view FILE.rrd                               open a recording in the Rerun viewer
  uvms campaign [--scenarios A,B] [--controllers C,D] [--ctl key=value ...] [--mismatch M]
               [--seeds N] [--first-seed K] [--workers K | --cluster ADDRESS] [--out DIR] [--latency L [--strict]]
               [--timeout SECONDS] [--resume]
                                                   run many, each row written as it finishes, with a
                                                   progress bar, intervals and paired tests at the end
  uvms compare A B                                 two campaigns' folders on the same runs: rates, the
                                                   exact McNemar test, rare failures and near misses
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from validation.scenarios import SCENARIOS, get
from validation.summary import Summary


def _overrides(pairs: list[str]) -> dict[str, str]:
    out = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ValueError(f"override {pair!r} is malformed; allowed: key=value")
        out[key.strip()] = value.strip()
    return out


def _view(path: Path) -> int:
    """Start Rerun's viewer on a recording (the `rerun` executable installed with rerun-sdk)."""
    import os
    import shutil
    import subprocess

    if not path.is_file():
        raise ValueError(f"recording {path} does not exist; allowed: an .rrd file written by uvms run --record")
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or sys.platform == "darwin"):
        raise ValueError("no display to open the viewer on; allowed: a machine with a display "
                         f"(or copy {path} to one and run `rerun {path}` there)")
    viewer = shutil.which("rerun", path=str(Path(sys.executable).parent)) or shutil.which("rerun")
    if viewer is None:
        raise ValueError("the rerun executable is missing; allowed: an environment with rerun-sdk installed")
    return subprocess.call([viewer, str(path)])


def _mismatch(text: str) -> str:
    """The mismatch spec: a name ("default", "wide", "none") or the terms themselves (one line if bad)."""
    from validation import mismatch

    return mismatch.resolve(text)


def _print_summary(s: Summary) -> None:
    rows = [("verdict", f"{s.verdict}: {s.reason}"), ("controller", s.controller), ("modes", " > ".join(s.modes)),
            ("min hull distance [m]", f"{s.min_hull_distance:.3f}"),
            ("hull contact impulse [N s]", f"{s.hull_contact_impulse:.3f}"),
            ("other arm-link contact impulse [N s]", f"{s.link_contact_impulse:.3f}"),
            ("peak end-effector force [N]", f"{s.ee_peak_contact_force:.0f} "
             f"(max total thrust along the wall normal: {s.max_total_thrust_along_wall_normal:.0f})"),
            ("final task error [m]", f"{s.final_task_error:.3f}"),
            ("mismatch (seed)", f"{s.mismatch['spec'] or 'none'} ({s.mismatch['seed']}): "
             + ", ".join(f"{k} {v:.3g}" for k, v in s.mismatch["values"].items())
             + (f"; told weight in water {s.mismatch['told_trim']:.2f} N" if s.mismatch.get("told_trim") is not None
                else "")),
            ("fallbacks", str(s.fallbacks)),
            ("switches to Mode II", s.switches),
            ("step time median / p95 [ms]", ", ".join(f"{m}: {1e3 * v.median_s:.0f} / {1e3 * v.p95_s:.0f}"
                                                      for m, v in s.solve_time.items())),
            ("simulated / wall clock [s]", f"{s.simulated_s:.1f} / {s.wall_clock_s:.1f}")]
    if s.latency != "none":
        rows.insert(-1, (f"steps over the latency {s.latency}", ", ".join(
            f"{m}: {v.overruns} of {v.steps}" for m, v in s.solve_time.items())))
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvms", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    sub.add_parser("scenarios", help="list the scenarios")
    sub.add_parser("controllers", help="list the controller presets")
    build = sub.add_parser("build", help="compile the generated code of scenarios and controllers ahead")
    run = sub.add_parser("run", help="run one scenario in closed loop against MuJoCo")
    run.add_argument("scenario", help="a scenario name (uvms scenarios)")
    run.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scenario setting by its dotted key, e.g. initial.pitch=15, "
                          "current.velocity=0.1,0.4,0 or duration=2 (validation.scenarios)")
    run.add_argument("--out", type=Path, default=Path("out"), help="folder for summary.json (default: out)")
    run.add_argument("--video", type=Path, help="write an MP4 rendered headlessly (EGL)")
    run.add_argument("--record", type=Path, help="write a Rerun recording (.rrd)")
    run.add_argument("--plots", type=Path, help="folder for telemetry figures (PNG)")
    run.add_argument("--controller", default="switching", help="a preset (uvms controllers; default: switching) "
                     "or package.module:Class of your own (controller.protocol)")
    for parser in (run,):
        parser.add_argument("--mismatch", default="default",
                            help='plant-vs-controller mismatch: "default", "wide", "none" or terms (mass*U(0.9,1.1))')
        parser.add_argument("--seed", type=int, default=0, help="seed of the mismatch draw")
    view = sub.add_parser("view", help="open a recording in the Rerun viewer (needs a display)")
    view.add_argument("recording", type=Path)
    camp = sub.add_parser("campaign", help="run many scenarios and controllers in worker processes")
    camp.add_argument("--scenarios", default=",".join(n for n in SCENARIOS if "kane" not in SCENARIOS[n].tags),
                      help="comma-separated names (default: all but those tagged kane)")
    camp.add_argument("--controllers", default="switching,mode1-only,braking",
                      help="comma-separated presets or package.module:Class")
    camp.add_argument("--workers", type=int, default=2, help="runs at once on this machine (default 2)")
    camp.add_argument("--cluster", metavar="ADDRESS", help="a Dask scheduler's address (tcp://host:8786) to run on "
                      "instead, or local:N for a Dask cluster of N workers on this machine")
    camp.add_argument("--out", type=Path, default=Path("out/campaign"),
                      help="folder for results.csv, results.md, success.png, runs/ (default: out/campaign)")
    camp.add_argument("--resume", action="store_true", help="finish the campaign in --out: run only what has no row")
    camp.add_argument("--timeout", type=float, metavar="SECONDS", help="stop a run after this long and record it "
                      "as timeout (default: none)")
    cmp = sub.add_parser("compare", help="compare two campaigns' result folders on the same runs")
    cmp.add_argument("a", type=Path)
    cmp.add_argument("b", type=Path)
    camp.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override for every scenario")
    camp.add_argument("--mismatch", default="default", help='as for run: "default", "wide", "none" or terms')
    camp.add_argument("--seeds", type=int, default=1, help="mismatch draws per scenario (seeds K..K+N-1)")
    camp.add_argument("--first-seed", type=int, default=0, metavar="K", help="the first seed (default 0)")
    default_scenarios = ",".join(n for n in SCENARIOS if "kane" not in SCENARIOS[n].tags)
    build.add_argument("--scenarios", default=default_scenarios, help="comma-separated names (default: all but kane)")
    build.add_argument("--controllers", default="switching,mode1-only,braking", help="comma-separated")
    build.add_argument("--workers", type=int, default=None, help="processes (default: the cores)")
    for parser in (run, camp, build):
        parser.add_argument("--ctl", action="append", default=[], metavar="KEY=VALUE",
                            help="override a controller setting, dotted, e.g. mode3.horizon=10")
    for parser in (run, camp):
        parser.add_argument("--latency", default="none",
                            help='computation delay: "none" (the plant waits for the controller; default), '
                                 '"measured" (each step\'s own wall-clock time on this machine) or seconds; '
                                 '"@II,III" after it delays only the steps of those modes')
        parser.add_argument("--strict", action="store_true",
                            help="strict real time: a step that overruns the latency has its answer discarded for "
                                 "the input the controller committed in advance (needs --latency in seconds)")
    args = ap.parse_args(argv)
    if getattr(args, "strict", False) and not args.latency.endswith(":strict"):
        args.latency += ":strict"
    try:
        if args.command == "scenarios":
            rows = [(name, ",".join(sc.tags), sc.description) for name, sc in SCENARIOS.items()]
            width, tag_width = (max(len(r[k]) for r in rows) for k in (0, 1))
            for name, tags, description in rows:
                print(f"{name:<{width}}  {tags:<{tag_width}}  {description}")
            return 0
        if args.command == "controllers":
            from validation import presets
            table = presets.load()
            width = max(len(n) for n in table)
            for name, p in table.items():
                print(f"{name:<{width}}  {p.description}")
            return 0
        if args.command == "build":
            from validation import precompile, presets
            controllers, ctl = [c for c in args.controllers.split(",") if c], _overrides(args.ctl)
            for c in controllers:
                presets.resolve(c, ctl)
            built = precompile.build([get(n) for n in args.scenarios.split(",") if n], controllers, ctl, args.workers)
            print(f"built {built} pieces" if built else "everything is compiled already")
            return 0
        if args.command == "view":
            return _view(args.recording)
        if args.command == "campaign":
            from validation import presets
            from validation.campaign import campaign
            controllers = [c for c in args.controllers.split(",") if c]
            ctl = _overrides(args.ctl)
            for c in controllers:
                presets.resolve(c, ctl)  # an unknown name or setting fails here, in one line
            overrides = _overrides(args.set)
            scenarios = [get(n).with_overrides(overrides) for n in args.scenarios.split(",") if n]
            from validation import report
            rows = campaign(scenarios, controllers, args.workers, args.out, _mismatch(args.mismatch), args.seeds,
                            args.first_seed, args.latency, ctl, cluster=args.cluster, resume=args.resume,
                            timeout=args.timeout)
            print(report.statistics_text(rows))
            print(f"wrote {args.out}/results.csv (a row per run), results.md, success.png, runs/*/summary.json")
            return 0 if all(r.get("verdict") not in report.UNFINISHED for r in rows) else 1
        if args.command == "compare":
            from validation import report
            print(report.compare(args.a, args.b))
            return 0
        scenario = get(args.scenario).with_overrides(_overrides(args.set))
        from validation import precompile, presets
        from validation.closed_loop import make_folders, parse_latency
        from validation.closed_loop import run as run_scenario  # heavy imports only when running
        ctl, mismatch = _overrides(args.ctl), _mismatch(args.mismatch)
        presets.resolve(args.controller, ctl)  # bad input fails here, in one line, before any compiling
        parse_latency(args.latency)
        make_folders(args.out, args.video.parent if args.video else None, args.record.parent if args.record else None,
                args.plots)
        precompile.build([scenario], [args.controller], ctl)
        summary = run_scenario(scenario, controller=args.controller, ctl=ctl, mismatch=mismatch, seed=args.seed,
                               latency=args.latency, out=args.out, video=args.video, record=args.record,
                               plots=args.plots)
    except ValueError as e:
        print(f"uvms: error: {e}", file=sys.stderr)
        return 2
    _print_summary(summary)
    written = [args.out / "summary.json", *(p for p in (args.video, args.record, args.plots) if p)]
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
