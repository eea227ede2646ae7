"""Refinement sessions: model versions with their errors, so work can be resumed.

Every stored field is validated before the one transaction that stores it; the versions are
numbered and labelled by :class:`pneucore.analysis.history.RefinementHistory` (through the store);
the work is :func:`app.services.new_session` and :func:`app.services.add_session_version`.
"""
from fastapi import APIRouter

from ..bodies import OffLoopRoute
from ..deps import LimitsDep, StoreDep, not_found
from ..schemas import SessionCreate, SessionOut, SessionSummary, VersionCreate
from ..services import add_session_version, new_session

router = APIRouter(prefix="/api/sessions", tags=["sessions"], route_class=OffLoopRoute)


@router.post("", status_code=201, summary="Start a refinement session (version 0 = the given model)",
             response_model=SessionOut)
def create_session(req: SessionCreate, store: StoreDep, limits: LimitsDep):
    return store.session(new_session(req, store, limits))


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
    s = add_session_version(session_id, req, store, limits)
    if s is None:
        raise not_found("session", session_id)
    return s


@router.delete("/{session_id}", status_code=204, summary="Delete a session")
def delete_session(session_id: str, store: StoreDep):
    if not store.delete_session(session_id):
        raise not_found("session", session_id)
