"""The interactive design explorer in the browser (``splitlf explore``, :func:`serve`).

Needs the ``explore`` extra (Panel): ``pip install "splitlf[explore]"``. ``import
splitlf`` does not import this package; :func:`splitlf.explore` does, on first call.

The server binds 127.0.0.1 by default and accepts the page and its websocket only with a
``Host``/``Origin`` of that address and port (Bokeh's allow-list), so other hosts can
neither connect nor embed it.
"""

from __future__ import annotations

import ipaddress
import socket
from typing import Any

__all__ = ["serve", "allowed_origins", "free_port"]

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


def serve(design: Any = None, *, port: int = 0, address: str = LOOPBACK,
          threaded: bool = False, show: bool = False) -> Any:
    """Start the explorer's server for ``design`` (a :class:`~splitlf.Design` or a
    :class:`~splitlf.Camera`; default the seed preset) on ``address:port`` (``port=0``:
    a free port). Prints the URL. ``threaded=True`` returns the running server (a thread;
    ``.stop()`` ends it) at once; otherwise blocks until interrupted. Each browser session
    gets its own copy of the design."""
    import panel as pn

    from ..camera import Camera
    from ..design import Design
    from .app import Explorer

    if design is None:
        design = Design.preset("seed")
    if isinstance(design, Camera):
        design = design.design
    if not isinstance(design, Design):
        raise TypeError(f"design must be a splitlf.Design or a splitlf.Camera, got "
                        f"{type(design).__name__}")
    ipaddress.ip_address(address)  # a literal address: ValueError otherwise
    if port == 0:
        port = free_port(address)

    def session() -> Any:
        return Explorer(design).layout

    url = f"http://{address}:{port}/"
    print(f"splitlf explorer: {url}", flush=True)
    server = pn.serve({"/": session}, port=port, address=address, show=show,
                      allow_websocket_origin=allowed_origins(address, port),
                      threaded=threaded, title="splitlf explorer", start=True,
                      print_url=False)
    server.url = url  # type: ignore[attr-defined]
    return server
