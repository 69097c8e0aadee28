"""Generate CURVE key pairs for the daemon and its clients (``streamseg keys DIR``).

Writes ``DIR/server.key`` + ``server.key_secret`` (kept if present), ``DIR/client.key`` +
``client.key_secret`` (and ``client2`` ... with ``--clients N``), and a copy of each client
public key in ``DIR/authorized/``, the keys ``streamseg serve --curve-dir DIR`` accepts.
"""

from __future__ import annotations


def add_arguments(parser) -> None:
    parser.add_argument("dir", help="directory for the key files (created)")
    parser.add_argument(
        "--clients", type=int, default=1, metavar="N", help="client key pairs to make (default 1)"
    )


def run(args) -> int:
    from streamseg.daemon.security import generate
    from streamseg.exceptions import ParameterError

    if args.clients < 1:
        raise ParameterError(
            f"--clients {args.clients} is invalid: expected a number of client key pairs >= 1"
        )
    written = generate(args.dir, clients=args.clients)
    for p in written:
        print(f"wrote {p}")
    print(
        f"serve with --curve-dir {args.dir}; give clients --curve-dir (client.key_secret "
        f"and server.key); a client key is accepted while its .key is in "
        f"{args.dir}/authorized/"
    )
    return 0
