"""Evaluation time of the paper's model f(h, u, ...) and of its Jacobian d f / d(h, u), through
CasADi's virtual machine and compiled to C by CasADi's code generation (gcc -O2); and of one RK4
step called from numpy, as the controller's rollouts call it.

Run: `python bench/model_eval.py`. Writes bench/results/model_eval.json and .md. Medians over
repeats, every variant measured in the same run. "batch of 20" evaluates 20 states in one call
(Function.map), which is how an OCP evaluates its stages and removes Python's per-call overhead.
"""

from __future__ import annotations

import json
import platform
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from controller.model import WATER, UVMSModel
from uvms import load_params, load_scene

OUT = Path(__file__).parent / "results"
REPEATS, CALLS, BATCH = 7, 200, 20


def compiled(fn: ca.Function, folder: Path) -> tuple[ca.Function, float]:
    """The same function compiled to a shared object; returns it and the compile time [s]."""
    t0 = time.perf_counter()
    c = folder / f"{fn.name()}.c"
    fn.generate(c.name, {"with_header": False})
    Path(c.name).rename(c)
    so = folder / f"{fn.name()}.so"
    subprocess.run(["gcc", "-O2", "-fPIC", "-shared", str(c), "-o", str(so)], check=True)
    return ca.external(fn.name(), str(so)), time.perf_counter() - t0


def per_eval(fn: ca.Function, args: list, n_evals: int) -> float:
    """Median seconds per evaluation."""
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        for _ in range(CALLS):
            fn(*args)
        times.append((time.perf_counter() - t0) / (CALLS * n_evals))
    return statistics.median(times)


def main() -> None:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    h = ca.SX.sym("h", params.n_states)
    u = ca.SX.sym("u", params.n_inputs)
    Fw, Rw, vc, ac = ca.SX.sym("Fw", 6), ca.SX.sym("Rw", 3, 3), ca.SX.sym("vc", WATER), ca.SX.sym("ac", 3)
    f_expr = model.f(h, u, Fw, Rw, vc, ac)
    f = ca.Function("f_model", [h, u, Fw, Rw, vc, ac], [f_expr])
    jac = ca.Function("jac_model", [h, u, Fw, Rw, vc, ac], [ca.jacobian(f_expr, ca.vertcat(h, u))])
    rng = np.random.default_rng(0)
    x = np.zeros(params.n_states)
    x[6:6 + params.n_joints] = params.arm.home
    x[6 + params.n_joints:] = rng.normal(0, 0.2, 6 + params.n_joints)
    args = [x, rng.normal(size=params.n_inputs), np.zeros(6), np.eye(3), np.array([0.1, 0, 0]), np.zeros(3)]
    batch_args = [np.tile(np.asarray(a).reshape(-1, 1), (1, BATCH)) if np.ndim(a) == 1 else np.tile(a, (1, BATCH))
                  for a in args]
    rows, compile_s = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, fn in (("f", f), ("jacobian", jac)):
            cfn, compile_s[name] = compiled(fn, Path(tmp))
            rows[f"{name}, interpreted"] = per_eval(fn, args, 1)
            rows[f"{name}, compiled"] = per_eval(cfn, args, 1)
            rows[f"{name}, interpreted, batch of {BATCH}"] = per_eval(fn.map(BATCH), batch_args, BATCH)
            rows[f"{name}, compiled, batch of {BATCH}"] = per_eval(cfn.map(BATCH), batch_args, BATCH)
    u0 = args[1]
    rows["RK4 step from numpy, interpreted (UVMSModel.rk4)"] = per_eval(
        lambda: model.rk4(x, u0, *model.defaults(), 0.01), [], 1)
    model.step(x, u0, 0.01)  # compiles (or loads) the RK4 step
    rows["RK4 step from numpy, compiled, no conversions (UVMSModel.step)"] = per_eval(
        lambda: model.step(x, u0, 0.01), [], 1)
    result = {"machine": {"python": platform.python_version(), "casadi": ca.__version__,
                          "processor": platform.processor() or platform.machine()},
              "vehicle": f"{params.name} {params.arm.name}", "n_states": params.n_states, "n_inputs": params.n_inputs,
              "sx_nodes": {"f": f.n_nodes(), "jacobian": jac.n_nodes()},
              "compile_seconds": compile_s, "us_per_evaluation": {k: 1e6 * v for k, v in rows.items()}}
    OUT.mkdir(exist_ok=True)
    (OUT / "model_eval.json").write_text(json.dumps(result, indent=2))
    lines = [f"# Model evaluation ({result['machine']['processor']}, casadi {ca.__version__})", "",
             f"{result['vehicle']}: {params.n_states} states, {params.n_inputs} inputs; SX nodes f "
             f"{f.n_nodes()}, Jacobian {jac.n_nodes()}; compile (gcc -O2) f {compile_s['f']:.1f} s, Jacobian "
             f"{compile_s['jacobian']:.1f} s. Median of {REPEATS} repeats of {CALLS} calls.", "",
             "| variant | us per evaluation |", "|---|---|"]
    lines += [f"| {k} | {1e6 * v:.1f} |" for k, v in rows.items()]
    (OUT / "model_eval.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "model_eval.manifest.json"):
        main()
