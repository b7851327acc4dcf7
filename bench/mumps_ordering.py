"""MUMPS's fill-reducing ordering under IPOPT, on the Mode II and Mode III problems closed loops posed.

IPOPT factorizes its KKT matrix with MUMPS at every iteration, and MUMPS orders the matrix once per
solve (its analysis phase); IPOPT's default `mumps_pivot_order` 7 lets MUMPS choose. On problems of
a few hundred unknowns the choice changes the time of a solve, not its iterates (up to rounding).
This benchmark replays the recorded problems with each ordering, the orderings interleaved problem by
problem and in a rotated order each round (the machine is shared: drifts hit every ordering alike),
and compares each ordering's per-problem median time with the default's on the same problem.

  python bench/mode3_solvers.py --record 2                    # out/mode3_problems.npz
  python bench/mode2_solvers.py --record 4 --latency 0.05:strict  # out/mode2_solver_problems.pkl
  python bench/mumps_ordering.py [--rounds 3]

Writes bench/results/mumps_ordering.md and its manifest: per mode and ordering, usable solves,
iterations, solve time (median / p95) and, per problem, the ratio of its time to the default's
(median, and on how many problems it is faster, with the two-sided sign test's p).
"""

from __future__ import annotations

import argparse
import json
import pickle
import platform
import sys
from dataclasses import replace
from math import comb
from pathlib import Path

import casadi as ca
import numpy as np
from tqdm import tqdm

from controller.mode2 import ModeIIOCP
from controller.mode3 import ModeIIIOCP, ModeIIISettings
from controller.model import ModelOptions, UVMSModel
from uvms import load_params, load_scene

ROOT = Path(__file__).parent
OUT = ROOT / "results"
MODE3 = ROOT.parent / "out" / "mode3_problems.npz"
MODE2 = ROOT.parent / "out" / "mode2_solver_problems.pkl"
ORDERINGS = {"MUMPS's choice (IPOPT's default, 7)": 7, "AMD (0)": 0, "AMF (2)": 2, "PORD (4)": 4,
             "METIS (5)": 5, "QAMD (6)": 6}


def sign_test(faster: int, slower: int) -> float:
    """Two-sided exact sign test's p of `faster` vs `slower` paired outcomes (ties dropped)."""
    n, k = faster + slower, min(faster, slower)
    return min(1.0, 2 * sum(comb(n, i) for i in range(k + 1)) / 2 ** n) if n else 1.0


def mode3_problems() -> list[dict]:
    """The recorded Mode III problems, each with a `solve(order)` -> (usable, iterations, seconds)."""
    data = dict(np.load(MODE3))
    if "horizon" not in data:
        raise SystemExit(f"{MODE3} lacks each problem's horizon; allowed: record again "
                         "(python bench/mode3_solvers.py --record 2)")
    scene = load_scene()
    model = UVMSModel(load_params(), scene.water, ModelOptions(**json.loads(str(data["model_options"][0]))))
    ocps: dict[tuple[int, int, int], ModeIIIOCP] = {}

    def solver(i: int, order: int) -> ModeIIIOCP:
        key = (int(data["contact"][i]), int(data["horizon"][i]), order)
        if key not in ocps:
            ocps[key] = ModeIIIOCP(model, scene.planes, key[0], ModeIIISettings(
                horizon=key[1], ipopt_options={"mumps_pivot_order": order}))
        return ocps[key]

    out = []
    for i in range(len(data["h0"])):
        cold = bool(np.isnan(data["lam_g"][i][0]))

        def solve(order: int, i: int = i, cold: bool = cold) -> tuple[bool, int, float]:
            ocp = solver(i, order)
            ocp.limit_inputs(data["lo"][i], data["hi"][i])
            duals = None if cold else (data["lam_g"][i], data["lam_x"][i])
            sol = ocp.solve(data["h0"][i], data["guess"][i], data["current"][i], duals)
            return sol.status.usable, sol.iterations, sol.solve_time

        out.append({"cold": cold, "solve": solve})
    return out


