"""``isj app``: the design space in the browser, on a local Bokeh server (docs/app.md)."""

from __future__ import annotations

import socket
import sys

from isj.errors import UsageError

from . import _common as c

#: Default port: Bokeh's.
DEFAULT_PORT = 5006


def register(sub) -> None:
    """Add ``isj app`` to the top-level subparsers ``sub``."""
    p = sub.add_parser(
        "app", help="explore designs in the browser: live lumped model, maps, uncertainty, FE verify"
    )
    p.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1: this machine only; another address exposes the "
        "app to the network)",
    )
    p.add_argument(
        "--port",
        type=c.int_option("--port", 0, 65535),
        default=DEFAULT_PORT,
        help=f"port, in [0, 65535]; 0 picks a free one (default {DEFAULT_PORT})",
    )
    p.add_argument("--no-browser", action="store_true", help="do not open a browser tab")
    p.set_defaults(func=run)


def _free_port(host: str) -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _check_bind(host: str, port: int) -> None:
    """Refuse, before the server starts, an address that cannot be bound (taken port, unknown host)."""
    try:
        with socket.socket() as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host, port))
    except OSError as exc:
        raise UsageError(
            f"--host {host} --port {port}: cannot listen there ({exc.strerror or exc})"
        ) from None


def run(args) -> int:
    from isj.app.server import serve

    port = args.port or _free_port(args.host)
    _check_bind(args.host, port)

    def ready(url: str) -> None:
        print(f"isj app: serving on {url} (Ctrl-C stops)", flush=True)

    serve(args.host, port, open_browser=not args.no_browser, on_ready=ready)
    print("isj app: stopped", file=sys.stderr)
    return 0
