"""The serving core's solve: a request's pairs through the one dispatcher
(:mod:`impactnet.models.dispatch`), admitted before they are solved.

Steps, each in the lane its known cost chooses (:mod:`impactnet.service.limits.lanes`), under
the request's deadline and its client's disconnect: the plan (the split of the rows: cheap, ~
the rows), the count (the broadphase's candidates under the caps), the memory reserved in the
request's lease (the candidates, one slice's working set, the largest answer), then the solve.
A step whose lane is the previous step's runs on in the same thread, without a hop.
A single box pair skips the lanes: it costs less than a thread hop. The models' refusals
become the API's errors: 413 naming the limit, 422 for a strict learned mode without a model.
"""
from __future__ import annotations

from dataclasses import dataclass

from impactnet.models.compound.candidates import TooManyCandidates
from impactnet.models.dispatch import Answers, Caps, TooManyContacts, TooManyShapePairs
from impactnet.models.dispatch.plan import Plan
from impactnet.models.learned.pair_dispatch import UnsupportedPairError
from impactnet.service.errors import LimitRefused, UnsupportedPair
from impactnet.service.limits.budget import Lease, MemoryBudget
from impactnet.service.limits.lanes import Work


def caps_of(settings) -> Caps:
    """The dispatcher's caps (the settings of the same meaning)."""
    return Caps(settings.max_candidates_per_pose, settings.max_candidates_per_request,
                settings.max_part_contacts_per_pose, settings.max_part_contacts_per_batch,
                settings.max_shape_pairs_per_request)


def _refused(exc: Exception, mode: str, batch: bool) -> Exception:
    """The API's error of a models' refusal."""
    if isinstance(exc, TooManyCandidates):
        if exc.pose is not None:
            return LimitRefused("too_many_candidates", "pairs", f"row {exc.pose} has "
                                f"{exc.count} candidate part pairs, more than "
                                f"max_candidates_per_pose ({exc.cap})", "max_candidates_per_pose")
        return LimitRefused("too_many_candidates", "pairs", f"the request has more than "
                            f"{exc.cap} candidate part pairs (max_candidates_per_request); "
                            "send fewer rows per request", "max_candidates_per_request")
    if isinstance(exc, TooManyShapePairs):
        return LimitRefused("too_many_shape_pairs", "pairs", f"the compound rows that may "
                            f"touch name {exc.count} distinct pairs of bodies, more than "
                            f"max_shape_pairs_per_request ({exc.cap}); send fewer distinct "
                            "bodies per request", "max_shape_pairs_per_request")
    if isinstance(exc, TooManyContacts):
        if exc.row is not None:
            return LimitRefused("too_many_part_contacts", "pairs", f"row {exc.row} has "
                                f"{exc.count} part contacts, more than "
                                f"max_part_contacts_per_pose ({exc.cap})",
                                "max_part_contacts_per_pose")
        return LimitRefused("too_many_part_contacts", "pairs", f"the request has more than "
                            f"{exc.cap} part contacts (max_part_contacts_per_batch); send "
                            "fewer rows per request", "max_part_contacts_per_batch")
    return UnsupportedPair(mode, exc.rows, exc.pairs, batch)


_REFUSALS = (TooManyCandidates, TooManyContacts, TooManyShapePairs, UnsupportedPairError)


def _plan(dispatcher, pairs, mode, include, margin, separated, caps: Caps):
    try:
        return dispatcher.plan(pairs, mode, include, margin, caps, separated)
    except _REFUSALS as exc:
        raise _refused(exc, mode, len(pairs) > 1) from None


def _count(dispatcher, plan, caps: Caps, lease: Lease):
    try:
        plan = dispatcher.count(plan, caps)
    except _REFUSALS as exc:
        raise _refused(exc, plan.mode, len(plan.pairs) > 1) from None
    lease.reserve(plan.memory_bytes(caps.contacts_per_request),
                  f"solving {len(plan.pairs)} pairs ({plan.candidates} candidate part pairs)")
    return plan


def _solve(dispatcher, plan, caps: Caps):
    try:
        return dispatcher.solve(plan, caps)
    except _REFUSALS as exc:
        raise _refused(exc, plan.mode, len(plan.pairs) > 1) from None


@dataclass
class Steps:
    """How far a request's plan, count and solve went (:func:`_steps`)."""

    plan: Plan | None = None
    counted: bool = False
    answers: Answers | None = None

    @property
    def done(self) -> bool:
        return self.answers is not None

    @property
    def cost(self) -> float:
        """The next step's known cost (box-pair solves)."""
        return self.plan.work


def _inline(dispatcher, pairs, mode, include, margin, caps, lease, separated=True):
    """The three steps at once, in this thread (a single box pair)."""
    return _steps(Steps(), dispatcher, pairs, (mode, include, margin, separated), caps, lease,
                  lambda cost: True).answers


def solve_now(dispatcher, pairs, mode: str, include, margin: float, settings):
    """Plan, count and solve at once in this thread, under the settings' caps and memory
    budget (``impactnet contact``: one request, nothing else running)."""
    lease = Lease(MemoryBudget(settings.memory_budget_bytes, 0.0, 1))
    return _inline(dispatcher, pairs, mode, include, margin, caps_of(settings), lease)


async def solve(work: Work, state, pairs, mode: str, include=(), margin: float = 0.0,
                lease: Lease | None = None, separated: bool = True):
    """The answers of ``pairs`` in ``mode`` (module docstring); ``separated=False``: rows
    without contact beyond the margin are not asked for their separating direction (a frame
    drops them)."""
    state.predictor(mode)  # 409 when the mode is not served
    settings = work.runtime.settings
    caps, dispatcher = caps_of(settings), state.dispatcher
    lease = lease if lease is not None else Lease(work.runtime.budget)
    if len(pairs) == 1 and pairs.table.is_box.all():
        return await work.inline(_inline, dispatcher, pairs, mode, include, margin, caps, lease,
                                 separated)
    done = await work.chain(len(pairs), _steps, Steps(), dispatcher, pairs,
                            (mode, include, margin, separated), caps, lease)
    return done.answers


def _steps(progress: Steps, dispatcher, pairs, request: tuple, caps: Caps, lease: Lease,
           stays) -> Steps:
    """The steps not taken yet (the plan, the count, the solve), for as long as the next
    step's known cost keeps it in this thread's lane (``stays(cost)``: :meth:`Work.chain`).
    ``request``: (mode, include, margin, separated)."""
    if progress.plan is None:
        progress.plan = _plan(dispatcher, pairs, *request, caps)
        if not stays(progress.plan.work):
            return progress
    if not progress.counted:
        progress.plan, progress.counted = _count(dispatcher, progress.plan, caps, lease), True
        if not stays(progress.plan.work):
            return progress
    progress.answers = _solve(dispatcher, progress.plan, caps)
    return progress
