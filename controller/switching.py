"""The switching NMPC (paper Sec. IV, Algorithms 1-3 and the Final Algorithm): one `step` per
control period.

Mode selection (Algorithm 3): Mode I while the feasibility certificate (controller.feasibility:
the braking rollout, the previous plan shifted, Mode I's fresh plan, optionally Mode I's SQP with
a line search, then the minimum-violation problem) finds Mode I's feasible set non-empty; Mode II
once it is empty (the contact plane is the one the braking rollout comes closest to); Mode III
after the Mode II step taken with N_p = 1 (Algorithm 1), once the tip is within
`contact_tolerance` (1 cm) of the plane (not in the paper: under model error the tip can end that
step centimetres short, and Mode III, which holds the tip on the plane from its first interval on,
then drags it there in one interval; if it is short, Mode II starts afresh from the measured state,
or, if the hull already moves away faster than `separation_speed`, Mode I); back to Mode I after a Mode III step once
the hull moves away from the contact plane faster than `separation_speed` (0.05 m/s), measured at
the start of the next step, or as soon as a Mode III step cannot use its solve (Mode I's
certificate then decides afresh; on the Kane model with every thruster dead and a current,
holding Mode III through 34 failed solves let the hull drift onto the wall). The
paper's condition is d_0' > 0; it assumes that Mode I is feasible again once the hull stops
approaching. Under a current that keeps pushing towards the wall that assumption fails: the arm
let go, the current pushed the vehicle back, and the modes cycled with the hull a little closer
each time (the note on issue 4 has the measurements).

Optional (`certified_release`, off by default; not in the paper): leave Mode III, once the hull
moves away faster than `separation_speed`, only when the certificate's screens (braking rollout,
Mode I's fresh plan; no minimum-violation problem) find a point of F; otherwise the arm keeps
holding the wall, and the StepInfo carries the screens' UNDECIDED certificate. It ends the II/III
cycles under a pushing current (Kane model, thrusters-dead-current: I > II > III > I > II > III
instead of four cycles, hull >= 0.333 m against 0.314 m) and, on 72 MuJoCo runs of the three hardest
families, succeeds in 62 against the default's 60 (two fixes, no new failure) with fewer switches;
but one run that failed by an arm-link contact (wall-headon seed 5) then ends with the hull on the
wall (29 N s): held in Mode III, whose J_III is satisfied by a hull at rest, the hull crept in
under the current (bench/results/certified_release; the note on issue 4). That is why it is off.

Optional (`minimum_violation=False`, off by default): the certificate's screens alone decide, and
F counts as empty when none of them finds a point of it (SwitchReason.NOT_CERTIFIED): no IPOPT in
Mode I's step, at the price of switching as soon as the real-time plan leans on the margin
("switching-screens": with `certificate_margin` 5 mm below Mode I's, for the re-simulation's few
millimetres, and the certified release, so that the screens decide both ways).

Optional (`background_certificate`, off by default; not in the paper): the minimum-violation
problem runs on a second thread (controller.background_certificate) while Mode I goes on with its
real-time plan (Verdict.PENDING); its verdict, on the state it started from, decides at the first
step after it is done. Meant for real time (validation.closed_loop's `--latency measured`), where
the synchronous certificate's 0.5-2.5 s would otherwise hold the previous input; when the plant
waits for the controller the verdict comes after as many periods as the job's wall time spans, so
runs are not reproducible to the step. With `certificate_wait` > 0 the step that starts a job waits
that long for it: most minimum-violation problems, started from Mode I's plan and stopped at their
first witness, end within a few iterations (bench/results/min_violation_stop.md), and then decide
on the step's own state as the synchronous certificate does.

The deploy deadline (`deploy_deadline`, on by default since 2026-12-01; not in the paper): also
leave Mode I, with F not found empty, when the certificate's braking rollout brings a body that
Mode II protects within the margin no later than one control period after the time Mode II's
deploy rollout needs to put the tip on that plane: waiting longer would leave Mode II no time. F's
emptiness on the model is the paper's criterion, but under plant-model mismatch it comes too late:
once the certificate's minimum-violation problem stopped failing where F is not empty (the
superellipsoids' smoothing, controller.model.ModelOptions.support_smoothing), the three hardest
MuJoCo families succeeded in 52 of 72 runs without the deadline, every failure an arm link on the
wall, and in 64 with it (bench/results/smooth_deadline), against 63 for the previous default, whose
switches came from IPOPT failing on the minimum-violation problem (147 of 149); 68 with Mode I's
QPs from mu0 = 0.1 (bench/results/qp_mu0). StepInfo.switch says which rule decided.

Before each solve the previous plan is shifted by one interval and its state trajectory
recomputed from the measured state with the model's RK4 under the plan's inputs (and dt, and
contact forces) (paper: Final Algorithm). Mode III's recomputed states are put back on the plane
by Algorithm 2's inverse kinematics, since a prescribed contact force alone would let the tip
drift off it.

Solver failures. A solve whose status is not usable (controller.transcription.SolverStatus: Mode
I's SQP accepts its real-time iterate after a successful QP; IPOPT must reach its tolerance, its
acceptable level, or a feasible iterate at its cap) is not used. The fallback, reported in
StepInfo.fallback: the previous plan of the same mode shifted by one interval (its second input)
when there is one; otherwise Mode I brakes at full thrust (the
certificate's rollout), Mode II brakes while the arm swings towards the wall (its initial guess)
and Mode III, whose first solve (from Algorithm 2's cold start) failed, goes back to Mode II
afresh from the measured state (`redeploy`, the default since 2026-12-01; Fallback.REDEPLOY, or
Mode II's own fallback when its solve fails too; not in the paper). Without `redeploy` Mode III
brakes with the arm held rigid, so that a tip on the wall keeps pushing
(controller.rollouts.BrakingPolicy): in MuJoCo that rigid arm, its shoulder and elbow 1 to 2 cm
off the wall while the hull came on, was how 3 of the default's 4 failures in 72 runs of the
three hardest families began (bench/results/qp_mu0); with `redeploy`, 71 of 72 succeed, the 17
runs where it acts changing and the other 55 not (bench/results/redeploy).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from controller.background_certificate import BackgroundCertificate
from controller.feasibility import MIN_VIOLATION_MAX_ITER, Certificate, FeasibilityTest, Method, Stop, Verdict
from controller.mode1 import ModeIOCP, ModeISettings, OCPSolution, SolverStatus
from controller.mode2 import ModeIIOCP, ModeIISettings, ModeIISolution, next_horizon, shifted_guess
from controller.mode3 import ModeIIIOCP, ModeIIISettings, ModeIIISolution
from controller.model import UVMSModel
from controller.rollouts import BrakingPolicy, JointHold, simulate
from controller.transcription import tip_gap
from uvms.scene import Plane


class Mode(Enum):
    I = "I"  # noqa: E741 (the paper's name)
    II = "II"
    III = "III"


class SwitchReason(Enum):
    """Why a step left Mode I for Mode II."""

    F_EMPTY = "F empty: a positive minimum violation"
    SOLVER_FAILURE = "F taken as empty: IPOPT failed on the minimum-violation problem"
    DEPLOY_DEADLINE = "deploy deadline: waiting would leave Mode II no time to put the tip on the wall"
    NOT_CERTIFIED = "F taken as empty: no screen certified it (the minimum-violation problem is off)"


class Fallback(Enum):
    NONE = "none"
    SHIFTED_PLAN = "shifted previous plan"
    GUESS = "initial guess (Mode I: maximum braking; Mode II: braking while the arm deploys)"
    HOLD = "maximum braking with the arm held rigid at its posture (Mode III)"
    REDEPLOY = "Mode II afresh from the measured state (Mode III's first solve failed)"


@dataclass(frozen=True)
class SwitchingSettings:
    mode1: ModeISettings = field(default_factory=ModeISettings)
    mode2: ModeIISettings = field(default_factory=ModeIISettings)
    mode3: ModeIIISettings = field(default_factory=ModeIIISettings)
    feasibility_tolerance: float = 1e-3  # m, summed clearance violation
    certificate_margin: float | None = None  # m, the clearance the certificate asks of F's plans (None: Mode I's)
    certificate_warm_start: bool = False  # minimum violation from Mode I's fresh plan (controller.feasibility)
    certificate_retry: bool = False  # minimum violation again from Mode I's fresh plan when IPOPT fails (feasibility)
    certificate_max_iter: int = MIN_VIOLATION_MAX_ITER  # the minimum-violation problem's IPOPT cap (feasibility)
    certificate_stop: Stop = Stop.WITNESS  # where that IPOPT stops early (controller.feasibility, iterate_stop)
    certificate_plan_start: bool = True  # that IPOPT from Mode I's fresh plan, else the braking rollout
    deploy_deadline: bool = True  # also switch when waiting would leave Mode II no time to deploy the arm (_deadline)
    deadline_first: bool = True  # ask the deadline before the minimum-violation problem, and skip that when it fires
    redeploy: bool = True  # Mode III's first solve failing: Mode II afresh instead of HOLD (module doc)
    certificate_search: int = 0  # the certificate's line-search SQP screen, iterations (0: off; controller.feasibility)
    minimum_violation: bool = True  # False: the certificate's screens alone decide (F taken as empty if none certifies)
    background_certificate: bool = False  # the minimum-violation problem on a second thread (module doc)
    certificate_wait: float = 0.0  # s: ... and how long a step waits for the job it starts (background_certificate)
    switching: bool = True  # False: Mode I only, no certificate (the plain NMPC baseline)
    separation_speed: float = 0.05  # m/s: Mode III -> I once the hull moves away faster (the paper: 0)
    certified_release: bool = False  # ... and only once Mode I's certificate screens find a point of F (module doc)
    contact_tolerance: float | None = 0.01  # m: enter Mode III only with the tip this close to the plane (None: paper)
    failed_thrusters: tuple[int, ...] = ()  # thrusters the controller knows to be dead (bounds 0)
    current: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m/s, world: the current the model assumes
    prebuild: bool = True  # build Modes II and III for every plane at construction (else at first use)


@dataclass(frozen=True)
class StepInfo:
    """What one control step decided and why."""

    t: float  # s
    mode: Mode
    status: SolverStatus
    fallback: Fallback
    solve_time: float  # s, the whole step: certificate, guesses, solve, re-simulation
    ocp_time: float  # s, the mode's OCP solve alone (IPOPT)
    iterations: int
    dt: float  # s, the interval the input is meant to be held (Mode II: dt*)
    horizon: int  # N_p
    h_pred: np.ndarray  # (N+1, ns) predicted states (re-simulated by RK4 from the plan's inputs)
    u_pred: np.ndarray  # (N, nu)
    contact_force: np.ndarray | None  # (N, 3) planned contact force, obstacle frame [N] (Mode III)
    contact_plane: int | None  # index of the plane of Modes II and III
    distances: np.ndarray  # (n_planes, n_bodies) m, at the measured state
    closing_speeds: np.ndarray  # (n_planes, n_bodies) m/s
    certificate: Certificate | None  # Mode I's feasibility test, when it ran
    switch: SwitchReason | None = None  # set on the step that left Mode I for Mode II


class SwitchingNMPC:
    """Algorithm 3 over Modes I-III for a model and a set of planes. `reference` is the task: a
    state h_ref or a function of time t [s] returning one."""

    def __init__(self, model: UVMSModel, planes: Sequence[Plane],
                 reference: np.ndarray | Callable[[float], np.ndarray],
                 settings: SwitchingSettings = SwitchingSettings()):
        self.model, self.planes, self.settings = model, tuple(planes), settings
        if callable(reference):
            self.reference = reference
        else:
            fixed = np.asarray(reference, float)
            self.reference = lambda t: fixed
        self.current = np.asarray(settings.current, float)
        self.mode1 = ModeIOCP(model, planes, settings.mode1)
        certified = settings.mode1 if settings.certificate_margin is None else replace(
            settings.mode1, distance_margin=settings.certificate_margin)
        self.feasibility = FeasibilityTest(model, planes, certified, settings.feasibility_tolerance,
                                           settings.certificate_search, settings.certificate_warm_start,
                                           settings.certificate_retry, settings.certificate_max_iter,
                                           settings.certificate_stop, settings.certificate_plan_start)
        self._background = BackgroundCertificate(self.feasibility) if (
            settings.background_certificate and settings.switching and settings.minimum_violation) else None
        self._hold = BrakingPolicy(model, JointHold(stiffness=30.0, damping=3.0))
        self._mode2: dict[int, ModeIIOCP] = {}
        self._mode3: dict[int, ModeIIIOCP] = {}
        self.set_failed_thrusters(settings.failed_thrusters)
        if settings.switching and settings.prebuild:
            for plane in range(len(self.planes)):  # no 1 s assembly stall at the first switch
                self.ocp2(plane)
                self.ocp3(plane)
        self.mode = Mode.I
        self.contact: int | None = None
        self._plan: OCPSolution | ModeIISolution | ModeIIISolution | None = None
        self._recomputed = np.zeros((0, model.n_states))  # the Mode III plan's states from its inputs
        self._horizon2 = settings.mode2.horizon
        self._last_u = np.zeros(model.n_inputs)
        self._reported_mode = Mode.I
        self._mode3_fell_back = False  # the last Mode III step could not use its solve
        self._switch: SwitchReason | None = None  # why this step left Mode I
        self._release_probe: Certificate | None = None  # this step's check for leaving Mode III

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
            ocp = ModeIIOCP(self.model, self.planes, plane, self.settings.mode2)
            ocp.limit_inputs(self.lo, self.hi)
            self._mode2[plane] = ocp
        return self._mode2[plane]

    def ocp3(self, plane: int) -> ModeIIIOCP:
        if plane not in self._mode3:
            ocp = ModeIIIOCP(self.model, self.planes, plane, self.settings.mode3)
            ocp.limit_inputs(self.lo, self.hi)
            self._mode3[plane] = ocp
        return self._mode3[plane]

    def _geometry(self, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = [np.asarray(self.model.distances(h, pl.normal, pl.offset)).ravel() for pl in self.planes]
        dd = [np.asarray(self.model.closing_speeds(h, pl.normal, pl.offset)).ravel() for pl in self.planes]
        return np.array(d), np.array(dd)

    def _closest_plane(self, hs: np.ndarray) -> int:
        """The plane a rollout (states (K, ns)) comes closest to (smallest body clearance)."""
        worst = [min(float(np.min(np.asarray(self.model.distances(x, pl.normal, pl.offset)))) for x in hs)
                 for pl in self.planes]
        return int(np.argmin(worst))

    def _resimulate(self, h0: np.ndarray, us: np.ndarray, dt: float, forces: np.ndarray | None = None,
                    ocp3: ModeIIIOCP | None = None) -> np.ndarray:
        """The Final Algorithm's state trajectory of the inputs (RK4, 4 substeps per interval); with
        Mode III's contact forces and OCP, each node is put back on the plane."""
        if forces is None:
            return simulate(self.model, h0, us, dt, current=self.current)
        hs = [np.asarray(h0, float)]
        for k, uk in enumerate(us):
            h = hs[-1]
            for _ in range(4):
                h = self.model.step(h, uk, dt / 4, Fw=np.concatenate([forces[k], np.zeros(3)]), Rw=ocp3.Rw,
                                    vc=self.current)
            h[6:6 + self.model.n_joints] = ocp3.onto_plane(h)
            hs.append(h)
        return np.array(hs)

    # ------------------------------------------------------------------------------------------
    def step(self, h: np.ndarray, t: float) -> tuple[np.ndarray, StepInfo]:
        """The input u (thruster forces N, joint torques N m) to hold for info.dt seconds."""
        h = np.asarray(h, float)
        if h.shape != (self.model.n_states,) or not np.all(np.isfinite(h)):
            raise ValueError(f"state has shape {h.shape} or non-finite entries; allowed: "
                             f"{self.model.n_states} finite numbers")
        distances, closing = self._geometry(h)
        release = False  # Mode III's hold on the wall ends this step if Mode I's screens certify F
        if self.mode is Mode.III and self._reported_mode is Mode.III:
            if self._mode3_fell_back:
                self.mode, self._plan = Mode.I, None
            elif closing[self.contact, 0] > self.settings.separation_speed:
                release = self.settings.certified_release
                if not release:
                    self.mode, self._plan = Mode.I, None
        if self.mode is Mode.III and self._reported_mode is Mode.II and self._short_of_contact(h):
            if closing[self.contact, 0] > self.settings.separation_speed:  # no contact needed: the certificate decides
                self.mode, self._plan = Mode.I, None
            else:  # Mode II afresh: Algorithm 1's entry from the measured state
                self.mode, self._plan, self._horizon2 = Mode.II, None, self.settings.mode2.horizon
        t0 = time.perf_counter()
        self._switch, self._release_probe = None, None
        out = self._step_mode1(h, t, release=True) if release else None
        if out is not None:
            self.mode = Mode.I
        elif self.mode is Mode.I:
            out = self._step_mode1(h, t)
        elif self.mode is Mode.II:
            out = self._step_mode2(h)
        else:
            out = self._step_mode3(h)
        u, status, fallback, iterations, dt, N, hp, up, F, cert = out
        self._last_u = np.clip(u, self.lo, self.hi)
        info = StepInfo(t=t, mode=self._reported_mode, status=status, fallback=fallback,
                        solve_time=time.perf_counter() - t0, ocp_time=self._ocp_time, iterations=iterations, dt=dt,
                        horizon=N, h_pred=hp, u_pred=up, contact_force=F, contact_plane=self.contact,
                        distances=distances, closing_speeds=closing, certificate=cert, switch=self._switch)
        return self._last_u, info

    def _step_mode1(self, h: np.ndarray, t: float, release: bool = False):
        """Mode I's step. With `release` (from Mode III): only if the certificate's screens find a
        point of F (no minimum-violation problem); else None, and the probe's certificate is kept
        for Mode III's StepInfo."""
        s, ocp = self.settings.mode1, self.mode1
        ref = np.asarray(self.reference(t), float)
        previous = self._plan if isinstance(self._plan, OCPSolution) else None
        shifted, guess = None, None
        if previous is not None:
            us = np.vstack([previous.u[1:], previous.u[-1:]])
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

        background = self._background is not None and not release
        deadline: bool | None = None  # the deploy deadline, when it was asked before the minimum-violation problem

        def needed(screened: Certificate) -> bool:
            """Whether F's answer still matters: not when the deploy deadline switches either way."""
            nonlocal deadline
            deadline = self._deadline(h, screened)
            return not deadline

        cert = self.feasibility(h, ref, self.current, plan=shifted, fresh=solve_now,
                                minimum_violation=self.settings.minimum_violation and not release and not background,
                                needed=needed if self.settings.deadline_first else None) \
            if self.settings.switching else None
        if background:
            cert = self._background_verdict(h, ref, t, cert, (fresh["h"], fresh["sol"].u) if "h" in fresh else None)
        self._release_probe = cert if release else None
        if release and cert.verdict is not Verdict.FEASIBLE:
            return None
        if cert is not None and cert.verdict is Verdict.INFEASIBLE:
            self._switch = SwitchReason.F_EMPTY if np.isfinite(cert.violation) else SwitchReason.SOLVER_FAILURE
        elif deadline:
            self._switch = SwitchReason.DEPLOY_DEADLINE
        elif cert is not None and cert.verdict is Verdict.UNDECIDED:
            self._switch = SwitchReason.NOT_CERTIFIED
        elif cert is not None and not release and deadline is None and self._deadline(h, cert):
            self._switch = SwitchReason.DEPLOY_DEADLINE
        if self._switch is not None:
            if self._background is not None:
                self._background.discard()
            self.contact = self._closest_plane(cert.rollout)
            self.mode, self._plan, self._horizon2 = Mode.II, None, self.settings.mode2.horizon
            return self._step_mode2(h, cert)
        self._reported_mode = Mode.I
        if cert is not None and cert.method in (Method.GLOBALIZED_SQP, Method.MINIMUM_VIOLATION) \
                and cert.solution is not None and cert.age == 0:
            guess = ocp.guess_from_rollout(cert.solution.h, cert.solution.u)  # a better start than the fresh one
            fresh.clear()
        sol = fresh["sol"] if "sol" in fresh else ocp.solve(h, ref, self.current, previous=previous, guess=guess)
        self._ocp_time = sol.solve_time
        if sol.status.usable:
            self._plan = sol
            return (sol.u[0], sol.status, Fallback.NONE, sol.iterations, s.dt, s.horizon,
                    fresh["h"] if "h" in fresh else self._resimulate(h, sol.u, s.dt), sol.u, None, cert)
        if previous is not None:
            self._plan = None
            return (previous.u[1], sol.status, Fallback.SHIFTED_PLAN, sol.iterations, s.dt, s.horizon,
                    previous.h, previous.u, None, cert)
        hs, us = self.feasibility.braking_rollout(h, self.current)
        return us[0], sol.status, Fallback.GUESS, sol.iterations, s.dt, s.horizon, hs, us, None, cert

    def _background_verdict(self, h: np.ndarray, ref: np.ndarray, t: float, cert: Certificate,
                            plan: tuple[np.ndarray, np.ndarray] | None) -> Certificate:
        """With `background_certificate`: a screen's point of F stands (a background verdict, now
        stale, is dropped); else the finished background verdict when there is one (on an older
        state; with this step's braking rollout, which picks the contact plane), and a new job from
        this state (from `plan`, Mode I's fresh plan, when there is one) when that verdict does not
        end Mode I and none runs, whose verdict counts at once if it is done within
        `certificate_wait`; else PENDING."""
        bg = self._background
        if cert.verdict is Verdict.FEASIBLE:
            bg.discard()
            return cert
        done = bg.take(t)
        if (done is None or done.verdict is not Verdict.INFEASIBLE) and not bg.busy:
            bg.submit(h, ref, self.current, cert, t, plan)
            done = bg.take(t, self.settings.certificate_wait) or done
        if done is None:
            return replace(cert, verdict=Verdict.PENDING, method=Method.MINIMUM_VIOLATION)
        return replace(done, rollout=cert.rollout, rollout_inputs=cert.rollout_inputs,
                       rollout_clearance=cert.rollout_clearance)

    def _short_of_contact(self, h: np.ndarray) -> bool:
        """With `contact_tolerance`: whether the tip is further than that from the contact plane
        after Mode II's last (N_p = 1) step, so that Mode III, which holds it on the plane from its
        first interval on, would have to drag it there in one interval."""
        tol = self.settings.contact_tolerance
        return tol is not None and float(tip_gap(self.model, h, self.planes[self.contact])) > tol

    def _deadline(self, h: np.ndarray, cert: Certificate) -> bool:
        """With `deploy_deadline`: whether the braking rollout brings something Mode II protects (every
        body but the tip and the last link against the contact plane: ModeIIOCP.protected_clearance)
        within the margin (first node t_hit) no later than one control period after the time Mode
        II's deploy rollout needs to put the tip on that plane (t_c): waiting another step would
        leave Mode II no time. The tip and the last link are left out so that an arm still on the
        wall after Mode III does not count. It also applies right after Mode III lets go: with a
        current pushing the hull back, the rollout soon returns it, and Mode II then re-plans with
        the arm still near the wall. (Applying it only while the hull approaches, d_0' <= 0, let Mode
        I swing the arm away first: 3 more arm-link contacts in 72 MuJoCo runs, none fewer; the note
        on issue 4.)"""
        if not self.settings.deploy_deadline or cert.rollout_clearance >= 0:
            return False
        s, ocp2 = self.settings.mode1, self.ocp2(self._closest_plane(cert.rollout))
        close = [ocp2.protected_clearance(x) < self.feasibility.settings.distance_margin for x in cert.rollout[1:]]
        if not any(close):
            return False
        _, us, dt = ocp2.deploy_guess(h, self.settings.mode2.horizon, self.current)
        return s.dt * (1 + close.index(True)) <= len(us) * dt + s.dt

    def _step_mode2(self, h: np.ndarray, cert: Certificate | None = None):
        self._reported_mode = Mode.II
        s, ocp, N = self.settings.mode2, self.ocp2(self.contact), self._horizon2
        previous = self._plan if isinstance(self._plan, ModeIISolution) else None
        if previous is not None:
            us, dt = shifted_guess(previous, N)
            guess = (self._resimulate(h, us, dt), us, dt)
        else:
            guess = ocp.deploy_guess(h, N, self.current)
            N = len(guess[1])
        sol = ocp.solve(h, guess, self.current)
        self._ocp_time = sol.solve_time
        iters = sol.iterations
        if sol.status.usable:
            u, dt, fallback, hp, up = sol.u[0], sol.dt, Fallback.NONE, self._resimulate(h, sol.u, sol.dt), sol.u
            self._plan = sol
        else:
            hp, up, dt = guess
            u, fallback = up[0], Fallback.SHIFTED_PLAN if previous is not None else Fallback.GUESS
            self._plan = ModeIISolution(sol.status, hp, up, dt, sol.solve_time, iters, np.nan, sol.w)
        # Algorithm 1
        if N > 1:
            self._horizon2 = min(N - 1, next_horizon(N, dt, s.dt_nominal))
        else:
            self.mode, self._plan = Mode.III, None
        return u, sol.status, fallback, iters, dt, N, hp, up, None, cert

    def _step_mode3(self, h: np.ndarray):
        """Mode III's step; its StepInfo carries the certificate that did not release it, if any."""
        self._reported_mode = Mode.III
        probe = self._release_probe
        s, ocp = self.settings.mode3, self.ocp3(self.contact)
        previous = self._plan if isinstance(self._plan, ModeIIISolution) else None
        if previous is not None:  # the Final Algorithm: the plan's recomputed states, shifted, from h
            us = np.vstack([previous.u[1:], previous.u[-1:]])
            Fs = np.vstack([previous.force[1:], previous.force[-1:]])
            guess = ocp.pack(np.vstack([h, self._recomputed[2:], self._recomputed[-1:]]), us, Fs)
            duals = ocp.shifted_duals(previous)
        else:  # Algorithm 2
            guess = ocp.contact_guess(h, np.repeat(self._last_u[None], s.horizon, 0), None, self.current)
            duals = None
        sol = ocp.solve(h, guess, self.current, duals)
        self._ocp_time = sol.solve_time
        self._mode3_fell_back = not sol.status.usable
        if sol.status.usable:
            self._plan, self._recomputed = sol, self._resimulate(h, sol.u, s.dt, sol.force, ocp)
            return (sol.u[0], sol.status, Fallback.NONE, sol.iterations, s.dt, s.horizon,
                    self._recomputed, sol.u, sol.force, probe)
        self._plan = None
        if previous is not None:
            return (previous.u[1], sol.status, Fallback.SHIFTED_PLAN, sol.iterations, s.dt, s.horizon, previous.h,
                    previous.u, previous.force, probe)
        if self.settings.redeploy:  # a plan that keeps the links off the wall rather than a rigid arm
            self.mode, self._horizon2, self._mode3_fell_back = Mode.II, self.settings.mode2.horizon, False
            out = self._step_mode2(h)
            return (out[0], out[1], Fallback.REDEPLOY if out[2] is Fallback.NONE else out[2], *out[3:])
        u = self._hold(h, h[6:6 + self.model.n_joints], self.current)
        return u, sol.status, Fallback.HOLD, sol.iterations, s.dt, s.horizon, h[None], u[None], None, probe
