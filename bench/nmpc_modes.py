"""Solve times of the switching NMPC per mode, with Mode I side by side against two baselines.
Run: `python bench/nmpc_modes.py` (needs the `bench` extra: do-mpc);
writes bench/results/nmpc_modes.json and .md.

Mode I: the avoidable approach of tests/test_mode1.py (0.3 m/s towards the wall, target out of
reach), 60 control periods of 0.1 s on the model itself as the plant (RK4, 10 ms), N = 20,
dt = 0.1 s, default vehicle (4-joint arm). Variants in one run:
  - ours (default): Gauss-Newton SQP, HPIPM's Riccati QP, two iterations per period, warm-started
    from the shifted previous solution (controller.sqp);
  - ours, one iteration per period: the real-time iteration;
  - ours with HPIPM's own initial barrier parameter for ROBUST (mu0 = 100; the default is 0.1);
  - ours with HPIPM's residual tolerances at 1e-4 instead of 1e-6 ("switching-loose-qp");
  - ours with HPIPM's SPEED_ABS QPs instead of ROBUST ones (controller.sqp.QPMode; its own mu0, 10);
  - ours, SQP to convergence (steps below 1e-3, at most 10 iterations);
  - ours, IPOPT: the same compiled stage derivatives, exact Hessian, warm-started from the shifted
    previous solution and its multipliers;
  - (a) the same NLP expanded into one SX graph, CasADi's own derivatives, IPOPT from a cold start
    (h0 held, no multipliers, IPOPT's default monotone barrier from mu = 0.1), no code generation;
  - (b) do-mpc 5.1.2 on the same model, horizon and constraint stages: the model as a DAE
    (h_dot = [eta_dot(h); a], 0 = M(q) a - Q(h, u)), one Gauss-Legendre collocation point per
    interval (the implicit midpoint rule, as ours), the same tracking cost and input weight, bounds,
    and the clearances as nonlinear constraints at the intervals' ends; its own warm start (the
    previous solution) with the IPOPT options of ours (warm start, adaptive barrier; with the
    monotone barrier it failed 34 of 60 solves at the 100-iteration cap, 5.0 s median).
Modes II and III: every step of the kane-thrusters-dead approach of validation.kane_closed_loop (the
OCP solve alone, and the whole step with certificate, guesses and re-simulation), with the default
Mode II (0.05 s intervals) and with the paper's (0.1 s).
Code generation: the first build of Mode I with an empty cache (a subprocess with its own
UVMS_CODEGEN_CACHE) against a second build that finds the compiled code on disk.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import casadi as ca
import numpy as np

from controller.mode1 import ModeIOCP, ModeISettings, Solver, _default_state_weights
from controller.model import WATER, UVMSModel
from controller.sqp import QPMode, SQPSettings
from controller.switching import Mode, SwitchingSettings
from controller.transcription import clearances
from uvms import load_params, load_scene
from validation import presets
from validation.kane_closed_loop import SCENARIOS, run

OUT = Path(__file__).parent / "results"
STEPS = 60


def approach(params) -> tuple[np.ndarray, np.ndarray]:
    n = params.n_joints
    h = np.zeros(params.n_states)
    h[6:6 + n], h[6 + n] = params.arm.home, 0.3
    ref = np.zeros(params.n_states)
    ref[0], ref[6:6 + n] = 1.8, params.arm.home
    return h, ref


def stats(times: list[float], iters: list[int], failures: int, build: float) -> dict:
    t = np.array(times) * 1e3
    return {"build_s": build, "median_ms": float(np.median(t)), "p95_ms": float(np.percentile(t, 95)),
            "max_ms": float(t.max()), "median_iterations": float(np.median(iters)), "max_iterations": int(max(iters)),
            "failures": failures, "solves": len(times)}


def closed_loop(solve, model, h, settings) -> tuple[list, list, int]:
    times, iters, failures = [], [], 0
    for _ in range(STEPS):
        u, t, it, ok = solve(h)
        times.append(t)
        iters.append(it)
        failures += not ok
        for _ in range(10):
            h = model.step(h, u, settings.dt / 10)
    return times, iters, failures


OURS = "ours: SQP + HPIPM, 2 iterations per period (default)"
COLD = "(a) CasADi + IPOPT, expanded SX, cold start"
VARIANTS = {
    OURS: ModeISettings(),
    "ours: SQP + HPIPM, 1 iteration per period (RTI)": ModeISettings(sqp=SQPSettings(max_iter=1)),
    "ours: SQP + HPIPM, mu0 = 100, HPIPM ROBUST's own": ModeISettings(sqp=SQPSettings(
        qp_mu0=None)),
    "ours: SQP + HPIPM, QP tolerances 1e-4 instead of 1e-6, 2 iterations per period": ModeISettings(sqp=SQPSettings(
        qp_tol=1e-4)),
    "ours: SQP + HPIPM's SPEED_ABS QPs, 2 iterations per period": ModeISettings(sqp=SQPSettings(
        qp_mode=QPMode.SPEED_ABS, qp_mu0=None)),
    "ours: SQP + HPIPM to convergence (<= 10 iterations)": ModeISettings(sqp=SQPSettings(max_iter=10)),
    "ours: IPOPT, compiled stage derivatives, warm start": ModeISettings(solver=Solver.IPOPT),
    COLD: ModeISettings(compiled=False, solver=Solver.IPOPT,
                        ipopt_options={"warm_start_init_point": "no", "mu_init": 0.1, "mu_strategy": "monotone"}),
}


def ours_and_cold(model, planes, h0, ref) -> dict:
    rows = {}
    for name, settings in VARIANTS.items():
        warm = name != COLD
        t0 = time.perf_counter()
        ocp = ModeIOCP(model, planes, settings)
        build = time.perf_counter() - t0
        state = {"previous": None}

        def solve(h, ocp=ocp, warm=warm, state=state):
            sol = ocp.solve(h, ref, previous=state["previous"] if warm else None)
            state["previous"] = sol
            return sol.u[0], sol.solve_time, sol.iterations, sol.status.usable

        rows[name] = stats(*closed_loop(solve, model, h0.copy(), settings), build)
    return rows


def do_mpc_row(model, planes, h0, ref) -> dict:
    import do_mpc  # the bench extra

    p, s = model.params, ModeISettings()
    n, ns, nu, nv = model.n_joints, model.n_states, model.n_inputs, model.n_speeds
    m = do_mpc.model.Model("continuous", "SX")
    h = m.set_variable("_x", "h", shape=(ns, 1))
    u = m.set_variable("_u", "u", shape=(nu, 1))
    a = m.set_variable("_z", "a", shape=(nv, 1))
    from controller.kinematics import euler_rates, euler_zyx
    R = euler_zyx(h[3], h[4], h[5])
    eta_dot = ca.vertcat(R @ h[6 + n:9 + n], euler_rates(h[3:6], h[9 + n:12 + n]), h[12 + n:])
    m.set_rhs("h", ca.vertcat(eta_dot, a))
    Q = sum(model.generalized_forces(h, u, ca.DM.zeros(6), ca.DM.eye(3), ca.DM.zeros(WATER), ca.DM.zeros(3)))
    m.set_alg("dynamics", model.mass_matrix(h) @ a - Q)
    m.setup()
    mpc = do_mpc.controller.MPC(m)
    mpc.settings.n_horizon, mpc.settings.t_step = s.horizon, s.dt
    mpc.settings.collocation_type, mpc.settings.collocation_deg, mpc.settings.collocation_ni = "legendre", 1, 1
    mpc.settings.store_full_solution = False
    mpc.settings.nlpsol_opts = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False,
                                "ipopt.max_iter": s.max_iter, "ipopt.tol": s.tol,
                                "ipopt.warm_start_init_point": "yes", "ipopt.warm_start_bound_push": 1e-6,
                                "ipopt.warm_start_mult_bound_push": 1e-6, "ipopt.mu_init": 1e-3,
                                "ipopt.mu_strategy": "adaptive", "ipopt.mu_oracle": "probing"}
    W = ca.DM(_default_state_weights(n))
    e = m.x["h"] - ca.DM(ref)
    mpc.set_objective(lterm=ca.dot(W * e, e) + s.input_weight * ca.dot(m.u["u"], m.u["u"]), mterm=ca.dot(W * e, e))
    lo, hi = p.input_bounds()
    mpc.bounds["lower", "_u", "u"], mpc.bounds["upper", "_u", "u"] = lo, hi
    q_lo = np.concatenate([-np.full(6, np.inf), [lk.joint_range[0] for lk in p.arm.links], -np.full(nv, np.inf)])
    q_hi = np.concatenate([np.full(6, np.inf), [lk.joint_range[1] for lk in p.arm.links], np.full(nv, np.inf)])
    mpc.bounds["lower", "_x", "h"], mpc.bounds["upper", "_x", "h"] = q_lo, q_hi
    mpc.set_nl_cons("clearance", -clearances(model, m.x["h"], planes), ub=-s.distance_margin)
    t0 = time.perf_counter()
    mpc.setup()
    build = time.perf_counter() - t0
    mpc.x0 = h0
    mpc.set_initial_guess()

    def solve(h):
        t = time.perf_counter()
        u = np.asarray(mpc.make_step(h)).ravel()
        elapsed = time.perf_counter() - t
        st = mpc.solver_stats
        return u, elapsed, int(st["iter_count"]), bool(st["success"])

    return stats(*closed_loop(solve, model, h0.copy(), s), build)


def modes_two_three(settings: SwitchingSettings | None = None, label: str = "") -> dict:
    r = run(SCENARIOS["kane-thrusters-dead"], settings)
    rows = {}
    for mode in Mode:
        infos = [i for i in r.infos if i.mode is mode]
        if infos:
            rows[f"Mode {mode.value}{label}: OCP solve"] = stats([i.ocp_time for i in infos],
                                                                 [i.iterations for i in infos],
                                                                 sum(not i.status.usable for i in infos), 0.0)
            rows[f"Mode {mode.value}{label}: whole step"] = stats([i.solve_time for i in infos],
                                                                  [i.iterations for i in infos], 0, 0.0)
    return rows


_BUILD = """
import time
from controller.mode1 import ModeIOCP
from controller.model import UVMSModel
from uvms import load_params, load_scene
params, scene = load_params(), load_scene()
model = UVMSModel(params, scene.water)
t0 = time.perf_counter()
ModeIOCP(model, scene.planes)
print(time.perf_counter() - t0)
"""


def build_times() -> dict:
    """Mode I's construction [s] with an empty code-generation cache, then with the cache filled."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "UVMS_CODEGEN_CACHE": cache}
        run_ = [float(subprocess.run([sys.executable, "-c", _BUILD], env=env, check=True, capture_output=True,
                                     text=True).stdout.split()[-1]) for _ in range(2)]
    return {"first_build_s": run_[0], "second_build_s": run_[1]}


