"""ZeroMQ CURVE for the daemon's three sockets, key files, and the loopback-only rule.

Layout of a key directory made by :func:`generate` (``streamseg keys DIR``)::

    DIR/server.key, DIR/server.key_secret   the daemon's pair (give server.key to clients)
    DIR/client.key, DIR/client.key_secret   a client pair (replay, listen, control)
    DIR/authorized/client.key               public keys the daemon accepts (add more here)

The daemon runs pyzmq's :class:`zmq.auth.thread.ThreadAuthenticator` (ZAP): a client whose
public key is not in ``authorized/`` never completes the handshake, so it can neither send,
subscribe nor control. Each accepted message carries the client's key as ``User-Id``.
"""

from __future__ import annotations

import ipaddress
import logging
import secrets
import shutil
import socket as _socket
import threading
from dataclasses import dataclass
from pathlib import Path

import zmq
import zmq.auth
from zmq.auth.thread import ThreadAuthenticator

# the daemon's modules took it from here before it was shared with the clients
from streamseg.endpoints import ipv6 as ipv6
from streamseg.exceptions import ParameterError

DOMAIN = "streamseg"  # the ZAP domain of the daemon's sockets
log = logging.getLogger("streamseg.security")


def generate(directory, clients: int = 1) -> list[Path]:
    """Write a server pair and ``clients`` client pairs (authorised) to ``directory``;
    returns the files written. Existing server keys are kept (clients would lose access)."""
    d = Path(directory)
    auth = d / "authorized"
    auth.mkdir(parents=True, exist_ok=True)
    written = []
    if not (d / "server.key_secret").exists():
        written += [Path(p) for p in zmq.auth.create_certificates(str(d), "server")]
    for k in range(clients):
        name = "client" if k == 0 else f"client{k + 1}"
        if (d / f"{name}.key_secret").exists():
            continue
        pub, sec = (Path(p) for p in zmq.auth.create_certificates(str(d), name))
        shutil.copy(pub, auth / pub.name)
        written += [pub, sec, auth / pub.name]
    for p in d.glob("*.key_secret"):
        p.chmod(0o600)
    return written


def _load(path: Path, secret: bool):
    if not path.exists():
        raise ParameterError(f"{path}: no such key file (make keys with `streamseg keys DIR`)")
    try:
        pub, sec = zmq.auth.load_certificate(str(path))
    except Exception as err:
        raise ParameterError(f"{path}: not a ZeroMQ certificate ({err})") from None
    if secret and sec is None:
        raise ParameterError(f"{path}: holds no secret key")
    if secret and path.stat().st_mode & 0o077:  # `keys` writes 0600; a copy may not keep it
        log.warning(
            "%s: the secret key is readable by other users (mode %o): chmod 600 %s",
            path,
            path.stat().st_mode & 0o777,
            path,
        )
    return pub, sec


@dataclass(frozen=True)
class ClientKeys:
    """A client's CURVE pair and the server's public key."""

    public: bytes
    secret: bytes
    server: bytes

    @classmethod
    def load(cls, directory, name: str = "client") -> ClientKeys:
        d = Path(directory)
        pub, sec = _load(d / f"{name}.key_secret", True)
        server, _ = _load(d / "server.key", False)
        return cls(pub, sec, server)

    def apply(self, sock: zmq.Socket) -> None:
        """Make ``sock`` (before connect) a CURVE client of the daemon."""
        sock.curve_publickey = self.public
        sock.curve_secretkey = self.secret
        sock.curve_serverkey = self.server


class ServerSecurity:
    """The daemon's side: server keys, the authenticator, and CURVE on each bound socket."""

    def __init__(self, ctx: zmq.Context, directory):
        d = Path(directory)
        self.public, self.secret = _load(d / "server.key_secret", True)
        self.authorized = d / "authorized"
        if not self.authorized.is_dir():
            raise ParameterError(
                f"{self.authorized}: no such directory of authorised client "
                f"public keys (make keys with `streamseg keys {d}`)"
            )
        self.auth = ThreadAuthenticator(ctx)
        self.auth.start()
        self.auth.configure_curve(domain=DOMAIN, location=str(self.authorized))

    def apply(self, sock: zmq.Socket) -> None:
        """Make ``sock`` (before bind) a CURVE server accepting only authorised keys."""
        sock.curve_secretkey = self.secret
        sock.curve_publickey = self.public
        sock.curve_server = True
        sock.zap_domain = DOMAIN.encode()

    def reload(self) -> None:
        """Re-read ``authorized/`` (a key added or removed takes effect for new connections)."""
        self.auth.configure_curve(domain=DOMAIN, location=str(self.authorized))

    def stop(self) -> None:
        self.auth.stop()


