"""The studio's web application (Starlette): a static page and a JSON API over one folder.

Security, as notebook servers do it:

- the server binds 127.0.0.1 unless told otherwise (:mod:`.server`), and then answers only
  requests whose ``Host`` is a loopback name (a web page elsewhere cannot reach it through a
  DNS name that points at 127.0.0.1);
- with a ``token`` (given whenever the host is chosen), every request must carry it: in the
  URL (``?token=…``, which sets a same-site cookie), the cookie, or an ``X-Studio-Token``
  header; compared in constant time;
- requests that change anything are POSTs of ``application/json`` whose ``Origin`` (when
  sent) is the studio's own, so a form on another site cannot post to it;
- files are read and written only inside the opened file's folder (:func:`.document.inside`);
- the page's input is data (edits, names, numbers): nothing it sends is run, and the page
  runs no script but its own (Content-Security-Policy ``script-src 'self'``, no eval).
"""

from __future__ import annotations

import hmac
import json
import threading
from pathlib import Path

from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from ..errors import InputError
from ..formatting import json_safe
from .document import RuleDocument, inside
from .edits import EditError
from .fits import MAX_FIT_BYTES, find_results, fit_view, read_fit, read_results
from .tissue import poke, tissue_view
from .view import document_view

__all__ = ["create_app", "StudioState"]

STATIC = Path(__file__).parent / "static"
LOOPBACK = {"127.0.0.1", "localhost", "::1", "[::1]"}
COOKIE = "neurofuzzy_studio_token"
MAX_BODY = 2**20
HEADERS = {
    "Content-Security-Policy": "default-src 'self'; script-src 'self'; style-src 'self'; "
                               "img-src 'self' data:; connect-src 'self'; object-src 'none'; "
                               "base-uri 'none'; frame-ancestors 'none'; form-action 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
    "X-Frame-Options": "DENY",
}


class StudioState:
    """What the server holds: the folder, the opened file, the opened fit result.

    Parameters
    ----------
    folder : path
        Where files may be read and written.
    path : path, optional
        The rule file to open (inside ``folder``).
    token : str, optional
        Required of every request when given.
    """

    def __init__(self, folder, path=None, *, token: str | None = None):
        self.folder = Path(folder).resolve()
        self.token = token
        self.lock = threading.Lock()
        self.document = RuleDocument(path) if path is not None else None
        self.fit: tuple[str, list] | None = None

    def rule_files(self) -> list[str]:
        return sorted(p.name for p in self.folder.glob("*.y*ml") if p.is_file()
                      and not p.name.startswith("."))

    def view(self) -> dict:
        if self.document is None:
            return {"file": None, "folder": str(self.folder), "files": self.rule_files()}
        return {**document_view(self.document), "files": self.rule_files(),
                "fit": self.fit_summary()}

    def rules(self):
        """The rule base of the current text, or :class:`InputError` (status 409)."""
        if self.document is None:
            raise _Refused("open a rule file first", 409)
        check = self.document.check()
        if check.rules is None:
            raise _Refused(f"the rule base has {len(check.problems)} problem(s); fix them "
                           "to see the tissue", 409)
        return check.rules

    def fit_summary(self):
        if self.fit is None:
            return None
        check = self.document.check() if self.document else None
        return {"source": self.fit[0],
                "entries": fit_view(self.fit[1], check.rules if check else None)}


class _Refused(Exception):
    def __init__(self, message: str, status: int = 403):
        super().__init__(message)
        self.status = status


def _json(value, status: int = 200) -> JSONResponse:
    return JSONResponse(json_safe(value), status_code=status, headers=HEADERS)


async def _body(request: Request, limit: int = MAX_BODY) -> dict:
    if request.headers.get("content-type", "").split(";")[0].strip() != "application/json":
        raise _Refused("send JSON (Content-Type: application/json)", 415)
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise _Refused(f"request larger than {limit // 2**20} MB", 413)
        chunks.append(chunk)
    try:
        data = json.loads(b"".join(chunks) or b"{}")
    except ValueError:
        raise _Refused("the request is not JSON", 400) from None
    if not isinstance(data, dict):
        raise _Refused("send a JSON object", 400)
    return data