def main() -> None:
    params, scene = load_params(), load_scene()
    model = UVMSModel(params, scene.water)
    h0, ref = approach(params)
    mode1 = ours_and_cold(model, scene.planes, h0, ref)
    mode1["(b) do-mpc 5.1.2, collocation, warm start"] = do_mpc_row(model, scene.planes, h0, ref)
    modes = modes_two_three() | modes_two_three(presets.resolve("switching-paper").settings,
                                                     " (switching-paper: the paper's rules)")
    builds = build_times()
    OUT.mkdir(exist_ok=True)
    (OUT / "nmpc_modes.json").write_text(json.dumps({"machine": platform.machine(), "casadi": ca.__version__,
                                                     "mode1": mode1, "closed_loop_thrusters_dead": modes,
                                                     "code_generation": builds}, indent=2))
    head = ("| variant | build [s] | median [ms] | p95 [ms] | max [ms] | iterations (median / max) "
            "| failures / solves |", "|---|---|---|---|---|---|---|")

    def table(rows: dict) -> list[str]:
        return [*head, *(f"| {k} | {r['build_s']:.1f} | {r['median_ms']:.0f} | {r['p95_ms']:.0f} | {r['max_ms']:.0f} | "
                         f"{r['median_iterations']:.0f} / {r['max_iterations']} | {r['failures']} / {r['solves']} |"
                         for k, r in rows.items())]

    ours, cold = mode1[OURS], mode1[COLD]
    lines = [f"# Switching NMPC solve times ({platform.machine()}, casadi {ca.__version__}, 2 cores)", "",
             "`python bench/nmpc_modes.py`. Targets: Mode I median <= 10 ms and p95 <= 25 ms; every "
             "mode's p95 below the control period (100 ms); Mode I at least 5x faster than (a).", "",
             f"## Mode I, avoidable approach, {STEPS} closed-loop periods", "", *table(mode1), "",
             f"Median speed-up of ours (default) over (a): {cold['median_ms'] / ours['median_ms']:.1f}x.", "",
             "Failures count solves whose plan is not usable (neither converged, nor feasible, nor an accepted "
             "real-time iterate).", "",
             f"Code generation (Mode I, gcc -O1, cached on disk): first build "
             f"{builds['first_build_s']:.0f} s with an empty cache, second build {builds['second_build_s']:.1f} s.",
             "",
             "## All modes, kane-thrusters-dead approach (validation.kane_closed_loop)", "", *table(modes)]
    (OUT / "nmpc_modes.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    from validation import manifest

    with manifest.recorded(Path(__file__).parent / "results" / "nmpc_modes.manifest.json"):
        main()
