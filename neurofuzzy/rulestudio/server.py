"""Starting the studio: :func:`studio` serves a rule file's folder with uvicorn and opens the
browser."""

from __future__ import annotations

import ipaddress
import os
import secrets
import socket
import threading
import time
import webbrowser
from pathlib import Path
from urllib.parse import quote

from ..errors import InputError

__all__ = ["studio", "Studio", "require_packages"]

#: the optional packages of ``pip install 'neurofuzzy[studio]'``
PACKAGES = ("starlette", "uvicorn")


def require_packages() -> None:
    """Raise :class:`~neurofuzzy.errors.MissingDependencyError` naming the extra when the
    web packages are missing."""
    from ..extras import require

    require("studio", "the rule studio")


class Studio:
    """A running studio (:func:`studio` with ``block=False``).

    Attributes
    ----------
    url : str
        The address to open (with the token when there is one).
    state : StudioState
        The folder, the opened document and the opened fit result.
    """

    def __init__(self, server, thread, url: str, state):
        self._server, self._thread = server, thread
        self.url, self.state = url, state

    def stop(self, timeout: float = 10.0) -> None:
        """Stop serving and wait for the server thread."""
        self._server.should_exit = True
        self._thread.join(timeout)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

    def __repr__(self):
        return f"Studio({self.url!r})"


def _resolve(rules) -> tuple[Path, Path | None]:
    """(folder, rule file or None) of what :func:`studio` was given."""
    if rules is None:
        return Path.cwd().resolve(), None
    from ..rules import locate

    path = locate(rules)        # a bare name: ./rules/NAME.yaml, ./NAME.yaml, else shipped
    if path.is_dir():
        return path.resolve(), None
    if not path.is_file():
        raise InputError("no such rule file", source=str(path))
    return path.resolve().parent, path.resolve()


def _bind(host: str, port: int) -> socket.socket:
    try:
        family = socket.AF_INET6 if ipaddress.ip_address(host).version == 6 else socket.AF_INET
    except ValueError:
        family = socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as error:
        sock.close()
        raise InputError(f"cannot listen on {host}:{port} ({error.strerror or error})",
                         key="--port" if port else "--host") from None
    sock.listen(64)
    sock.set_inheritable(True)
    return sock


def studio(rules=None, *, host: str | None = None, port: int = 0, open_browser: bool = True,
           block: bool = True, quiet: bool = False) -> Studio:
    """Start the rule studio: edit a rule base in the browser and see it as tissue.

    Parameters
    ----------
    rules : path or str, optional
        A rule file (its folder is where the studio may read and write), the name of a
        shipped one (``"liver"``), or a folder; default the current folder, whose rule files
        the page offers to open.
    host : str, optional
        Address to listen on. Default 127.0.0.1, answering only requests addressed to
        localhost. Given (e.g. ``"0.0.0.0"`` to be reached from other machines), every request
        must carry a token made for this run, which the printed URL holds.
    port : int
        0 (default): any free port.
    open_browser : bool
        Open the URL in the default browser.
    block : bool
        Serve until interrupted (Ctrl-C); False: serve in a background thread and return a
        :class:`Studio` to stop it.
    quiet : bool
        Print neither the URL nor the server's log.

    Returns
    -------
    Studio
        The running studio (when ``block`` is False; else after it stopped).
    """
    require_packages()
    import uvicorn

    from .app import StudioState, create_app

    folder, path = _resolve(rules)
    token = secrets.token_urlsafe(24) if host is not None else None
    state = StudioState(folder, path, token=token)
    bind_host = host or "127.0.0.1"
    sock = _bind(bind_host, int(port))
    actual = sock.getsockname()[1]
    shown = "127.0.0.1" if bind_host in ("0.0.0.0", "::") else bind_host
    shown = f"[{shown}]" if ":" in shown else shown
    url = f"http://{shown}:{actual}/" + (f"?token={quote(token)}" if token else "")
    config = uvicorn.Config(create_app(state), log_level="warning" if not quiet else "error",
                            access_log=False, lifespan="off")
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True,
                              name="neurofuzzy-studio")
    thread.start()
    deadline = time.monotonic() + 10
    while not server.started and thread.is_alive() and time.monotonic() < deadline:
        time.sleep(0.02)
    running = Studio(server, thread, url, state)
    if not quiet:
        print(f"neurofuzzy studio: {state.document.path if state.document else folder}\n"
              f"  open {url}\n  (Ctrl-C stops it)" if block else f"  open {url}", flush=True)
    if open_browser and not os.environ.get("NEUROFUZZY_NO_BROWSER"):
        webbrowser.open(url)
    if not block:
        return running
    try:
        while thread.is_alive():
            thread.join(0.5)
    except KeyboardInterrupt:
        running.stop()
    return running
