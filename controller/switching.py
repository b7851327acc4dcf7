"""The switching NMPC (paper Sec. IV, Algorithms 1-3 and the Final Algorithm): one `step` per
control period.

Mode selection (Algorithm 3): Mode I while the feasibility certificate (controller.feasibility)
finds Mode I's feasible set F non-empty; Mode II once it is empty, or once the deploy deadline
fires (`deploy_deadline`, not in the paper: waiting longer would leave Mode II no time to put the
tip on the wall; `_deadline`); Mode III after the Mode II step taken with N_p = 1 (Algorithm 1),
once the tip is within `contact_tolerance` of the plane or, with `contact_reach` under a
latency, approaches it within the impact bound and gets there by Mode III's first node (else Mode
II afresh); back to Mode I once the hull moves away from the contact plane faster than
`separation_speed` (the paper: d_0' > 0) and maximum braking from there would keep it off
(`release_check`, not in the paper: `_may_release`).

Before each solve the previous plan is shifted by one interval and its states recomputed from the
measured state by the model's RK4 (the Final Algorithm); Mode III's nodes are put back on the plane
by Algorithm 2's inverse kinematics. Under a latency on the wall clock a helper process solves
ahead what the next step will need (controller.entries_ahead: Mode II's deploy while Mode I's
braking rollout fails, Mode III's next step from its plan's next node), and those steps start from
its answers. A solve whose status is not usable is not used: the fallback
(StepInfo.fallback) is the previous plan of the same mode shifted by one interval, else Mode I's
maximum braking, Mode II's deploy guess, and for Mode III's first solve Mode II afresh (`redeploy`,
not in the paper) or, without it, maximum braking with the arm held rigid. A failed Mode III solve
does not end Mode III: the next step solves again from the measured state. The rules not in the
paper and their evidence: docs/decisions.md.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from typing import Any

import numpy as np

from controller import impact
from controller.entries_ahead import ContactEntry, ContactStep, DeployEntry, EntryHelper
from controller.estimator import CurrentObserver, ObserverSettings
from controller.feasibility import Certificate, CertificateSettings, FeasibilityTest, Method, Verdict
from controller.mode1 import ModeIOCP, ModeISettings, OCPSolution, SolverStatus
from controller.mode2 import ModeIIOCP, ModeIISettings, ModeIISolution, next_horizon, shifted_guess
from controller.mode3 import ModeIIIOCP, ModeIIISettings, ModeIIISolution
from controller.model import ModelOptions, UVMSModel, water
from controller.protocol import StepInfo, Task
from controller.rollouts import BrakingPolicy, JointHold, simulate
from controller.transcription import tip_gap
from uvms.scene import Plane

DELAY_TOLERANCE = 0.0025  # s: a later input than the previous one's by at most this counts as on time (observer)


class Mode(Enum):
    I = "I"  # noqa: E741 (the paper's name)
    II = "II"
    III = "III"


class SwitchReason(Enum):
    """Why a step left Mode I for Mode II."""

    F_EMPTY = "F empty: a positive minimum violation"
    SOLVER_FAILURE = "F taken as empty: IPOPT failed on the minimum-violation problem"
    DEPLOY_DEADLINE = "deploy deadline: waiting would leave Mode II no time to put the tip on the wall"


class Fallback(Enum):
    NONE = "none"
    SHIFTED_PLAN = "shifted previous plan"
    GUESS = "initial guess (Mode I: maximum braking; Mode II: braking while the arm deploys)"
    HOLD = "maximum braking with the arm held rigid at its posture (Mode III)"
    REDEPLOY = "Mode II afresh from the measured state (Mode III's first solve failed)"


@dataclass(frozen=True)
class SwitchingSettings:
    """The switching NMPC's settings (the modes' own, and the rules that join them)."""

    mode1: ModeISettings = field(default_factory=ModeISettings)
    mode2: ModeIISettings = field(default_factory=ModeIISettings)
    mode3: ModeIIISettings = field(default_factory=ModeIIISettings)
    certificate: CertificateSettings = field(default_factory=CertificateSettings)
    switching: bool = True  # False: Mode I only, no certificate (the plain NMPC baseline)
    deploy_deadline: bool = True  # also switch when waiting would leave Mode II no time to deploy the arm
    deadline_lead: float = 0.1  # s: the deploy deadline fires this much earlier (one Mode I period)
    redeploy: bool = True  # Mode III's first solve failing: Mode II afresh (else maximum braking, arm held)
    separation_speed: float = 0.05  # m/s: Mode III -> I once the hull moves away faster (the paper: 0) ...
    release_check: bool = True  # ... and maximum braking from there keeps the hull off (SwitchingNMPC._may_release)
    contact_tolerance: float | None = 0.01  # m: enter Mode III only with the tip this close (None: the paper) ...
    contact_reach: bool = True  # ... or, under a latency, approaching it within the impact bound to be that close
    # Mode II's last (N_p = 1) step commits, for a Mode III first step that comes too late (strict real
    # time), its plan's last thrust with the joints unpowered: the arm coasts into the contact it planned
    # instead of being driven on into the wall by the swing's torque (StepInfo.commit_after)
    handover_coast: bool = True
    failed_thrusters: tuple[int, ...] = ()  # thrusters the controller knows to be dead (bounds 0)
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s, world: the current the model assumes
    observe_current: bool = True  # add controller.estimator's estimate of the unknown current and hull weight
    observer: ObserverSettings = field(default_factory=ObserverSettings)
    # under a latency, update the observer too, its prediction holding the previous input until the
    # step's answer arrives (SwitchingController._sample); False: no update under a latency. With the
    # observer's acceleration gate, station keeping at a fixed 50 ms ends 3.4 cm off instead of 18.8
    # (59 of 60 runs closer), strict 50 ms 72/72 vs 71/72 (experiments/observer_latency_accel); without
    # that gate it lost twice in strict real time (experiments/observer_latency, observer_gated_latency)
    observe_under_latency: bool = True
    trim_in_contact: bool = True  # in contact before the observer's first update: the task's trim's weight
    plan_for_latency: bool = True  # plan from the state predicted at the task's latency (SwitchingController)
    # s: with plan_for_latency, the delay planned for when the task tells none in a loop on the wall
    # clock (a measured delay, which a task cannot tell in advance); 0: none. Measured delay, three
    # families: 38/72 vs 4/72 planning for none (experiments/realtime_measured_assumed)
    assumed_latency: float = 0.05
    # ... and there a step that computes faster returns only once that delay has run from its call, so
    # that its input acts when its plan assumed (a fixed-latency release); a slower one returns at
    # once: 137/144 vs 117/144 (experiments/measured_release_confirm)
    release_at_latency: bool = True
    # the controller's model with the joints' viscous friction of the parameter file (ModelOptions.
    # joint_damping; the paper's model has none): strict 50 ms 109/144 vs 82/144, hull contacts 18
    # vs 39 (experiments/model_joint_damping)
    model_joint_damping: bool = True
    # under a latency (told or assumed) in a loop on the wall clock (Task.wall_clock), a helper process
    # solves Mode III's entry from each Mode II plan's last node while Mode II runs, and Mode III's
    # first solve starts from its newest answer (controller.entries_ahead; not Algorithm 2's guess, cold)
    mode3_entry_helper: bool = False
    # ... and Mode II's deploy from each Mode I plan's next node while Mode I's braking rollout fails,
    # warm from its previous answer, and a switch in the next step starts Mode II's first solve from
    # that answer (not the deploy guess, cold): strict 50 ms 72/72 vs 67/72, Mode II late 1-4 % vs
    # 19-26 % (experiments/mode2_entry_helper)
    mode2_entry_helper: bool = True
    # ... and each Mode III step's successor from its plan's next node, warm from that plan, and the
    # next Mode III step starts from that answer (not the shifted plan) when it continues the same plan:
    # strict 50 ms, later Mode III steps late 2.3 % vs 5.4 % (p = 2.1e-6), 72/72 vs 71/72
    # (experiments/mode3_step_helper)
    mode3_step_helper: bool = True
    # under a latency, Mode III's cold first solve (Algorithm 2's guess) plans over this many intervals,
    # and its plan is held over the rest of the horizon (ModeIIIOCP.held_over) for the next step to start
    # from: on 72 first solves recorded at a 50 ms delay, 18 IPOPT iterations at the median (p95 38)
    # against 34 (77) over 0.3 s, and the next step's solve as fast (15 vs 16); strict 50 ms, first steps
    # late in 29/73 episodes vs 66/72, 71/72 vs 69/72 (experiments/mode3_entry_intervals). None: the whole horizon
    mode3_entry_intervals: int | None = 2
    # under a latency, a Mode I step whose certificate solved the minimum-violation problem (an episode's
    # first, whose input acts at once) also solves the next step's plan from the state predicted for it
    # and the next step starts from that plan, unshifted (SwitchingNMPC._solve_next_mode1). Strict 50 ms,
    # 144 held-out runs: the first delayed Mode I step late in 3/96 wall runs vs 96/96, 142/144 vs
    # 144/144 (p = 0.5), the hull further off (experiments/first_step_solves_next_strict)
    first_step_solves_next: bool = True

    def model_options(self) -> ModelOptions:
        """The options of the model this controller plans on."""
        return ModelOptions(joint_damping=self.model_joint_damping)


@dataclass(frozen=True)
class SolveEvent:
    """One optimal-control solve, as `SwitchingNMPC.on_solve` sees it: which problem ("mode1",
    "certificate", "mode2", "mode3"), the problem object, its solve() arguments and its solution."""

    kind: str
    ocp: Any
    args: tuple
    kwargs: dict
    solution: Any


@dataclass(frozen=True)
class _ModeStep:
    """What one mode's step decided (SwitchingNMPC.step adds the timing and the geometry)."""

    u: np.ndarray  # (nu,) the input to hold
    status: SolverStatus
    fallback: Fallback
    iterations: int
    dt: float  # s
    horizon: int
    h_pred: np.ndarray  # (N+1, ns)
    u_pred: np.ndarray  # (N, nu)
    contact_force: np.ndarray | None = None  # (N, 3) obstacle frame [N] (Mode III)
    certificate: Certificate | None = None
    commit_after: np.ndarray | None = None  # (K, nu) inputs committed past the plan's end (StepInfo)
    impact_force: float | None = None  # N (Mode II's plan)


