"""The simulator's run control in the terms of the ``simulation_interfaces`` standard:
which states exist, which transitions are allowed and what each answers, and the stepping
requests of ``StepSimulation`` and ``SimulateSteps``. Plain logic, no node.

States: STOPPED (paused at the scene's initial state, clock at 0), PLAYING (time advances:
free-running, or lockstep with a controller), PAUSED (time stands; stepping requests step
it). Transitions (answer of ``SetSimulationState``):

==========  =======================  ======================  =======================
from \\ to   STOPPED                  PLAYING                 PAUSED
==========  =======================  ======================  =======================
STOPPED     ALREADY_IN_TARGET_STATE  OK                      OK (starts paused)
PLAYING     OK (reset, clock to 0)   ALREADY_IN_TARGET_STATE OK
PAUSED      OK (reset, clock to 0)   OK                      ALREADY_IN_TARGET_STATE
==========  =======================  ======================  =======================

QUITTING is not offered over ROS (FEATURE_UNSUPPORTED: stop the process); NO_WORLD,
LOADING_WORLD and unknown values are INCORRECT_TRANSITION.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field

from simulation_interfaces.msg import Result, SimulationState, SimulatorFeatures
from simulation_interfaces.srv import ResetSimulation, SetSimulationState

STOPPED, PLAYING, PAUSED = SimulationState.STATE_STOPPED, SimulationState.STATE_PLAYING, SimulationState.STATE_PAUSED
RUN_STATE_NAMES = {STOPPED: "stopped", PLAYING: "playing", PAUSED: "paused", SimulationState.STATE_QUITTING: "quitting",
                   SimulationState.STATE_NO_WORLD: "no world", SimulationState.STATE_LOADING_WORLD: "loading world"}
STATE_BY_NAME = {"stopped": STOPPED, "playing": PLAYING, "paused": PAUSED}

#: What this simulator implements (GetSimulatorFeatures); everything else is absent.
FEATURES = (SimulatorFeatures.SIMULATION_RESET, SimulatorFeatures.SIMULATION_RESET_STATE,
            SimulatorFeatures.SIMULATION_STATE_GETTING, SimulatorFeatures.SIMULATION_STATE_SETTING,
            SimulatorFeatures.SIMULATION_STATE_PAUSE, SimulatorFeatures.STEP_SIMULATION_SINGLE,
            SimulatorFeatures.STEP_SIMULATION_MULTIPLE, SimulatorFeatures.STEP_SIMULATION_ACTION)


@dataclass(frozen=True)
class Answer:
    """A ``simulation_interfaces`` result: ``code`` (Result or service-specific) and a message."""

    code: int
    message: str = ""

    @property
    def ok(self) -> bool:
        return bool(self.code == Result.RESULT_OK)


@dataclass(frozen=True)
class Transition:
    """The answer to a state change, and what to do: ``reset`` to the initial state with
    the clock at 0 (into STOPPED), then be in ``state``."""

    answer: Answer
    state: int
    reset: bool = False


def transition(current: int, target: int) -> Transition:
    """The transition from ``current`` to ``target`` (see the module table)."""
    if target == current:
        return Transition(Answer(SetSimulationState.Response.ALREADY_IN_TARGET_STATE,
                                 f"already {RUN_STATE_NAMES[current]}"), current)
    if target == SimulationState.STATE_QUITTING:
        return Transition(Answer(Result.RESULT_FEATURE_UNSUPPORTED,
                                 "quitting is not offered over ROS: stop the tensegrity_sim process"), current)
    if target not in (STOPPED, PLAYING, PAUSED):
        known = ", ".join(f"{v} {n}" for v, n in sorted(RUN_STATE_NAMES.items()))
        what = RUN_STATE_NAMES.get(target, "unknown")
        return Transition(Answer(SetSimulationState.Response.INCORRECT_TRANSITION,
                                 f"cannot set state {target} ({what}); states: {known}"), current)
    message = f"{RUN_STATE_NAMES[current]} -> {RUN_STATE_NAMES[target]}"
    return Transition(Answer(Result.RESULT_OK, message + (" (reset, clock at 0)" if target == STOPPED else "")),
                      target, reset=target == STOPPED)


@dataclass(frozen=True)
class ResetPlan:
    """What a ``ResetSimulation`` scope asks: the state back to the initial state, and the
    clock back to 0 too (``time``) or going on (state only)."""

    answer: Answer
    time: bool = False


def reset_plan(scope: int) -> ResetPlan:
    """SCOPE_DEFAULT/SCOPE_ALL: state and time; SCOPE_STATE: state, the clock goes on;
    SCOPE_STATE|SCOPE_TIME: both. Time alone and SCOPE_SPAWNED (nothing is ever spawned here)
    are not supported."""
    req = ResetSimulation.Request
    if scope in (req.SCOPE_DEFAULT, req.SCOPE_ALL):
        return ResetPlan(Answer(Result.RESULT_OK, "state and time reset"), time=True)
    if scope & ~(req.SCOPE_TIME | req.SCOPE_STATE | req.SCOPE_SPAWNED):
        return ResetPlan(Answer(Result.RESULT_FEATURE_UNSUPPORTED, f"unknown reset scope bits in {scope}"))
    if scope & req.SCOPE_SPAWNED:
        return ResetPlan(Answer(Result.RESULT_FEATURE_UNSUPPORTED,
                                "SCOPE_SPAWNED: this simulator spawns nothing (use SCOPE_STATE or SCOPE_ALL)"))
    if not scope & req.SCOPE_STATE:
        return ResetPlan(Answer(Result.RESULT_FEATURE_UNSUPPORTED,
                                "SCOPE_TIME alone is not supported: the time cannot go back without the state "
                                "(use SCOPE_ALL, or SCOPE_STATE to keep the clock going)"))
    both = bool(scope & req.SCOPE_TIME)
    return ResetPlan(Answer(Result.RESULT_OK, "state and time reset" if both else "state reset, the clock goes on"),
                     time=both)


@dataclass
class StepRequest:
    """``steps`` steps asked by StepSimulation or SimulateSteps. ``done`` is called once
    with the final :class:`Answer`; ``feedback(completed, remaining)`` after every step;
    ``cancel_requested`` is set from outside (an action cancel) and honoured at the next
    step boundary. ``owner``: the action goal handle that asked, if any."""

    steps: int
    done: Callable[[Answer], None]
    feedback: Callable[[int, int], None] | None = None
    owner: object = None             # the action goal handle that asked, if any
    completed: int = 0
    cancel_requested: bool = False
    _finished: threading.Event = field(default_factory=threading.Event)

    @property
    def remaining(self) -> int:
        return self.steps - self.completed

    def finish(self, answer: Answer) -> None:
        if not self._finished.is_set():
            self._finished.set()
            self.done(answer)

    @property
    def finished(self) -> bool:
        return self._finished.is_set()


def check_step_request(steps: int, state: int, busy: StepRequest | None, max_steps: int) -> Answer | None:
    """Why a stepping request of ``steps`` cannot start (an :class:`Answer`), or None.

    A simulation that is not paused answers RESULT_OPERATION_FAILED, the code the standard's
    StepSimulation and SimulateSteps name for that case (and O3DE's implementation
    answers); a request while another runs, RESULT_INCORRECT_STATE."""
    if state != PAUSED:
        return Answer(Result.RESULT_OPERATION_FAILED,
                      f"stepping needs the simulation paused; it is {RUN_STATE_NAMES[state]} "
                      "(SetSimulationState to STATE_PAUSED first)")
    if busy is not None and not busy.finished:
        return Answer(Result.RESULT_INCORRECT_STATE,
                      f"another stepping request is running ({busy.completed} of {busy.steps} steps done)")
    if steps < 1:
        return Answer(Result.RESULT_OPERATION_FAILED, f"steps must be at least 1, got {steps}")
    if steps > max_steps:
        return Answer(Result.RESULT_OPERATION_FAILED,
                      f"steps = {steps} is more than this simulator's max_steps_per_request = {max_steps}; "
                      "step in several requests")
    return None
