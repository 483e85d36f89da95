"""``dronefleet credentials`` (broker users) and ``dronefleet broker-config`` (issue 12).

    dronefleet credentials add-drone QUAD_1 --state ground.db --password-file quad1.secret
    dronefleet credentials add-ground ground --state ground.db --password-file ground.secret
    dronefleet credentials revoke QUAD_1 --state ground.db
    dronefleet broker-config --broker mosquitto --state ground.db --out /etc/mosquitto/dronefleet

A password is shown once, or written to a file only its owner can read (``--password-file``),
never taken from the command line. ``broker-config`` writes ``passwd`` and ``acl`` (mode 0600)
and ``dronefleet.conf`` to include from ``mosquitto.conf``.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
from pathlib import Path

from dronefleet.cli.ground import _host_port
from dronefleet.messaging.broker_users import BrokerUsers


def register(sub: argparse._SubParsersAction) -> None:
    c = sub.add_parser("credentials", help="broker users of the fleet (drones, ground services)")
    actions = c.add_subparsers(dest="action", metavar="ACTION", required=True)
    for action, what in (("add-drone", "a drone (its id)"), ("add-ground", "a ground service")):
        a = actions.add_parser(action, help=f"make the broker user of {what}; prints its password")
        a.add_argument("name")
        a.add_argument("--state", type=Path, required=True, help="the ground state DB")
        a.add_argument("--password-file", type=Path, help="write the password here (0600)")
        a.set_defaults(func=run_credentials, role="drone" if action == "add-drone" else "ground")
    r = actions.add_parser("revoke", help="remove a broker user")
    r.add_argument("name")
    r.add_argument("--state", type=Path, required=True)
    r.set_defaults(func=run_credentials, role=None)

    b = sub.add_parser(
        "broker-config",
        help="write the broker's users and rights: Mosquitto password and ACL files, or a "
        "RabbitMQ definitions file",
    )
    b.add_argument("--broker", choices=["mosquitto", "rabbitmq"], default="mosquitto")
    b.add_argument(
        "--vhost", default="dronefleet", help="RabbitMQ: the fleet's vhost (clients: VHOST:USER)"
    )
    b.add_argument("--state", type=Path, required=True, help="the ground state DB")
    b.add_argument(
        "--out", type=Path, required=True, help="folder for passwd, acl, dronefleet.conf"
    )
    b.add_argument("--listener", type=_host_port, default=("0.0.0.0", 1883), help="HOST:PORT")
    b.set_defaults(func=run_broker_config)


def _secret_file(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as out:
        out.write(text)
    os.chmod(path, 0o600)


def run_credentials(args: argparse.Namespace) -> int:
    return asyncio.run(_credentials(args))


async def _credentials(args: argparse.Namespace) -> int:
    from dronefleet.ground.broker_credentials import BrokerCredentials
    from dronefleet.ground.state import StateStore
    from dronefleet.messaging.broker_users import BrokerRole

    state = await StateStore(args.state).open()
    try:
        book = await BrokerCredentials(state).open()
        if args.role is None:
            if not await book.revoke(args.name):
                print(f"dronefleet credentials: no broker user {args.name!r}", file=sys.stderr)
                return 2
            print(f"revoked {args.name}; write the broker's files again (broker-config)")
            return 0
        password = await book.add(args.name, BrokerRole(args.role))
    finally:
        await state.close()
    if args.password_file:
        _secret_file(args.password_file, password + "\n")
        print(f"{args.role} user {args.name}: password written to {args.password_file}")
    else:
        print(f"{args.role} user {args.name}, password (shown once): {password}")
    return 0


def run_broker_config(args: argparse.Namespace) -> int:
    from dronefleet.messaging.broker_acl import mosquitto_files

    users = asyncio.run(_users(args.state))
    if not users.all():
        print("dronefleet broker-config: no broker users yet (dronefleet credentials add-...)",
              file=sys.stderr)  # fmt: skip
        return 2
    out: Path = args.out.resolve()
    if args.broker == "rabbitmq":
        return _rabbitmq(users, args.vhost, out)
    passwords, acl = mosquitto_files(users)
    _secret_file(out / "passwd", passwords)
    _secret_file(out / "acl", acl)
    host, port = args.listener
    (out / "dronefleet.conf").write_text(
        "# Written by dronefleet broker-config: every client has a user (no anonymous access).\n"
        f"listener {port} {host}\nallow_anonymous false\n"
        f"password_file {out / 'passwd'}\nacl_file {out / 'acl'}\n"
    )
    print(f"wrote {out}/passwd, {out}/acl and {out}/dronefleet.conf ({len(users.all())} users)")
    return 0


def _rabbitmq(users: BrokerUsers, vhost: str, out: Path) -> int:
    import json

    from dronefleet.errors import InvalidInput
    from dronefleet.messaging.rabbit_acl import rabbitmq_definitions

    try:
        definitions = rabbitmq_definitions(users, vhost)
    except InvalidInput as exc:
        print(f"dronefleet broker-config: {exc}", file=sys.stderr)
        return 2
    path = out / "rabbitmq-definitions.json"
    _secret_file(path, json.dumps(definitions, indent=2) + "\n")
    print(f"wrote {path} ({len(users.all())} users in vhost {vhost!r}); load it with:")
    print(f"  rabbitmqctl import_definitions {path}")
    return 0


async def _users(path: Path) -> BrokerUsers:
    from dronefleet.ground.broker_credentials import BrokerCredentials
    from dronefleet.ground.state import StateStore

    state = await StateStore(path).open()
    try:
        return await (await BrokerCredentials(state).open()).users()
    finally:
        await state.close()