class ConnectionIds:
    """Without CURVE: a ZAP handler (a thread of the daemon's context) that accepts every
    connection of the ingest socket and names it ``conn-<run>-<n>``: ZeroMQ then attaches that
    ``User-Id`` to every message the connection delivers, so a quota or a stream's owner is one
    connection, which its peer cannot forge (a sender-supplied id could be any). ``<run>`` is
    random per daemon start: a name from before a restart matches no connection after it.
    Apply before binding; ``stop`` before the context ends."""

    ENDPOINT = "inproc://zeromq.zap.01"  # ZeroMQ's fixed ZAP address (RFC 27)

    def __init__(self, ctx: zmq.Context):
        self.sock = ctx.socket(zmq.REP)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.bind(self.ENDPOINT)
        self.run_id = secrets.token_hex(3)
        self.count = 0
        self._stopping = threading.Event()
        self.thread = threading.Thread(target=self._serve, name="streamseg-zap", daemon=True)
        self.thread.start()

    def apply(self, sock: zmq.Socket) -> None:
        sock.zap_domain = DOMAIN.encode()

    def _serve(self) -> None:
        while not self._stopping.is_set():
            if not self.sock.poll(100):
                continue
            version, request_id = self.sock.recv_multipart()[:2]
            self.count += 1
            self.sock.send_multipart(
                [
                    version,
                    request_id,
                    b"200",
                    b"OK",
                    f"conn-{self.run_id}-{self.count}".encode(),
                    b"",
                ]
            )
        self.sock.close(linger=0)

    def stop(self) -> None:
        self._stopping.set()
        self.thread.join(5)


def is_loopback(endpoint: str) -> bool:
    """True for ``ipc://``, ``inproc://`` and TCP endpoints on a loopback address."""
    if not endpoint.startswith("tcp://"):
        return endpoint.startswith(("ipc://", "inproc://"))
    host = endpoint[len("tcp://") :].rsplit(":", 1)[0].strip("[]")
    if ";" in host:  # "source;destination" form (connect only): judge the destination
        host = host.split(";")[-1]
    if host in ("*", ""):
        return False
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # an interface name or a host name: resolve it
        try:
            return all(
                ipaddress.ip_address(a[4][0]).is_loopback for a in _socket.getaddrinfo(host, None)
            )
        except (OSError, ValueError):
            return False


def check_binds(config) -> None:
    """Refuse non-loopback endpoints without CURVE unless ``insecure`` (ParameterError);
    publishers subscribed to (``subscribe``) are never encrypted: beyond loopback they need
    ``insecure``."""
    if config.insecure:
        return
    for ep in config.subscribe:
        if not is_loopback(ep):
            raise ParameterError(
                f"subscribe={ep} is not a loopback address: a subscription is not encrypted "
                f"(CURVE covers the PULL ingest only), so anyone on the way could read or "
                f"forge its frames. Send to the ingest endpoint with CURVE instead, or give "
                f"--insecure if the network is trusted"
            )
    if config.curve_dir:
        return
    for name in ("ingest", "publish", "control"):
        ep = getattr(config, name)
        if ep and not is_loopback(ep):
            raise ParameterError(
                f"{name}={ep} is not a loopback address and CURVE is off: anyone who can "
                f"reach it could send, listen and shut the daemon down. Give --curve-dir DIR "
                f"(keys from `streamseg keys DIR`), or --insecure if the network is trusted"
            )


def peer_of(frame) -> str | None:
    """Who sent a received ``zmq.Frame``: its ``User-Id`` (the CURVE key, else the connection's
    name from :class:`ConnectionIds`), else the peer address."""
    for prop in ("User-Id", "Peer-Address"):
        try:
            v = frame.get(prop)
        except (zmq.ZMQError, KeyError):
            continue
        if v and v != "anonymous":
            return v
    return None


def control_token() -> tuple:
    """``(token, file)`` of :func:`streamseg.protocol.auth.daemon_token`; ``(None, None)`` with
    a warning when it cannot be written (then only signals stop the daemon)."""
    from streamseg.protocol.auth import daemon_token, token_path

    try:
        return daemon_token()
    except OSError as err:
        log.warning(
            "cannot write the control token to %s (%s): shutdown and checkpoint are "
            "refused to every client; set XDG_RUNTIME_DIR to a private directory",
            token_path(),
            err,
        )
        return None, None
