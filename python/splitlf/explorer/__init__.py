"""The interactive design explorer in the browser (``splitlf explore``, :func:`serve`).

Needs the ``explore`` extra (Bokeh): ``pip install "splitlf[explore]"``. ``import
splitlf`` does not import this package; :func:`splitlf.explore` does, on first call.

The server binds 127.0.0.1 by default and accepts the page and its websocket only with a
``Host``/``Origin`` of that address and port (Bokeh's allow-list), so other hosts can
neither connect nor embed it.
"""

from __future__ import annotations

import asyncio
import atexit
import ipaddress
import socket
import threading
from typing import Any

__all__ = ["Running", "serve", "allowed_origins", "free_port"]

LOOPBACK = "127.0.0.1"


def free_port(address: str = LOOPBACK) -> int:
    """A TCP port free on ``address`` now (the OS picks it)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((address, 0))
        return int(s.getsockname()[1])


def allowed_origins(address: str, port: int) -> list[str]:
    """The ``host:port`` values the server accepts in ``Host`` and ``Origin``: the bound
    address (and ``localhost`` when it is the loopback)."""
    out = [f"{address}:{port}"]
    if address == LOOPBACK:
        out.append(f"localhost:{port}")
    return out


class Running:
    """A server running on its own thread: ``url``, ``server`` (Bokeh's) and :meth:`stop`.

    Jupyter shows it inline: its ``_repr_html_`` is an IFrame of the page (the notebook's
    browser must reach ``url``: a kernel on this machine)."""

    #: Height of the inline IFrame [px].
    height = 900

    def __init__(self, url: str, server: Any, thread: threading.Thread) -> None:
        self.url, self.server, self.thread = url, server, thread
        atexit.register(self.stop)  # the interpreter's exit stops the server cleanly

    def __repr__(self) -> str:
        return f"<splitlf explorer at {self.url}>"

    def _repr_html_(self) -> str:
        import html

        return (f'<iframe src="{html.escape(self.url, quote=True)}" width="100%" '
                f'height="{self.height}" style="border:0" title="splitlf explorer"></iframe>')

    def stop(self) -> None:
        """Stop the server and wait for its thread (again: nothing; also at interpreter
        exit)."""
        atexit.unregister(self.stop)
        if not self.thread.is_alive():
            return
        loop = self.server.io_loop

        def halt() -> None:
            self.server.stop()
            loop.stop()

        loop.add_callback(halt)
        self.thread.join(timeout=10)


def _refuse_other_hosts(server: Any, address: str) -> None:
    """Answer 403 to every request whose Host is not the bound address (or localhost for
    the loopback): Bokeh checks the websocket's Origin, this also covers the page itself
    (a DNS-rebinding page never gets a session)."""
    import re

    from tornado.web import RequestHandler

    class Forbidden(RequestHandler):
        def prepare(self) -> None:
            self.send_error(403)

    names = [re.escape(address)] + (["localhost"] if address == LOOPBACK else [])
    server._tornado.add_handlers(rf"^(?!(?:{'|'.join(names)})$).*$", [(r".*", Forbidden)])


def serve(design: Any = None, *, port: int = 0, address: str = LOOPBACK,
          threaded: bool = False, reference: Any = None) -> Any:
    """Start the explorer's server for ``design`` (a :class:`~splitlf.Design` or a
    :class:`~splitlf.Camera`; default the seed preset) on ``address:port`` (``port=0``:
    a free port) and print its URL. ``threaded=True`` returns a :class:`Running` server at
    once (``.url``, ``.stop()``); otherwise blocks until interrupted. Each browser session
    gets its own copy of the design. The URL is printed once the server listens (a port
    in use is an ``OSError`` before it); the server stops at interpreter exit.
    ``reference`` (a Design or Camera) is drawn beside it on the same axes (the page can
    also pin its current design as the reference)."""
    from bokeh.application import Application
    from bokeh.application.handlers.function import FunctionHandler
    from bokeh.server.server import Server

    from ..model.design import Design
    from .app import Explorer

    def as_design(value: Any, what: str) -> Design:
        """The general form of a design (a Camera is a Design: its two-channel form)."""
        if not isinstance(value, Design):
            raise TypeError(f"{what} must be a splitlf.Design or a splitlf.Camera, got "
                            f"{type(value).__name__}")
        return value.design

    design = as_design(Design.preset("seed") if design is None else design, "design")
    ref = None if reference is None else as_design(reference, "reference")
    ipaddress.ip_address(address)  # a literal address: ValueError otherwise
    if port == 0:
        port = free_port(address)

    def session(doc: Any) -> None:
        from bokeh.models import CustomJS

        from .app import SKIP_SAME_CSS_JS

        doc.add_root(Explorer(design, ref, doc).layout)
        doc.title = "splitlf explorer"
        doc.js_on_event("document_ready", CustomJS(code=SKIP_SAME_CSS_JS))

    url = f"http://{address}:{port}/"

    def make() -> Any:
        server = Server({"/": Application(FunctionHandler(session))}, port=port,
                        address=address, allow_websocket_origin=allowed_origins(address, port))
        _refuse_other_hosts(server, address)
        return server

    if not threaded:
        server = make()  # binds the port: an OSError here, before the URL is printed
        server.start()
        print(f"splitlf explorer: {url}", flush=True)
        atexit.register(server.stop)
        try:
            server.io_loop.start()
        finally:
            atexit.unregister(server.stop)
            server.stop()
        return server
    holder: list[Any] = []
    errors: list[BaseException] = []
    ready = threading.Event()

    def run() -> None:
        asyncio.set_event_loop(asyncio.new_event_loop())
        try:
            server = make()
            server.start()
        except BaseException as e:  # reported to the caller below
            errors.append(e)
            ready.set()
            return
        holder.append(server)
        ready.set()
        server.io_loop.start()

    thread = threading.Thread(target=run, name="splitlf-explorer", daemon=True)
    thread.start()
    ready.wait(60)
    if errors:
        raise errors[0]
    print(f"splitlf explorer: {url}", flush=True)
    return Running(url, holder[0], thread)