class SwitchingNMPC:
    """Algorithm 3 over Modes I-III for a model and a set of planes. `reference` is the task: a
    state h_ref or a function of time t [s] returning one. `on_solve`, when given, is called after
    every optimal-control solve with its SolveEvent (benchmarks record the problems so)."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane],
                 reference: np.ndarray | Callable[[float], np.ndarray],
                 settings: SwitchingSettings = SwitchingSettings(),
                 on_solve: Callable[[SolveEvent], None] | None = None):
        self.model, self.planes, self.settings, self.on_solve = model, tuple(planes), settings, on_solve
        if callable(reference):
            self.reference = reference
        else:
            fixed = np.asarray(reference, float)
            self.reference = lambda t: fixed
        self.current = water(settings.current)  # the model's vc: current [m/s] and extra hull weight [N]
        self.mode1 = self._hooked("mode1", ModeIOCP(model, planes, settings.mode1))
        self.feasibility = FeasibilityTest(model, planes, settings.mode1, settings.certificate)
        self._hooked("certificate", self.feasibility.problem)
        self._hold = BrakingPolicy(model, JointHold(stiffness=30.0, damping=3.0))
        self._mode2: dict[int, ModeIIOCP] = {}
        self._mode3: dict[tuple[int, int], ModeIIIOCP] = {}  # by (plane, horizon)
        self.set_failed_thrusters(settings.failed_thrusters)
        if settings.switching:
            for plane in range(len(self.planes)):  # no assembly stall at the first switch, nor at a new N_p
                for n in range(1, settings.mode2.horizon + 1):
                    self.ocp2(plane).solver(n)
                    self.ocp2(plane).solver(n, warm=settings.mode2.warm_start)
                self.ocp2(plane).prepare_guesses(settings.mode2.horizon)
                self.ocp3(plane)
        # the rollouts' compiled RK4 loaded now, not in the first step that predicts (30 ms there), nor
        # in Mode III's first (Algorithm 2's guess: 28 ms), nor the compiled mass matrix in the
        # switching step (the impact bound's effective mass: 7 ms there)
        model.held_steps(np.zeros(model.n_states), np.zeros(model.n_inputs), settings.mode1.dt, 4)
        model.step(np.zeros(model.n_states), np.zeros(model.n_inputs), settings.mode3.dt)
        model.mass_and_bias(np.zeros(model.n_states))
        self.mode = Mode.I
        self.contact: int | None = None
        self._plan: OCPSolution | ModeIISolution | ModeIIISolution | None = None
        self._recomputed = np.zeros((0, model.n_states))  # the Mode III plan's states from its inputs
        self._horizon2 = settings.mode2.horizon
        self.last_u = np.zeros(model.n_inputs)
        self._distance_maps: dict[int, Any] = {}  # _closest_plane's mapped distances, by number of states
        self._mode3_plans = 0  # Mode III plans made so far (which one a ContactStep answer continues)
        self._reported_mode = Mode.I
        self._switch: SwitchReason | None = None  # why this step left Mode I
        self._ocp_time = 0.0
        self._deploy: tuple[ModeIIOCP, np.ndarray, tuple] | None = None  # the deadline's deploy rollout this step
        self._helper: EntryHelper | None = None  # mode entries solved ahead (start_entry_helper)
        self._t = 0.0  # s: the time of the state this step plans from
        self._plan_ahead = False  # whether Mode I's plan was solved for the next step (_solve_next_mode1)
        self.latency = 0.0  # s: the delay its answers act after (SwitchingController sets it)

    def prepare_every_problem(self) -> None:
        """Build now the problems a step would otherwise build when it first needs them (Mode III's
        over either horizon, a thruster dying between, and their twins for a hull pitched past
        `mode3.regular_pitch`: about 0.1 s each), for loops where a step pays for what it builds."""
        entry = self.settings.mode3_entry_intervals
        for plane in range(len(self.planes)):
            for horizon in self.settings.mode3.horizons | ({entry} if entry else set()):
                self.ocp3(plane, horizon).prepare_twins()

    def start_entry_helper(self) -> None:
        """Fork the process that solves mode entries ahead (controller.entries_ahead)."""
        if self._helper is None:
            self._helper = EntryHelper(self)

    def close(self) -> None:
        """Stop the entry helper, if any."""
        if self._helper is not None:
            self._helper.close()
            self._helper = None

    def _hooked(self, kind: str, ocp: Any) -> Any:
        """The problem with its solve reported to `on_solve` (unchanged without a hook)."""
        if self.on_solve is None:
            return ocp
        solve, hook = ocp.solve, self.on_solve

        def reported(*args: Any, **kwargs: Any) -> Any:
            sol = solve(*args, **kwargs)
            hook(SolveEvent(kind, ocp, args, kwargs, sol))
            return sol

        ocp.solve = reported
        return ocp

    def set_failed_thrusters(self, failed: Sequence[int]) -> None:
        """Thrusters known to be dead from now on (input bounds 0 in every mode and fallback)."""
        nt = self.model.params.n_thrusters
        if any(not 0 <= i < nt for i in failed):
            raise ValueError(f"failed thrusters {list(failed)}; allowed: indices 0..{nt - 1}")
        self.lo, self.hi = self.model.params.input_bounds()
        self.lo[list(failed)] = self.hi[list(failed)] = 0.0
        for ocp in (self.mode1, *self._mode2.values(), *self._mode3.values()):
            ocp.limit_inputs(self.lo, self.hi)
        self.feasibility.limit_inputs(self.lo, self.hi)
        self._hold.limit_thrust(self.lo, self.hi)
        self._plan = None

    # ------------------------------------------------------------------------------------------
    def ocp2(self, plane: int) -> ModeIIOCP:
        if plane not in self._mode2:
            ocp = self._hooked("mode2", ModeIIOCP(self.model, self.planes, plane, self.settings.mode2))
            ocp.limit_inputs(self.lo, self.hi)
            self._mode2[plane] = ocp
        return self._mode2[plane]

    def ocp3(self, plane: int, horizon: int | None = None) -> ModeIIIOCP:
        """Mode III's problem against `plane` over `horizon` intervals; None: over
        `mode3.thrust_horizon` while some thruster lives (if set), else over `mode3.horizon`."""
        s, nt = self.settings.mode3, self.model.params.n_thrusters
        live = bool(np.any(self.lo[:nt]) or np.any(self.hi[:nt]))
        if horizon is None:
            horizon = s.thrust_horizon if live and s.thrust_horizon is not None else s.horizon
        if (plane, horizon) not in self._mode3:
            ocp = self._hooked("mode3", ModeIIIOCP(self.model, self.planes, plane, replace(s, horizon=horizon)))
            ocp.limit_inputs(self.lo, self.hi)
            self._mode3[plane, horizon] = ocp
        return self._mode3[plane, horizon]

    def _geometry(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = [np.asarray(self.model.distances(h, pl.normal, pl.offset)).ravel() for pl in self.planes]
        dd = [np.asarray(self.model.closing_speeds(h, pl.normal, pl.offset)).ravel() for pl in self.planes]
        return np.array(d), np.array(dd)

    def _closest_plane(self, hs: np.ndarray) -> int:
        """The plane a rollout (states (K, ns)) comes closest to (smallest body clearance): the
        distances mapped over the states, one call per plane (not K)."""
        K = len(hs)
        if K not in self._distance_maps:
            self._distance_maps[K] = self.model.distances.map(K)
        states = np.asarray(hs, float).T
        worst = [float(np.min(np.asarray(self._distance_maps[K](states, pl.normal, pl.offset)))) for pl in self.planes]
        return int(np.argmin(worst))

    def predict(self, h: np.ndarray, u: np.ndarray, seconds: float) -> np.ndarray:
        """The state `seconds` after h with the input u held, in free flight (the model's RK4 in 4
        substeps, with the current the model assumes)."""
        if seconds <= 0.0:
            return np.asarray(h, float)
        return self._resimulate(h, np.asarray(u, float)[None], seconds)[-1]

    def _resimulate(self, h0: np.ndarray, us: np.ndarray, dt: float, forces: np.ndarray | None = None,
                    ocp3: ModeIIIOCP | None = None) -> np.ndarray:
        """The Final Algorithm's state trajectory of the inputs (RK4, 4 substeps per interval); with
        Mode III's contact forces and OCP, each node is put back on the plane."""
        if forces is None:
            return simulate(self.model, h0, us, dt, current=self.current)
        hs = [np.asarray(h0, float)]
        for k, uk in enumerate(us):
            h = self.model.held_steps(hs[-1], uk, dt, 4, Fw=np.concatenate([forces[k], np.zeros(3)]), Rw=ocp3.Rw,
                                      vc=self.current)
            h[6:6 + self.model.n_joints] = ocp3.onto_plane(h)
            hs.append(h)
        return np.array(hs)

    # ------------------------------------------------------------------------------------------
    def step(self, h: np.ndarray, t: float, ahead: tuple[np.ndarray, float] | None = None
             ) -> tuple[np.ndarray, StepInfo]:
        """The input u (thruster forces N, joint torques N m) to hold for info.dt seconds. `ahead`:
        the state predicted for when the input will act, and that time [s] (`predict`; None: h, t).
        Modes I and II plan from it and the check that the tip reached the plane reads it; Mode III
        and the release check read the measured h (planning from a prediction through the contact
        lost: experiments/realtime_mode3_ahead)."""
        h = np.asarray(h, float)
        if h.shape != (self.model.n_states,) or not np.all(np.isfinite(h)):
            raise ValueError(f"state has shape {h.shape} or non-finite entries; allowed: "
                             f"{self.model.n_states} finite numbers")
        h_a, t_a = (h, t) if ahead is None else (np.asarray(ahead[0], float), float(ahead[1]))
        self._t = t_a
        distances, closing = self._geometry(h)
        if self.mode is Mode.III and self._reported_mode is Mode.III and self._may_release(h, closing):
            self.mode, self._plan = Mode.I, None
        if self.mode is Mode.III and self._reported_mode is Mode.II and self._short_of_contact(h_a, t_a - t):
            if closing[self.contact, 0] > self.settings.separation_speed:  # no contact needed: the certificate decides
                self.mode, self._plan = Mode.I, None
            else:  # Mode II afresh: Algorithm 1's entry
                self.mode, self._plan, self._horizon2 = Mode.II, None, self.settings.mode2.horizon
        t0 = time.perf_counter()
        self._switch, self._ocp_time, self._deploy = None, 0.0, None
        if self.mode is Mode.I:
            out = self._step_mode1(h_a, t_a)
        elif self.mode is Mode.II:
            out = self._step_mode2(h_a)
        else:
            out = self._step_mode3(h, entry=self._reported_mode is Mode.II)
        self.last_u = np.clip(out.u, self.lo, self.hi)
        info = StepInfo(t=t, mode=self._reported_mode, status=out.status, fallback=out.fallback,
                        solve_time=time.perf_counter() - t0, ocp_time=self._ocp_time, iterations=out.iterations,
                        dt=out.dt, horizon=out.horizon, h_pred=out.h_pred, u_pred=out.u_pred,
                        contact_force=out.contact_force, contact_plane=self.contact, distances=distances,
                        closing_speeds=closing, certificate=out.certificate, switch=self._switch,
                        impact_force=out.impact_force, commit_after=out.commit_after)
        return self.last_u, info

    def _step_mode1(self, h: np.ndarray, t: float) -> _ModeStep:
        """Mode I's step, or Mode II's first when the certificate or the deadline ends Mode I."""
        s, ocp = self.settings.mode1, self.mode1
        ref = np.asarray(self.reference(t), float)
        previous = self._plan if isinstance(self._plan, OCPSolution) else None
        shifted, guess = None, None
        if previous is not None:
            us = previous.u if self._plan_ahead else np.vstack([previous.u[1:], previous.u[-1:]])
            shifted = (self._resimulate(h, us, s.dt), us)
            guess = ocp.guess_from_rollout(*shifted)
        fresh: dict = {}

        def solve_now() -> tuple[np.ndarray, np.ndarray] | None:
            """Mode I's solve, with its plan re-simulated (the certificate's third screen)."""
            sol = fresh["sol"] = ocp.solve(h, ref, self.current, previous=previous, guess=guess)
            if not sol.status.usable:
                return None
            fresh["h"] = self._resimulate(h, sol.u, s.dt)
            return fresh["h"], sol.u

        def refine(screened: Certificate) -> tuple[np.ndarray, np.ndarray] | None:
            """The fresh plan (when its solve failed: the braking rollout) continued by the SQP with
            a line search to a witness (the certificate's fourth screen), then Mode I's plan."""
            usable = "sol" in fresh and fresh["sol"].status.usable
            start = fresh["sol"].w if usable else ocp.guess_from_rollout(screened.rollout, screened.rollout_inputs)
            found = self.feasibility.continued(ocp, h, ref, self.current, start)
            if found is None:
                return None
            before = fresh["sol"].solve_time if "sol" in fresh else 0.0
            fresh["h"], fresh["sol"] = found[0], replace(found[1], solve_time=found[1].solve_time + before)
            return fresh["h"], fresh["sol"].u

        deadline = False  # the deploy deadline, asked by the certificate once its braking rollout has failed

        def needed(screened: Certificate) -> bool:
            """Whether F's answer still matters: not when the deploy deadline switches either way."""
            nonlocal deadline
            deadline = self._deadline(h, screened)
            return not deadline

        cert = self.feasibility(h, ref, self.current, plan=shifted, fresh=solve_now, needed=needed, refine=refine) \
            if self.settings.switching else None
        if cert is not None and cert.verdict is Verdict.INFEASIBLE:
            self._switch = SwitchReason.F_EMPTY if np.isfinite(cert.violation) else SwitchReason.SOLVER_FAILURE
        elif deadline:  # asked whenever the braking rollout failed (else it cannot fire)
            self._switch = SwitchReason.DEPLOY_DEADLINE
        if self._switch is not None:
            self.contact = self._closest_plane(cert.rollout)
            self.mode, self._plan, self._horizon2 = Mode.II, None, self.settings.mode2.horizon
            return self._step_mode2(h, cert)
        self._reported_mode = Mode.I
        if cert is not None and cert.method is Method.MINIMUM_VIOLATION and cert.solution is not None:
            guess = ocp.guess_from_rollout(cert.solution.h, cert.solution.u)  # a better start than the fresh one
            fresh.clear()
        sol = fresh["sol"] if "sol" in fresh else ocp.solve(h, ref, self.current, previous=previous, guess=guess)
        self._ocp_time = sol.solve_time
        if sol.status.usable:
            self._plan, self._plan_ahead = sol, False
            hp = fresh["h"] if "h" in fresh else self._resimulate(h, sol.u, s.dt)
            if self.latency > 0.0 and self.settings.first_step_solves_next and cert is not None \
                    and cert.method is Method.MINIMUM_VIOLATION:
                self._solve_next_mode1(h, t, sol)
            if self._helper is not None and self.settings.mode2_entry_helper and cert is not None \
                    and cert.rollout_clearance < 0:  # Mode II's deploy from where the next step plans
                self._helper.submit(DeployEntry(self._closest_plane(cert.rollout), self.settings.mode2.horizon,
                                                hp[1].copy(), t + s.dt, self.current.copy(), self.lo.copy(),
                                                self.hi.copy()))
            return _ModeStep(sol.u[0], sol.status, Fallback.NONE, sol.iterations, s.dt, s.horizon, hp, sol.u,
                             certificate=cert)
        if previous is not None:
            self._plan, k = None, 0 if self._plan_ahead else 1
            return _ModeStep(previous.u[k], sol.status, Fallback.SHIFTED_PLAN, sol.iterations, s.dt, s.horizon,
                             previous.h[k:], previous.u[k:], certificate=cert)
        hs, us = self.feasibility.braking_rollout(h, self.current)
        return _ModeStep(us[0], sol.status, Fallback.GUESS, sol.iterations, s.dt, s.horizon, hs, us, certificate=cert)

    def _solve_next_mode1(self, h: np.ndarray, t: float, sol: OCPSolution) -> None:
        """The next Mode I step's plan, solved now from the state predicted for it: the input u_0 of
        sol (this step's plan, from h at t) acts at once and is held until the next step's answer
        acts, a period plus the latency later. Solved as that step would (from sol shifted by one
        interval), then continued by the SQP with a line search to a point of F when its
        re-simulation is not one (FeasibilityTest.continued). The next step starts from it."""
        s, ocp = self.settings.mode1, self.mode1
        t1 = t + s.dt + self.latency
        h1 = self.predict(h, sol.u[0], t1 - t)
        ref = np.asarray(self.reference(t1), float)
        us = np.vstack([sol.u[1:], sol.u[-1:]])
        guess = ocp.guess_from_rollout(self._resimulate(h1, us, s.dt), us)
        nxt = ocp.solve(h1, ref, self.current, previous=sol, guess=guess)
        if not nxt.status.usable:
            return
        if not self.feasibility.plan_is_feasible(self._resimulate(h1, nxt.u, s.dt), nxt.u):
            found = self.feasibility.continued(ocp, h1, ref, self.current, nxt.w)
            nxt = found[1] if found is not None else nxt
        self._plan, self._plan_ahead = nxt, True

    def _may_release(self, h: np.ndarray, closing: np.ndarray) -> bool:
        """Mode III -> I: the hull moves away from the contact plane faster than `separation_speed`
        and, with `release_check`, the backup that Mode I falls back on, maximum braking with the arm
        held (the certificate's braking rollout over Mode I's horizon), keeps every body that Mode II
        protects at least the certificate's margin off every plane: letting go is safe even if Mode
        I then finds no plan. Without thrusters, or against a current onto the wall, the rollout
        drifts back and Mode III holds on."""
        if closing[self.contact, 0] <= self.settings.separation_speed:
            return False
        if not self.settings.release_check:
            return True
        hs, _ = self.feasibility.braking_rollout(h, self.current)
        protected = self.ocp2(self.contact).protected_clearance
        return min(protected(x) for x in hs[1:]) >= self.feasibility.settings.distance_margin

    def _short_of_contact(self, h: np.ndarray, lead: float = 0.0) -> bool:
        """With `contact_tolerance`: whether the tip is further than that from the contact plane
        after Mode II's last (N_p = 1) step, so that Mode III, which holds it on the plane from its
        first interval on, would have to drag it there in one interval. With `contact_reach`, under
        a latency (h, the state the check reads, predicted `lead` > 0 seconds after the measured
        one), a tip is not short either when it approaches the plane no faster than Mode II's
        impact bound allows (ModeIIOCP.allowed_speed) and, at that speed, comes within the
        tolerance by Mode III's first node, one Mode III interval after the measured state. There
        the N_p = 1 interval is planned from a prediction and lasts up to twice the delay, and the
        tip ends a few cm short while still approaching; without a delay one more short Mode II
        step costs no time and slows the tip (docs/decisions.md, 'Under a latency, a tip still
        approaching counts as on the plane')."""
        tol = self.settings.contact_tolerance
        if tol is None:
            return False
        plane = self.planes[self.contact]
        gap = float(tip_gap(self.model, h, plane))
        if gap <= tol:
            return False
        if not self.settings.contact_reach or lead <= 0.0:
            return True
        speed = impact.approach_speed(self.model, h, plane)
        reach = speed * max(self.settings.mode3.dt - lead, 0.0)
        return not (0.0 < speed <= self.ocp2(self.contact).allowed_speed(h) and gap <= tol + reach)

    def _deadline(self, h: np.ndarray, cert: Certificate) -> bool:
        """With `deploy_deadline`: whether the braking rollout brings something Mode II protects (every
        body but the tip and the last link against the contact plane: ModeIIOCP.protected_clearance)
        within the margin (first node t_hit) no later than one control period plus `deadline_lead`
        after the time Mode II's deploy rollout needs to put the tip on that plane (t_c, the
        rollout's own: not the entry guess's N_p dt, which a latency's longer shortest interval
        rounds up to a whole number of intervals, up to one interval more lead): waiting
        longer would leave Mode II no time, and the lead keeps the stowed arm's base links off the
        wall when the plant drifts closer than the model. The tip and the last link are left out so
        that an arm still on the wall after Mode III does not count. It also applies right after Mode
        III lets go: with a current pushing the hull back, the rollout soon returns it, and Mode II
        then re-plans with the arm still near the wall (docs/decisions.md, 'The deploy deadline')."""
        if not self.settings.deploy_deadline or cert.rollout_clearance >= 0:
            return False
        s, ocp2 = self.settings.mode1, self.ocp2(self._closest_plane(cert.rollout))
        close = [ocp2.protected_clearance(x) < self.feasibility.settings.distance_margin for x in cert.rollout[1:]]
        if not any(close):
            return False
        N_max = self.settings.mode2.horizon
        guess = ocp2.deploy_guess(h, N_max, self.current)
        self._deploy = (ocp2, h, guess)  # Mode II's entry guess if this step switches (_step_mode2)
        t_c = ocp2.time_to_contact(h, N_max, self.current)
        t_deploy = len(guess[1]) * guess[2] if t_c is None else t_c
        return s.dt * (1 + close.index(True)) <= t_deploy + s.dt + self.settings.deadline_lead

    def _deploy_ahead(self, N: int) -> ModeIISolution | None:
        """With `mode2_entry_helper`, at Mode II's entry (Algorithm 1's longest horizon N): the deploy
        the helper solved for this plane at a state within half a Mode I period of this step's, if
        one has come back (controller.entries_ahead)."""
        if self._helper is None or not self.settings.mode2_entry_helper or N != self.settings.mode2.horizon:
            return None
        answer = self._helper.take(DeployEntry, self.contact, N)
        if answer is None or abs(answer[0].t - self._t) > self.settings.mode1.dt / 2:
            return None
        return answer[1]

    def _step_mode2(self, h: np.ndarray, cert: Certificate | None = None) -> _ModeStep:
        self._reported_mode = Mode.II
        s, ocp, N = self.settings.mode2, self.ocp2(self.contact), self._horizon2
        previous = self._plan if isinstance(self._plan, ModeIISolution) else None
        duals = None
        if previous is not None:
            us, dt = shifted_guess(previous, N)
            guess = (self._resimulate(h, us, dt), us, dt)
            duals = ocp.shifted_duals(previous, N)
        elif (ahead := self._deploy_ahead(N)) is not None:  # the deploy solved ahead, from this step's state
            guess, duals = (np.vstack([h, ahead.h[1:]]), ahead.u, ahead.dt), (ahead.lam_g, ahead.lam_x)
            N = len(ahead.u)
        else:  # the deploy rollout, unless the deadline computed it for this state in this step
            ready = (self._deploy is not None and self._deploy[0] is ocp and self._deploy[1] is h
                     and N == self.settings.mode2.horizon)
            guess = self._deploy[2] if ready else ocp.deploy_guess(h, N, self.current)
            N = len(guess[1])
        sol = ocp.solve(h, guess, self.current, duals)
        self._ocp_time = sol.solve_time
        iters = sol.iterations
        if sol.status.usable:
            u, dt, fallback, hp, up = sol.u[0], sol.dt, Fallback.NONE, self._resimulate(h, sol.u, sol.dt), sol.u
            self._plan = sol
        else:
            hp, up, dt = guess
            u, fallback = up[0], Fallback.SHIFTED_PLAN if previous is not None else Fallback.GUESS
            self._plan = ModeIISolution(sol.status, hp, up, dt, sol.solve_time, iters, np.nan, sol.w)
        if self._helper is not None and self.settings.mode3_entry_helper:  # Mode III where this plan meets the plane
            self._helper.submit(ContactEntry(self.contact, self.ocp3(self.contact).settings.horizon, hp[-1].copy(),
                                             np.clip(up[-1], self.lo, self.hi), self.current.copy(),
                                             self.lo.copy(), self.hi.copy()))
        # Algorithm 1
        coast = None
        if N > 1:
            self._horizon2 = min(N - 1, next_horizon(N, dt, s.dt_nominal))
        else:
            self.mode, self._plan = Mode.III, None
            if self.settings.handover_coast:
                coast = np.asarray(up[-1], float).copy()
                coast[self.model.params.n_thrusters:] = 0.0
                coast = np.clip(coast, self.lo, self.hi)[None]
        return _ModeStep(u, sol.status, fallback, iters, dt, N, hp, up, certificate=cert,
                         impact_force=ocp.impact_force(hp[-1]), commit_after=coast)

    def _mode3_entry(self, h: np.ndarray, ocp: ModeIIIOCP) -> ModeIIISolution | None:
        """Under a latency, Mode III's cold first solve over `mode3_entry_intervals` intervals (from
        Algorithm 2's guess), its plan held over `ocp`'s horizon. None without a latency,
        with that setting off or not shorter than the horizon, or when that solve fails (the whole
        horizon's is then solved)."""
        k, N = self.settings.mode3_entry_intervals, ocp.settings.horizon
        if self.latency <= 0.0 or k is None or k >= N:
            return None
        short = self.ocp3(self.contact, k)
        held = np.repeat(self.last_u[None], k, 0)
        sol = short.solve(h, short.contact_guess(h, held, None, self.current), self.current)
        return short.held_over(sol, N) if sol.status.usable else None

    def _step_mode3(self, h: np.ndarray, entry: bool = False) -> _ModeStep:
        """Mode III's step; `entry`: its first after Mode II (the entry helper's answer, if any, is its start)."""
        self._reported_mode = Mode.III
        ocp = self.ocp3(self.contact)
        s = ocp.settings
        previous = self._plan if isinstance(self._plan, ModeIIISolution) else None
        ahead, entered = None, None
        if entry and self._helper is not None and self.settings.mode3_entry_helper:
            answer = self._helper.take(ContactEntry, self.contact, s.horizon)
            ahead = None if answer is None else answer[1]
        step_ahead = None
        if previous is not None and self._helper is not None and self.settings.mode3_step_helper:
            answer = self._helper.take(ContactStep, self.contact, s.horizon)
            if answer is not None and answer[0].plan_index == self._mode3_plans:
                step_ahead = answer[1]
        if step_ahead is not None:  # the previous plan's successor solved ahead, from h measured now
            guess = ocp.pack(np.vstack([h, step_ahead.h[1:]]), step_ahead.u, step_ahead.force)
            duals = (step_ahead.lam_g, step_ahead.lam_x)
        elif previous is not None:  # the Final Algorithm: the plan's recomputed states, shifted, from h
            us = np.vstack([previous.u[1:], previous.u[-1:]])
            Fs = np.vstack([previous.force[1:], previous.force[-1:]])
            guess = ocp.pack(np.vstack([h, self._recomputed[2:], self._recomputed[-1:]]), us, Fs)
            duals = ocp.shifted_duals(previous)
        elif ahead is not None:  # the entry solved ahead from the predicted contact state, from h measured now
            guess, duals = ocp.pack(np.vstack([h, ahead.h[1:]]), ahead.u, ahead.force), (ahead.lam_g, ahead.lam_x)
        else:  # Algorithm 2, under a latency over fewer intervals first (_mode3_entry)
            entered = self._mode3_entry(h, ocp)
            held = np.repeat(self.last_u[None], s.horizon, 0)
            guess, duals = (ocp.contact_guess(h, held, None, self.current) if entered is None else None), None
        sol = entered if guess is None else ocp.solve(h, guess, self.current, duals)
        self._ocp_time = sol.solve_time
        if sol.status.usable:
            self._plan, self._recomputed = sol, self._resimulate(h, sol.u, s.dt, sol.force, ocp)
            self._mode3_plans += 1
            if self._helper is not None and self.settings.mode3_step_helper:
                self._helper.submit(ContactStep(self.contact, s.horizon, self._mode3_plans, self._recomputed.copy(),
                                                sol, self.current.copy(), self.lo.copy(), self.hi.copy()))
            return _ModeStep(sol.u[0], sol.status, Fallback.NONE, sol.iterations, s.dt, s.horizon,
                             self._recomputed, sol.u, sol.force)
        self._plan = None
        if previous is not None:
            return _ModeStep(previous.u[1], sol.status, Fallback.SHIFTED_PLAN, sol.iterations, s.dt, s.horizon,
                             previous.h[1:], previous.u[1:], previous.force[1:])
        if self.settings.redeploy:  # a plan that keeps the links off the wall rather than a rigid arm
            self.mode, self._horizon2 = Mode.II, self.settings.mode2.horizon
            out = self._step_mode2(h)
            return replace(out, fallback=Fallback.REDEPLOY if out.fallback is Fallback.NONE else out.fallback)
        u = self._hold(h, h[6:6 + self.model.n_joints], self.current)
        return _ModeStep(u, sol.status, Fallback.HOLD, sol.iterations, s.dt, s.horizon, h[None], u[None])


