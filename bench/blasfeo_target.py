"""Mode I's solve with CasADi's HPIPM on BLASFEO built for this CPU instead of the wheel's build.

Run: `python bench/blasfeo_target.py --source DIR [--target X64_INTEL_HASWELL] [--rounds 8]`, DIR a
BLASFEO source tree at the version the casadi wheel carries (its libblasfeo.so.0.<version>); writes
bench/results/blasfeo_target.json, .md and its manifest.

BLASFEO is built as a shared library for `--target` into a temporary folder. CasADi's HPIPM plugin
finds libblasfeo.so.0 through its RUNPATH, so LD_LIBRARY_PATH, set before a process starts, puts
that build in its place for the whole process. Each round runs bench/nmpc_modes' Mode I closed loop
(the avoidable approach, 60 periods of 0.1 s, the model as the plant, the default SQP: two
iterations per period on HPIPM's Riccati QP) in two fresh processes, one per library, their order
alternating (ABBA), and records each solve's time, the inputs, and which libblasfeo the process
mapped. Reported: each round's median solve time per library, their ratio, the exact sign test
over rounds, and the largest input difference between the libraries (the same QPs solved by
other kernels: equal up to rounding).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

OUT = Path(__file__).parent / "results"


def worker(out: Path) -> None:
    """One Mode I closed loop; its solve times, inputs and mapped libblasfeo to `out` (JSON)."""
    sys.path.insert(0, str(Path(__file__).parent))
    from nmpc_modes import approach, closed_loop

    from controller.mode1 import ModeIOCP, ModeISettings
    from controller.model import UVMSModel
    from uvms import load_params, load_scene

    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    h, ref = approach(params)
    settings = ModeISettings()
    ocp = ModeIOCP(model, scene.planes, settings)
    inputs, state = [], {"previous": None}

    def solve(x: np.ndarray) -> tuple[np.ndarray, float, int, bool]:
        sol = state["previous"] = ocp.solve(x, ref, previous=state["previous"])
        inputs.append(sol.u[0].tolist())
        return sol.u[0], sol.solve_time, sol.iterations, sol.status.usable

    times, _, _ = closed_loop(solve, model, h, settings)
    mapped = sorted({line.split()[-1] for line in open("/proc/self/maps") if "libblasfeo" in line})
    out.write_text(json.dumps({"times": times, "inputs": inputs, "blasfeo": mapped}))


def build(source: Path, target: str, into: Path) -> Path:
    """BLASFEO from `source` built for `target` as libblasfeo.so.0 in `into`/lib."""
    tree = into / "blasfeo"
    shutil.copytree(source, tree, ignore=shutil.ignore_patterns(".git"))
    subprocess.run(["make", "-j2", "shared_library", f"TARGET={target}"], cwd=tree, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    lib = into / "lib"
    lib.mkdir()
    shutil.copy(tree / "lib" / "libblasfeo.so", lib / "libblasfeo.so.0")
    return lib


def main() -> None:
    from scipy.stats import binomtest
    from tqdm import tqdm

    from validation.manifest import recorded

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, help="a BLASFEO source tree at the wheel's version")
    parser.add_argument("--target", default="X64_INTEL_HASWELL", help="BLASFEO's TARGET (default X64_INTEL_HASWELL)")
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        return worker(args.worker)
    if args.source is None or not (args.source / "Makefile.rule").is_file():
        raise SystemExit(f"--source {args.source} is not a BLASFEO source tree; allowed: a folder with Makefile.rule")
    if args.rounds < 2:
        raise SystemExit(f"--rounds {args.rounds}; allowed: at least 2")
    import casadi

    wheel = sorted(p.name for p in Path(casadi.__file__).parent.glob("libblasfeo.so.0.*"))
    settings = {"source": str(args.source), "target": args.target, "rounds": args.rounds, "wheel_blasfeo": wheel}
    with tempfile.TemporaryDirectory() as tmp, recorded(OUT / "blasfeo_target_manifest.json", settings):
        lib = build(args.source, args.target, Path(tmp))
        envs = {"wheel": dict(os.environ), "built": dict(os.environ, LD_LIBRARY_PATH=str(lib))}
        runs: dict[str, list[dict]] = {"wheel": [], "built": []}
        for r in tqdm(range(args.rounds), desc="rounds", unit="round"):
            order = ("wheel", "built") if r % 2 == 0 else ("built", "wheel")
            for name in order:
                out = Path(tmp) / f"{name}{r}.json"
                subprocess.run([sys.executable, __file__, "--worker", str(out)], env=envs[name], check=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                runs[name].append(json.loads(out.read_text()))
    medians = {k: [1e3 * float(np.median(run["times"])) for run in v] for k, v in runs.items()}
    ratios = [b / w for b, w in zip(medians["built"], medians["wheel"], strict=True)]
    faster = sum(x < 1.0 for x in ratios)
    p = binomtest(faster, len(ratios)).pvalue
    du = max(float(np.max(np.abs(np.array(b["inputs"]) - np.array(w["inputs"]))))
             for b, w in zip(runs["built"], runs["wheel"], strict=True))
    result = {"target": args.target, "wheel_blasfeo": wheel, "mapped": {k: v[0]["blasfeo"] for k, v in runs.items()},
              "median_ms": medians, "ratio_built_to_wheel": ratios, "rounds_faster": faster, "sign_test_p": p,
              "max_input_difference": du}
    (OUT / "blasfeo_target.json").write_text(json.dumps(result, indent=1))
    lines = [f"# Mode I's solve on BLASFEO built for {args.target} vs the casadi wheel's ({', '.join(wheel)})", "",
             "bench/nmpc_modes' Mode I closed loop (60 periods, the default SQP), one fresh process per library "
             "and round, ABBA. Median solve time [ms] per round:", "",
             "| round | wheel | built | built / wheel |", "|---|---|---|---|",
             *[f"| {r} | {w:.2f} | {b:.2f} | {b / w:.2f} |"
               for r, (w, b) in enumerate(zip(medians["wheel"], medians["built"], strict=True))], "",
             f"Median ratio {np.median(ratios):.2f}; built faster in {faster} of {len(ratios)} rounds (exact sign "
             f"test p = {p:.2g}). Largest input difference between the libraries: {du:.1e} (N, N m).", ""]
    (OUT / "blasfeo_target.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