def create_app(state: StudioState) -> Starlette:
    """The Starlette application serving ``state``."""

    def locked(work, limit: int = MAX_BODY):
        async def endpoint(request: Request):
            try:
                body = await _body(request, limit) if request.method == "POST" else dict(
                    request.query_params)
            except _Refused as error:
                return _json({"error": str(error)}, error.status)

            def run():
                with state.lock:
                    return work(body)
            try:
                return _json(await run_in_threadpool(run))
            except _Refused as error:
                return _json({"error": str(error)}, error.status)
            except InputError as error:
                return _json({"error": error.detail if isinstance(error, EditError)
                              else str(error), "line": error.line,
                              "file": state.document.path.name if state.document else None},
                             400)
        return endpoint

    def get_state(body):
        return state.view()

    def edit(body):
        document = _document(state)
        document.apply(body.get("edit"))
        return state.view()

    def undo(body):
        _document(state).undo()
        return state.view()

    def redo(body):
        _document(state).redo()
        return state.view()

    def save(body):
        name = body.get("name")
        target = _document(state).save(None if name in (None, "") else str(name))
        return {"saved": target.name, "state": state.view()}

    def open_file(body):
        name = str(body.get("name", ""))
        if state.document is not None and state.document.dirty and not body.get("discard"):
            raise _Refused(f"{state.document.path.name} has unsaved changes; save them or "
                           "discard them first", 409)
        path = inside(state.folder, name)
        if path.parent != state.folder or not path.is_file():
            raise InputError(f"{name}: no such rule file in {state.folder}")
        state.document = RuleDocument(path)
        return state.view()

    def tissue(body):
        return tissue_view(state.rules(), str(body.get("name", "")))

    def block(body):
        force = body.get("force")
        return poke(state.rules(), str(body.get("tissue", "")),
                    None if force in (None, "") else _float(force))

    def fits(body):
        return {"results": find_results(state.folder)}

    def open_fit(body):
        if isinstance(body.get("content"), dict):
            name = str(body.get("name", "uploaded fit result"))[:200]
            entries = read_fit(body["content"], name)
        else:
            name = str(body.get("path", ""))
            entries = read_results(inside(state.folder, name))
        if not entries:
            raise InputError("holds no fitted specimen", source=name)
        state.fit = (name, entries)
        return state.view()

    def close_fit(body):
        state.fit = None
        return state.view()

    async def index(request: Request):
        response = FileResponse(STATIC / "index.html", headers=HEADERS)
        if state.token and request.query_params.get("token"):
            response.set_cookie(COOKIE, state.token, httponly=True, samesite="strict")
        return response

    routes = [
        Route("/", index),
        Route("/api/state", locked(get_state)),
        Route("/api/edit", locked(edit), methods=["POST"]),
        Route("/api/undo", locked(undo), methods=["POST"]),
        Route("/api/redo", locked(redo), methods=["POST"]),
        Route("/api/save", locked(save), methods=["POST"]),
        Route("/api/open", locked(open_file), methods=["POST"]),
        Route("/api/tissue", locked(tissue)),
        Route("/api/block", locked(block), methods=["POST"]),
        Route("/api/fits", locked(fits)),
        Route("/api/fit", locked(open_fit, MAX_FIT_BYTES), methods=["POST"]),
        Route("/api/fit/close", locked(close_fit), methods=["POST"]),
        Mount("/static", StaticFiles(directory=STATIC), name="static"),
    ]
    app = Starlette(routes=routes)
    return _Guard(app, state)


def _document(state: StudioState) -> RuleDocument:
    if state.document is None:
        raise _Refused("open a rule file first", 409)
    return state.document


def _float(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"got {value!r}; expected a number", key="force") from None


class _Guard:
    """ASGI middleware: the host, token and origin checks of the module docstring."""

    def __init__(self, app, state: StudioState):
        self.app, self.state = app, state

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        request = Request(scope)
        problem = self.refuse(request)
        if problem:
            response = Response(problem + "\n", status_code=403, media_type="text/plain",
                                headers=HEADERS)
            return await response(scope, receive, send)
        return await self.app(scope, receive, send)

    def refuse(self, request: Request) -> str | None:
        host = request.headers.get("host", "")
        if self.state.token is None:
            name = host.rsplit(":", 1)[0] if not host.startswith("[") else host.split("]")[0] + "]"
            if name not in LOOPBACK:
                return f"refused: this studio answers only on localhost, not {host!r}"
        else:
            given = (request.query_params.get("token") or request.headers.get("x-studio-token")
                     or request.cookies.get(COOKIE) or "")
            if not hmac.compare_digest(given.encode(), self.state.token.encode()):
                return "refused: this studio needs its token (open the URL it printed)"
        if request.method not in ("GET", "HEAD", "POST"):
            return f"refused: method {request.method}"
        origin = request.headers.get("origin")
        if request.method == "POST" and origin not in (None, f"http://{host}"):
            return f"refused: a request from another site ({origin})"
        return None