@dataclass(frozen=True)
class _Sample:
    """A step as the observer's next update reads it: the measured state, the input returned, the
    sample time [s], whether nothing touched, the input that acted first in the period (the
    previous one, for `delay` seconds until this one arrived; None: this one from the sample on),
    whether both are known to have acted so (`timed`), and whether this input was applied."""

    h: np.ndarray
    u: np.ndarray
    t: float
    free: bool
    before: tuple[np.ndarray, float] | None
    timed: bool
    delay: float
    applied: bool


class SwitchingController:
    """The switching NMPC behind the controller protocol (controller.protocol): built at `reset`
    from the task's vehicle, planes and reference; told the known current and faults each step.
    With `switching=False` in its settings it is the Mode-I-only baseline. With `observe_current` (the
    default) the model's current is the known one plus controller.estimator's estimate of the rest, and the
    model's hull weight its own plus the estimated extra weight, updated from each pair of measured
    states in any mode while every body and the tip are at least `contact_clearance` off every plane
    at both (a contact's force would read as a current or a weight), and held
    otherwise. Under a latency (with `observe_under_latency`, the default; else not updated there)
    each period's prediction holds the previous input until this step's arrives (the told delay; on
    the wall clock without one, the step's own duration), then this one (`_sample`), and a period
    whose inputs the loop replaced is skipped.
    With `trim_in_contact`, a vehicle in contact before the observer's first update (arm-deployed: on
    the wall 0.05 s in) plans with the extra weight the task's trim check tells (Task.trim less the
    model's own weight in water) instead of none; in free flight the observer's estimate stands, also
    before its first update (told at the first step, Mode I's first plan pitches a heavy hull and the
    observer's first target misreads it: experiments/trim_prior).

    With a task latency L > 0 (none told on the wall clock: `assumed_latency`) and `plan_for_latency`,
    each step after the first predicts the state L after the measured one under the input it returned last,
    which acts meanwhile, in free flight (SwitchingNMPC.predict): Modes I and II plan from it for
    the reference at t + L, and Mode III's entry check reads the tip there; Mode III plans from the
    measured state (SwitchingNMPC.step says why). Mode II's intervals are at least L long, so that
    each input acts for as long as it was planned: dt_bounds scaled so that their lower end is L
    (their ratio kept: the default's (0.025, 0.05) s become (L, 2L), so that a plan behind schedule
    can still stretch its time to contact: experiments/realtime_mode2_stretch), dt_nominal raised
    to L. It does not use the protocol's `late` (predicting under the committed input lost in
    strict real time: experiments/realtime_late_notice). Algorithm 1's horizon rule is unchanged:
    the plan of the next step starts one interval later, as without a delay. L may not exceed Mode
    I's or Mode III's interval. Under an assumed L each faster step returns L after its call
    (`release_at_latency`)."""

    settings_type = SwitchingSettings
    contact_clearance = 0.02  # m

    def __init__(self, settings: SwitchingSettings = SwitchingSettings(),
                 on_solve: Callable[[SolveEvent], None] | None = None):
        self.settings, self.on_solve = settings, on_solve
        self.nmpc: SwitchingNMPC | None = None
        self.observer: CurrentObserver | None = None
        self._trim: np.ndarray | None = None  # the told extra weight as the model's vc (trim_in_contact)
        self._task: Task | None = None
        self._failed: tuple[int, ...] = ()
        self._last: _Sample | None = None  # the last step's, for the observer's next update

    def reset(self, task: Task) -> None:
        model = UVMSModel(task.params, task.scene.water, self.settings.model_options())
        self._task, self._failed, self._last = task, task.failed_thrusters(0.0), None
        settings = replace(self.settings, failed_thrusters=self._failed,
                           current=tuple(float(c) for c in task.scene.current.at(0.0)))
        told = float(task.latency)
        latency = told if told > 0.0 or not task.wall_clock else self.settings.assumed_latency
        self.latency = latency if self.settings.plan_for_latency else 0.0
        if self.latency > 0.0:
            s = settings
            longest = min(s.mode1.dt, s.mode3.dt)
            if self.latency > longest + 1e-12:
                raise ValueError(f"latency {self.latency} s (told or assumed) is longer than Mode I's and III's "
                                 f"interval; allowed: at most {longest} s, or plan_for_latency=false")
            m2 = s.mode2
            scale = max(1.0, self.latency / m2.dt_bounds[0])
            settings = replace(s, mode2=replace(m2, dt_nominal=max(m2.dt_nominal, self.latency),
                                                dt_bounds=(m2.dt_bounds[0] * scale, m2.dt_bounds[1] * scale)))
        self._started = False
        self._release = self.settings.release_at_latency and task.wall_clock and self.latency > float(task.latency)
        if self.nmpc is not None:
            self.nmpc.close()
        self.nmpc = SwitchingNMPC(model, task.scene.planes, task.reference, settings, self.on_solve)
        self.nmpc.latency = self.latency
        if self.latency > 0.0 and self.settings.switching:
            self.nmpc.prepare_every_problem()
        helpers = (self.settings.mode3_entry_helper, self.settings.mode2_entry_helper, self.settings.mode3_step_helper)
        if any(helpers) and self.latency > 0.0 and task.wall_clock:
            self.nmpc.start_entry_helper()
        self.observer = CurrentObserver(model, self.settings.observer) if self.settings.observe_current else None
        water_of = task.scene.water
        self._trim = None if not self.settings.trim_in_contact or task.trim is None else \
            water(np.zeros(3), task.trim - task.params.weight_in_water(water_of.density, water_of.gravity))

    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        if self.nmpc is None or self._task is None:
            raise ValueError("step before reset; allowed: reset(task) first")
        called = time.perf_counter()
        failed = self._task.failed_thrusters(t)
        if failed != self._failed:
            self.nmpc.set_failed_thrusters(failed)
            self._failed = failed
        known = water(self._task.scene.current.at(t))
        free = self.observer is not None and self._free(h)
        last = self._last
        if self.observer is not None:
            delayed = self.settings.observe_under_latency
            usable = last is not None and last.timed and last.free and free and t > last.t
            if usable and (delayed or self.latency == 0.0):
                self.observer.update(last.h, last.u, t - last.t, np.asarray(h, float), known,
                                     before=last.before if delayed else None)
            untaught = self._trim is not None and not free and not self.observer.updates
            known = known + (self._trim if untaught else self.observer.estimate)
        self.nmpc.current = known
        if self._started and self.latency > 0.0:  # the first step's input acts at once
            ahead = self.nmpc.predict(h, self.nmpc.last_u, self.latency), t + self.latency
            u, info = self.nmpc.step(h, t, ahead)
        else:
            u, info = self.nmpc.step(h, t)
        if self._release and self._started:
            time.sleep(max(0.0, self.latency - (time.perf_counter() - called)))
        self._last = self._sample(h, u, t, free, time.perf_counter() - called, last)
        self._started = True
        return u, replace(info, water=known.copy())

    def _sample(self, h: np.ndarray, u: np.ndarray, t: float, free: bool, duration: float,
                last: _Sample | None) -> _Sample:
        """This step's record for the observer: when its input acts (the told delay; on the wall
        clock without one, its own `duration` [s]; the first step's at once), the previous input
        acting until then, and whether both are known to have acted so (not when strict real time
        discarded either for a committed row, nor when this one came later than the previous one's
        period ran out: the loop then played that step's committed rows; closed_loop's docstring)."""
        told = float(self._task.latency) if self._task is not None else 0.0
        wall_clock = self._task is not None and self._task.wall_clock
        delay = 0.0 if not self._started else told if told > 0.0 else duration if wall_clock else 0.0
        applied = not (told > 0.0 and wall_clock and duration > told)
        if delay == 0.0 or last is None:
            return _Sample(np.asarray(h, float).copy(), u.copy(), t, free, None, applied, delay, applied)
        timed = applied and last.applied and delay <= last.delay + DELAY_TOLERANCE
        return _Sample(np.asarray(h, float).copy(), u.copy(), t, free, (last.u, delay), timed, delay, applied)

    def _free(self, h: np.ndarray) -> bool:
        """Every body and the tip at least `contact_clearance` off every plane: no contact force acts."""
        model, h = self.nmpc.model, np.asarray(h, float)
        return all(float(np.min(np.asarray(model.distances(h, pl.normal, pl.offset)))) > self.contact_clearance
                   and float(tip_gap(model, h, pl)) > self.contact_clearance for pl in self.nmpc.planes)
