"""Mode III's IPOPT on recorded problems: where its time goes and which solver options change it.

Mode III is the slowest mode (bench/results/nmpc_modes.md): about 30 interior-point iterations of
about 4 ms each. This benchmark replays the Mode III problems that MuJoCo closed loops actually
posed, so that a change of solver or options is measured offline, side by side, on the same set.

  python bench/mode3_solvers.py --record 2   # only record the problems of `--controller` (a preset;
                                             # default: switching) on wall-headon, wall-oblique and
                                             # arm-deployed, seeds 0-1 (1 min)
  python bench/mode3_solvers.py              # every option set of OPTIONS on them (about 15 min)
  python bench/mode3_solvers.py --record 2 --families thrusters-dead
  python bench/mode3_solvers.py --record 24 --latency 0.05 --ctl mode3_entry_intervals=none
                                             # under a fixed 50 ms delay, with a setting overridden
  python bench/mode3_solvers.py --options default,converged --name mode3_solvers_thrusters_dead
                                             # the option sets whose names start so, on thrusters-dead's problems
  python bench/mode3_solvers.py --horizons 5,10   # the default options on the problems cut to each
                                             # horizon (intervals; at most the recorded one), 4 min
  python bench/mode3_solvers.py --breakdown  # the default options: where an iteration's time goes
                                             # (IPOPT's timing of the derivative callbacks), 1 min

--record writes out/mode3_problems.npz (not committed, 1-2 MB; the closed loops are deterministic, so
recording again gives the same problems on the same machine): per problem, the measured state, the primal guess
(Algorithm 2's for a cold start, else the shifted recomputed plan), the multipliers of a warm start
(NaN for a cold one), the input bounds (failed thrusters), the contact plane and the horizon (the
vectors NaN-padded to the longest horizon's length, trimmed on loading). The evaluation
writes bench/results/mode3_solvers.md: per option set, usable solves, iterations, solve time
(median, p95), ms per iteration, and the cost against the default's on the problems both solve.
Solve times are wall clock on a shared machine; the iterations are what the options change.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.mode3 import ModeIIIOCP, ModeIIISettings, ModeIIISolution
from controller.model import ModelOptions, UVMSModel
from uvms import load_params, load_scene
from uvms.scene import Scene

OUT = Path(__file__).parent / "results"
PROBLEMS = Path(__file__).parent.parent / "out" / "mode3_problems.npz"
FAMILIES = ("wall-headon", "wall-oblique", "arm-deployed")

# name: IPOPT options on top of Mode III's own (controller.mode3)
OPTIONS: dict[str, dict] = {
    "default (MUMPS, monotone barrier)": {},
    "MUMPS ordering AMD": {"mumps_pivot_order": 0},
    "MUMPS ordering PORD": {"mumps_pivot_order": 4},
    "MUMPS without scaling": {"mumps_permuting_scaling": 0, "mumps_scaling": 0},
    "no iterative refinement": {"min_refinement_steps": 0},
    "adaptive barrier (Mehrotra oracle)": {"mu_strategy": "adaptive"},
    "adaptive barrier (probing oracle)": {"mu_strategy": "adaptive", "mu_oracle": "probing"},
    "gentler Hessian perturbations": {"perturb_dec_fact": 0.1, "first_hessian_perturbation": 1e-2},
    "L-BFGS Hessian": {"hessian_approximation": "limited-memory"},
    "SPRAL instead of MUMPS (in CasADi's wheel)": {"linear_solver": "spral"},
    "filter's infeasibility limit x1": {"theta_max_fact": 1.0},
    "filter's infeasibility limit x0.1": {"theta_max_fact": 0.1},
    "first acceptable iterate": {"acceptable_iter": 1},
    "limit x1 and first acceptable iterate": {"theta_max_fact": 1.0, "acceptable_iter": 1},
    "converged (no acceptable-level stop)": {"acceptable_iter": 0},
    "warm: barrier from 1e-6": {"mu_init": 1e-6},
    "warm: barrier from 1e-3": {"mu_init": 1e-3},
    "warm: barrier from 1e-2": {"mu_init": 1e-2},
    "warm: bound pushes 1e-3": {"warm_start_bound_push": 1e-3, "warm_start_mult_bound_push": 1e-3},
    "warm: primal guess only (the cold solver's options)": {"warm_start_init_point": "no", "mu_init": 1e-2},
}


def _record_run(args: tuple[str, int, str, str, dict[str, str]]) -> list[dict]:
    """The Mode III problems of one closed loop (family, seed, preset, latency, settings overridden)."""
    from validation.scenarios import SCENARIOS

    family, seed, preset, latency, ctl = args
    return record_problems(SCENARIOS[family], seed, preset, latency, ctl)


def record_problems(scenario, seed: int, preset: str, latency: str = "none",
                    ctl: dict[str, str] | None = None) -> list[dict]:
    """The Mode III problems of one closed loop (`latency` as validation.closed_loop.run takes it, `ctl`
    the preset's settings overridden), as the controller's on_solve hook reports them."""
    from controller.switching import SolveEvent, SwitchingController
    from validation import presets
    from validation.closed_loop import run

    calls: list[dict] = []

    def recording(e: SolveEvent) -> None:
        if e.kind != "mode3":
            return
        h0, guess, current, duals = (*e.args, *(None,) * (4 - len(e.args)))[:4]
        calls.append({"h0": np.array(h0), "guess": np.array(guess), "current": np.zeros(3) if current is None
                      else np.array(current), "lam_g": None if duals is None else np.array(duals[0]),
                      "lam_x": None if duals is None else np.array(duals[1]), "lo": e.ocp._lo_u.copy(),
                      "hi": e.ocp._hi_u.copy(), "contact": e.ocp.contact, "horizon": e.ocp.settings.horizon,
                      "model_options": json.dumps(asdict(e.ocp.model.options)), "iterations": e.solution.iterations})

    run(scenario, seed=seed, latency=latency,
        controller=SwitchingController(presets.resolve(preset, ctl).settings, recording))
    return calls


def record(seeds: int, workers: int, controller: str, families: tuple[str, ...] = FAMILIES,
           latency: str = "none", ctl: dict[str, str] | None = None) -> None:
    jobs = [(f, s, controller, latency, ctl or {}) for f in families for s in range(seeds)]
    calls: list[dict] = []
    with ProcessPoolExecutor(workers) as ex:
        for c in tqdm(ex.map(_record_run, jobs), total=len(jobs), desc="closed loops", unit="run"):
            calls += c
    save(calls, seeds, families, latency, ctl)


def save(calls: list[dict], seeds: int, families: tuple[str, ...], latency: str = "none",
         ctl: dict[str, str] | None = None) -> None:
    """The recorded problems to PROBLEMS (with how they were recorded)."""
    if not any(c["lam_g"] is not None for c in calls):
        raise SystemExit("no warm-started Mode III problem in these runs; allowed: more seeds")
    PROBLEMS.parent.mkdir(exist_ok=True)
    columns = {k: [c[k] for c in calls] for k in calls[0]}
    np.savez_compressed(PROBLEMS, **{k: _padded(v) if k in VECTORS else np.array(v) for k, v in columns.items()},
                        seeds=seeds, families=",".join(families), latency=latency, ctl=json.dumps(ctl or {}))
    print(f"{len(calls)} problems ({sum(c['lam_g'] is None for c in calls)} cold) -> {PROBLEMS}")


VECTORS = ("guess", "lam_g", "lam_x")  # per problem, as long as its horizon makes them (a cold one: no multipliers)


def _padded(rows: list[np.ndarray | None]) -> np.ndarray:
    """Rows of different lengths (None: none) as one array, each padded with NaN (load_problems trims them)."""
    width = max(len(r) for r in rows if r is not None)
    return np.array([np.full(width, np.nan) if r is None else np.pad(r, (0, width - len(r)), constant_values=np.nan)
                     for r in rows])


def load_problems() -> tuple[dict[str, Any], np.ndarray, UVMSModel, Scene]:
    """The recorded problems, which of them are cold starts, the controller's model and the scene."""
    if not PROBLEMS.exists():
        raise SystemExit(f"{PROBLEMS} is missing; allowed: run `python bench/mode3_solvers.py --record 2` first")
    data = dict(np.load(PROBLEMS))
    scene = load_scene()
    if "model_options" not in data or len(set(data["model_options"])) != 1 or "horizon" not in data:
        raise SystemExit(f"{PROBLEMS} does not hold one controller model's options and each problem's horizon; "
                         "allowed: record again")
    options = ModelOptions(**json.loads(str(data["model_options"][0])))
    cold = np.isnan(data["lam_g"][:, 0])
    for k in VECTORS:  # each row without its padding (problems of different horizons share the array)
        data[k] = [row[:int(np.flatnonzero(np.isfinite(row))[-1]) + 1] if np.isfinite(row).any() else row
                   for row in data[k]]
    return data, cold, UVMSModel(load_params(), scene.water, options), scene


def replayed(data: dict[str, Any], cold: np.ndarray, model: UVMSModel, scene: Scene,
             ipopt_options: dict | None = None) -> Iterator[tuple[int, ModeIIIOCP, ModeIIISolution]]:
    """Each recorded problem solved as the controller posed it (its plane, horizon, input bounds, guess
    and, when warm, multipliers), with `ipopt_options` on Mode III's own: (its index, the problem
    object, the solution), one problem object per plane and horizon."""
    ocps: dict[tuple[int, int], ModeIIIOCP] = {}
    for i in range(len(cold)):
        key = (int(data["contact"][i]), int(data["horizon"][i]))
        if key not in ocps:
            ocps[key] = ModeIIIOCP(model, scene.planes, key[0],
                                   ModeIIISettings(horizon=key[1], ipopt_options=ipopt_options or {}))
        ocp = ocps[key]
        ocp.limit_inputs(data["lo"][i], data["hi"][i])
        duals = None if cold[i] else (data["lam_g"][i], data["lam_x"][i])
        yield i, ocp, ocp.solve(data["h0"][i], data["guess"][i], data["current"][i], duals)


def recorded(data: dict[str, np.ndarray]) -> str:
    """The scenarios whose closed loops posed the recorded problems."""
    return str(data["families"]).replace(",", ", ") if "families" in data else ", ".join(FAMILIES)


def mp(v: np.ndarray) -> str:
    """median / p95 of v, rounded ("-" when empty)."""
    return f"{np.median(v):.0f} / {np.percentile(v, 95):.0f}" if len(v) else "-"


def evaluate(prefixes: tuple[str, ...] = ("",), stem: str = "mode3_solvers") -> None:
    """The option sets whose names start with one of `prefixes` (the first of them in OPTIONS is the
    reference row) on the recorded problems; writes bench/results/{stem}.md."""
    data, cold, model, scene = load_problems()
    n = len(cold)
    results: dict[str, list[tuple]] = {}
    chosen = {k: v for k, v in OPTIONS.items() if k.startswith(prefixes)}
    for name, opts in tqdm(chosen.items(), desc="option sets", unit="set"):
        results[name] = [(sol.status.usable, sol.iterations, sol.solve_time, sol.cost)
                         for _, _, sol in replayed(data, cold, model, scene, opts)]
    base = results[next(iter(chosen))]
    ref = np.array([b[3] for b in base])
    lines = ["# Mode III's IPOPT on recorded problems", "",
             f"`python bench/mode3_solvers.py` ({platform.machine()}, casadi {ca.__version__}, IPOPT with MUMPS). "
             f"{n} Mode III problems ({int(cold.sum())} cold starts from Algorithm 2's guess, {n - int(cold.sum())} "
             "warm starts from the shifted plan and its multipliers) that the controller posed in MuJoCo "
             f"closed loops of {recorded(data)}, seeds 0-{int(data['seeds']) - 1} (`--record`). Iterations and "
             "times: median / p95 over the problems; cost: the median of (cost - the first row's cost) and of "
             "their ratio over the problems both solve, and on how many of them the first row's costs "
             "over 10% more.", "",
             "| options | usable | iterations, warm | iterations, cold | time, warm [ms] | time, cold [ms] "
             "| ms per iteration | cost - first row's | cost / first row's | first row's > 1.1 x |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, rows in results.items():
        ok, it, t, cost = (np.array(c) for c in zip(*rows, strict=True))
        both = ok & np.array([b[0] for b in base])
        dc = np.median(cost[both] - ref[both]) if both.any() else np.nan
        rc = np.median(cost[both] / ref[both]) if both.any() else np.nan
        worse = int(np.sum(ref[both] > 1.1 * cost[both]))

        lines.append(f"| {name} | {int(ok.sum())}/{n} | {mp(it[~cold])} | {mp(it[cold])} | {mp(1e3 * t[~cold])} | "
                     f"{mp(1e3 * t[cold])} | {1e3 * t.sum() / max(it.sum(), 1):.1f} | {dc:+.1e} | {rc:.3g} | {worse} |")
    (OUT / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def cut(ocp: ModeIIIOCP, guess: np.ndarray, duals: tuple[np.ndarray, np.ndarray] | None, recorded: int
        ) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """A recorded problem's primal guess and multipliers (of a `recorded`-interval plan) cut to the
    first ocp.settings.horizon intervals and the state after them."""
    N, nz, ns = ocp.settings.horizon, ocp.nz, ocp.ns
    if N > recorded:
        raise SystemExit(f"horizon {N} is longer than the recorded problems' {recorded}; allowed: at most {recorded}")
    primal = np.concatenate([guess[:N * nz], guess[N * nz:N * nz + ns]])
    if duals is None:
        return primal, None
    lg, lx = duals
    nc = (len(lg) - ns) // recorded
    return primal, (lg[:ns + N * nc], np.concatenate([lx[:N * nz], lx[N * nz:N * nz + ns]]))


def horizons(values: list[int]) -> None:
    """The default options on the recorded problems cut to each horizon, one horizon after the other."""
    data, cold, model, scene = load_problems()
    rows: dict[int, list[tuple]] = {}
    for N in tqdm(values, desc="horizons", unit="horizon"):
        ocps: dict[int, ModeIIIOCP] = {}
        rows[N] = []
        for i in range(len(cold)):
            contact = int(data["contact"][i])
            if contact not in ocps:
                ocps[contact] = ModeIIIOCP(model, scene.planes, contact, ModeIIISettings(horizon=N))
            ocp = ocps[contact]
            nz = ocp.nz
            recorded = (len(data["guess"][i]) - ocp.ns) // nz
            ocp.limit_inputs(data["lo"][i], data["hi"][i])
            guess, duals = cut(ocp, data["guess"][i], None if cold[i] else (data["lam_g"][i], data["lam_x"][i]),
                               recorded)
            sol = ocp.solve(data["h0"][i], guess, data["current"][i], duals)
            rows[N].append((sol.status.usable, sol.iterations, sol.solve_time))
    n = len(cold)
    lines = ["# Mode III's horizon on recorded problems", "",
             f"`python bench/mode3_solvers.py --horizons {','.join(map(str, values))}` ({platform.machine()}, casadi "
             f"{ca.__version__}): the {n} recorded Mode III problems ({int(cold.sum())} cold), each cut to the first N "
             "intervals (primal guess and multipliers), solved with Mode III's default options; one horizon after "
             "the other. Iterations and times: median / p95.", "",
             "| N (intervals of 0.1 s) | usable | iterations, warm | iterations, cold | time, warm [ms] | "
             "time, cold [ms] |", "|---|---|---|---|---|---|"]
    for N, r in rows.items():
        ok, it, t = (np.array(c) for c in zip(*r, strict=True))
        lines.append(f"| {N} | {int(ok.sum())}/{n} | {mp(it[~cold])} | {mp(it[cold])} | {mp(1e3 * t[~cold])} | "
                     f"{mp(1e3 * t[cold])} |")
    (OUT / "mode3_horizon_solves.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


CALLBACKS = ("nlp_hess_l", "nlp_jac_g", "nlp_g", "nlp_grad_f", "nlp_f")


def breakdown() -> None:
    """The default options on every recorded problem: each solve's wall time split into IPOPT's own
    timing of the derivative callbacks (compiled stage functions and CasADi's block assembly) and
    the rest (IPOPT's iteration with MUMPS, and CasADi's call around the solver), per
    interior-point iteration summed over the problems."""
    data, cold, model, scene = load_problems()
    total, iterations, spent = 0.0, 0, dict.fromkeys(CALLBACKS, 0.0)
    for i, ocp, sol in tqdm(replayed(data, cold, model, scene), total=len(cold), desc="problems", unit="problem"):
        stats = (ocp.solver if cold[i] else ocp.warm_solver).stats()
        total, iterations = total + sol.solve_time, iterations + sol.iterations
        for name in CALLBACKS:
            spent[name] += float(stats.get(f"t_wall_{name}", 0.0))
    per = 1e3 / max(iterations, 1)
    rest = total - sum(spent.values())
    lines = ["# Where a Mode III interior-point iteration's time goes", "",
             f"`python bench/mode3_solvers.py --breakdown` ({platform.machine()}, casadi {ca.__version__}, IPOPT "
             f"with MUMPS): the {len(cold)} Mode III problems ({int(cold.sum())} cold) recorded in closed loops of "
             f"{recorded(data)}, seeds 0-{int(data['seeds']) - 1} (`--record`), default options, "
             f"{iterations} iterations in all. Wall time per iteration [ms], summed over the problems; the callbacks "
             "as IPOPT times them (the compiled stage derivatives and CasADi's block assembly around them).", "",
             "| part | ms per iteration | share |", "|---|---|---|"]
    for name in CALLBACKS:
        lines.append(f"| callback {name} | {per * spent[name]:.2f} | {spent[name] / total:.0%} |")
    lines += [f"| the rest: IPOPT with MUMPS (KKT factorizations, solves) and CasADi's call | {per * rest:.2f} | "
              f"{rest / total:.0%} |", f"| whole solve | {per * total:.2f} | 100% |"]
    (OUT / "mode3_breakdown.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", type=int, metavar="SEEDS", help="record the problems of seeds 0..SEEDS-1 first")
    ap.add_argument("--workers", type=int, default=2, help="closed loops in parallel while recording")
    ap.add_argument("--controller", default="switching",
                    help="the preset whose problems --record records (assets/presets.toml)")
    ap.add_argument("--families", default=",".join(FAMILIES), help="comma-separated scenarios --record runs")
    ap.add_argument("--latency", default="none", help="the delay of --record's closed loops (uvms run's --latency)")
    ap.add_argument("--ctl", action="append", default=[], metavar="KEY=VALUE",
                    help="a setting of --controller overridden while recording (repeatable)")
    ap.add_argument("--options", default="", help="comma-separated prefixes of the option sets to compare "
                    "(the first of them in OPTIONS is the reference row; default: all)")
    ap.add_argument("--name", default="mode3_solvers", help="the results file's stem under bench/results")
    ap.add_argument("--horizons", help="comma-separated Mode III horizons to compare instead of the option sets")
    ap.add_argument("--breakdown", action="store_true", help="where an iteration's time goes (not the option sets)")
    a = ap.parse_args(argv)
    if a.record is not None:
        if a.record < 1 or a.workers < 1:
            raise SystemExit(f"--record {a.record}, --workers {a.workers}; allowed: both >= 1")
        from validation.scenarios import SCENARIOS

        families = tuple(f for f in a.families.split(",") if f)
        if not families or any(f not in SCENARIOS for f in families):
            raise SystemExit(f"--families {a.families!r}; allowed: comma-separated names of {sorted(SCENARIOS)}")
        bad = [c for c in a.ctl if "=" not in c]
        if bad:
            raise SystemExit(f"--ctl {bad}; allowed: key=value")
        record(a.record, a.workers, a.controller, families, a.latency, dict(c.split("=", 1) for c in a.ctl))
        return
    if a.horizons:
        try:
            values = [int(v) for v in a.horizons.split(",")]
        except ValueError:
            raise SystemExit(f"--horizons {a.horizons!r}; allowed: comma-separated integers >= 1") from None
        if min(values) < 1:
            raise SystemExit(f"--horizons {a.horizons!r}; allowed: comma-separated integers >= 1")
        horizons(values)
    elif a.breakdown:
        breakdown()
    else:
        prefixes = tuple(p for p in a.options.split(",") if p) or ("",)
        unknown = [p for p in prefixes if not any(k.startswith(p) for k in OPTIONS)]
        if unknown:
            raise SystemExit(f"--options {unknown}; allowed: prefixes of {list(OPTIONS)}")
        evaluate(prefixes, a.name)


if __name__ == "__main__":
    if "--record" in sys.argv:
        sys.exit(main(sys.argv[1:]))
    from validation import manifest

    name = "mode3_breakdown" if "--breakdown" in sys.argv else next(
        (sys.argv[i + 1] for i, v in enumerate(sys.argv[:-1]) if v == "--name"), "mode3_solvers")
    with manifest.recorded(Path(__file__).parent / "results" / f"{name}.manifest.json"):
        main(sys.argv[1:])
