"""The view's web server: viser on one address and port, loopback unless the user names another.

viser (PyPI ``viser``) serves its three.js client from its own wheel and talks to the page
over one websocket on the same port, so the page loads nothing from anywhere else. Three of
its defaults do not suit a suite that stays on the machine, and are changed here:

- it binds 0.0.0.0 (every interface): here the host is 127.0.0.1 unless given;
- a port in use makes it try the next one silently: here that is an error naming the port
  (:class:`PortInUseError`), checked before it starts and again after (a race);
- its page has a "share" button whose request makes the *server* open a tunnel through a
  public relay: here the button is hidden and the request refused (:class:`LocalViserServer`);
- it answers any ``Host`` and ``Origin``: here a request of another site's page (DNS
  rebinding, a cross-site websocket) is refused (:mod:`.request_guard`);
- it applies any value a client sends for a control: here one that does not fit the control
  is refused (:mod:`.control_values`).
"""

from __future__ import annotations

import contextlib
import errno
import io
import ipaddress
import socket
from typing import Any

from tensegrity_core.errors import TensegrityError
from tensegrity_ros.view import control_values, request_guard

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080


class ViewError(TensegrityError):
    """The view cannot start or go on (a one-line reason for the user)."""


class PortInUseError(ViewError):
    pass


def require_viser() -> None:
    """Raise :class:`ViewError` (one line) unless the ``view`` extra is installed."""
    try:
        import viser  # noqa: F401
    except ImportError as err:
        raise ViewError(f"the view needs the 'view' extra ({err}): pip install 'tensegrity-ros[view]' "
                        "(./run installs it)") from None


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and names that resolve only to them (``localhost``)."""
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        try:
            infos = socket.getaddrinfo(host, None)
        except socket.gaierror:
            return False
        return bool(infos) and all(ipaddress.ip_address(i[4][0]).is_loopback for i in infos)


def check_port_free(host: str, port: int) -> None:
    """Raise :class:`PortInUseError` if ``host:port`` cannot be bound now, :class:`ViewError`
    for an address that is not this machine's."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        # as the server binds (asyncio sets it): connections of an earlier run still in
        # TIME_WAIT do not count, another listener does
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError as err:
            if err.errno == errno.EADDRINUSE:
                raise PortInUseError(f"port {port} on {host} is in use (another view or program listens there); "
                                     "choose another with --port") from None
            raise ViewError(f"cannot listen on {host}:{port}: {err.strerror}") from None


def start_server(host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, *, label: str = "tensegrity view") -> Any:
    """A started :class:`LocalViserServer` on ``host:port`` (``port`` 0: any free port)."""
    import viser

    class LocalViserServer(viser.ViserServer):
        """viser's server without the public share tunnel (see the module docstring)."""

        def request_share_url(self, verbose: bool = True) -> None:
            print("tensegrity view: sharing through a public relay is disabled; the view stays on this machine")
            return None

    if port:
        check_port_free(host, port)
    request_guard.install()
    control_values.install()
    with contextlib.redirect_stdout(io.StringIO()):     # viser's own banner: the command prints the URL
        server = LocalViserServer(host=host, port=port, label=label, verbose=False)
    if not request_guard.guarding():
        server.stop()
        raise ViewError(f"viser {viser.__version__} serves without the view's Host/Origin check "
                        "(tensegrity_ros/view/request_guard.py): install the pinned viser (pip install '.[view]')")
    if port and server.get_port() != port:
        bound = server.get_port()
        server.stop()
        raise PortInUseError(f"port {port} on {host} was taken while the view started (viser moved to {bound}); "
                             "choose another with --port")
    server.gui.configure_theme(show_share_button=False, show_logo=False, control_width="large")
    server.gui.main_panel.dock_right()      # the controls docked to the right edge, beside the scene
    # Plain lights, no shadows and no environment map (image-based lighting): the page stays
    # fluid on software WebGL (no GPU) too. viser's default map alone kept a page on SwiftShader
    # busy for about 10 s after it loaded (docs/design/view.md).
    server.scene.configure_default_lights(enabled=True, cast_shadow=False)
    server.scene.configure_environment_map(hdri=None)
    return server