def mode2_problems() -> list[dict]:
    """The recorded Mode II problems, each with a `solve(order)` -> (usable, iterations, seconds)."""
    data = pickle.loads(MODE2.read_bytes())
    scene, params = load_scene(), load_params()
    models: dict[ModelOptions, UVMSModel] = {}
    ocps: dict[tuple, ModeIIOCP] = {}
    out = []
    for p in data["problems"]:
        options = p.get("model_options", ModelOptions())
        model = models.setdefault(options, UVMSModel(params, scene.water, options))

        def solve(order: int, p: dict = p, model: UVMSModel = model) -> tuple[bool, int, float]:
            s = p["settings"]
            settings = replace(s, ipopt_options={**s.ipopt_options, "mumps_pivot_order": order})
            key = (p["contact"], settings.dt_bounds, settings.dt_nominal, order)
            if key not in ocps:
                ocps[key] = ModeIIOCP(model, scene.planes, p["contact"], settings)
            ocp = ocps[key]
            ocp.limit_inputs(p["lo"], p["hi"])
            sol = ocp.solve(p["h0"], p["guess"], p["current"], p["duals"])
            return sol.status.usable, sol.iterations, sol.solve_time

        out.append({"cold": p["duals"] is None, "solve": solve})
    return out


def measure(problems: list[dict], rounds: int, desc: str) -> dict[str, np.ndarray]:
    """Per ordering: (usable, iterations, median seconds) per problem, over `rounds` interleaved rounds."""
    names = list(ORDERINGS)
    times = {n: np.zeros((len(problems), rounds)) for n in names}
    usable = {n: np.zeros(len(problems), bool) for n in names}
    iters = {n: np.zeros(len(problems), int) for n in names}
    for r in tqdm(range(rounds), desc=desc, unit="round"):
        for i, p in enumerate(problems):
            for j in range(len(names)):
                name = names[(i + r + j) % len(names)]
                ok, it, t = p["solve"](ORDERINGS[name])
                times[name][i, r], usable[name][i], iters[name][i] = t, ok, it
    return {n: (usable[n], iters[n], np.median(times[n], axis=1)) for n in names}


def table(mode: str, problems: list[dict], results: dict[str, tuple]) -> list[str]:
    cold = np.array([p["cold"] for p in problems])
    base = results[next(iter(ORDERINGS))]
    lines = [f"## Mode {mode}: {len(problems)} problems ({int(cold.sum())} cold)", "",
             "| ordering | usable | iterations (median / p95) | time [ms] (median / p95) | ms per iteration | "
             "time / default's, per problem (median) | faster / slower than the default | sign test p |",
             "|---|---|---|---|---|---|---|---|"]
    for name, (ok, it, t) in results.items():
        ratio = t / base[2]
        faster, slower = int(np.sum(t < base[2])), int(np.sum(t > base[2]))
        lines.append(f"| {name} | {int(ok.sum())}/{len(ok)} | {np.median(it):.0f} / {np.percentile(it, 95):.0f} | "
                     f"{1e3 * np.median(t):.1f} / {1e3 * np.percentile(t, 95):.1f} | "
                     f"{1e3 * t.sum() / max(int(it.sum()), 1):.2f} | {np.median(ratio):.2f} | {faster} / {slower} | "
                     f"{sign_test(faster, slower):.2g} |")
    same = int(sum(np.array_equal(results[n][1], base[1]) for n in results))
    lines += ["", f"Iterations per problem identical to the default's for {same - 1} of {len(results) - 1} orderings.", ""]
    return lines


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds per problem (median time)")
    a = ap.parse_args(argv)
    if a.rounds < 1:
        raise SystemExit(f"--rounds {a.rounds}; allowed: >= 1")
    missing = [str(p) for p in (MODE3, MODE2) if not p.exists()]
    if missing:
        raise SystemExit(f"{', '.join(missing)} missing; allowed: record them first (this module's docstring)")
    lines = ["# MUMPS's ordering under IPOPT, on recorded problems", "",
             f"`python bench/mumps_ordering.py --rounds {a.rounds}` ({platform.machine()}, {platform.processor() or '?'}"
             f", casadi {ca.__version__}, one process): the orderings interleaved problem by problem, each problem's "
             f"time the median of {a.rounds} rounds. Mode III's problems from `bench/mode3_solvers.py --record`, "
             "Mode II's from `bench/mode2_solvers.py --record` (the manifest names the recordings' commands).", ""]
    for mode, problems in (("II", mode2_problems()), ("III", mode3_problems())):
        lines += table(mode, problems, measure(problems, a.rounds, f"Mode {mode}"))
    (OUT / "mumps_ordering.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(OUT / "mumps_ordering.manifest.json", {"orderings": ORDERINGS}):
        main(sys.argv[1:])
