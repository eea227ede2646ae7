"""Refinement sessions: model versions with their errors, so work can be resumed.

Every stored field is validated before the one transaction that stores it; the versions are
numbered and labelled by :class:`pneucore.analysis.history.RefinementHistory` (through the store).
"""
from fastapi import APIRouter

from pneucore.analysis.compare import errors as model_errors
from pneucore.spec.effects import EFFECTS
from pneucore.spec.validation import FieldError, choice, finite_json

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, StoreDep, not_found, parse_experiments, parse_model
from ..schemas import SessionCreate, SessionOut, SessionSummary, VersionCreate

router = APIRouter(prefix="/api/sessions", tags=["sessions"], route_class=OffLoopRoute)


def _errors(model, experiments, store, limits):
    """``(errors, overall)`` of ``model`` on the experiments; None without experiments."""
    if not experiments:
        return None
    return model_errors(model, parse_experiments(experiments, model, store, limits))


@router.post("", status_code=201, summary="Start a refinement session (version 0 = the given model)",
             response_model=SessionOut)
def create_session(req: SessionCreate, store: StoreDep, limits: LimitsDep):
    model = parse_model(req.model)
    comparison = _errors(model, req.experiments, store, limits)
    exps = finite_json([e.model_dump(exclude_none=True) for e in req.experiments], "experiments")
    sid = store.create_session(req.name, exps, model, comparison)
    return store.session(sid)


@router.get("", summary="List sessions", response_model=list[SessionSummary])
def list_sessions(store: StoreDep):
    return store.list_sessions()


@router.get("/{session_id}", summary="A session with all its versions", response_model=SessionOut)
def get_session(session_id: str, store: StoreDep):
    s = store.session(session_id)
    if s is None:
        raise not_found("session", session_id)
    return s


@router.post("/{session_id}/versions", status_code=201,
             summary="Add a model version (errors recomputed on the session's experiments)",
             response_model=SessionOut)
def add_version(session_id: str, req: VersionCreate, store: StoreDep, limits: LimitsDep):
    s = store.session(session_id)
    if s is None:
        raise not_found("session", session_id)
    model = parse_model(req.model)
    if req.added is not None:
        choice(req.added, EFFECTS, "added")
    params = finite_json(req.params, "params")
    from ..schemas import ExperimentIn
    try:
        exps = [ExperimentIn(**e) for e in s["experiments"]]
    except (TypeError, ValueError):
        raise FieldError("session", f"session {session_id!r} has unreadable experiments; "
                                    f"start a new session") from None
    store.add_version(session_id, model, _errors(model, exps, store, limits), req.added, params,
                      req.note)
    return store.session(session_id)


@router.delete("/{session_id}", status_code=204, summary="Delete a session")
def delete_session(session_id: str, store: StoreDep):
    if not store.delete_session(session_id):
        raise not_found("session", session_id)
