"""``dronefleet credentials`` (broker users) and ``dronefleet broker-config`` (issue 12).

    dronefleet credentials add-drone QUAD_1 --state ground.db --password-file quad1.secret
    dronefleet credentials add-ground ground --state ground.db --password-file ground.secret
    dronefleet credentials revoke QUAD_1 --state ground.db
    dronefleet broker-config --broker mosquitto --state ground.db --out /etc/mosquitto/dronefleet

A password is shown once, or written to a file only its owner can read (``--password-file``),
never taken from the command line. ``broker-config`` writes ``passwd`` and ``acl`` (mode 0600)
and ``dronefleet.conf``, for Mosquitto's ``include_dir`` (Debian's ``/etc/mosquitto/conf.d``).

Mosquitto 2.0 started as root drops to its own user before it opens those files: ``--owner``
(by default ``mosquitto`` when run as root) gets them, still 0600 (cli/broker_files.py).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

from dronefleet.cli.broker_files import (
    add_owner_argument,
    broker_owner,
    check_reachable,
    make_folder,
    secret_file,
)
from dronefleet.cli.ground import _host_port, state_spec
from dronefleet.messaging.broker_users import BrokerUsers

CREDENTIALS_EXAMPLES = """examples:
  dronefleet credentials add-drone QUAD_1 --state var/ground.db --password-file var/QUAD_1.secret
  dronefleet credentials add-ground ground --state var/ground.db --password-file var/ground.secret
  dronefleet credentials revoke QUAD_1 --state var/ground.db
"""
BROKER_CONFIG_EXAMPLES = """examples:
  dronefleet broker-config --state var/ground.db --out /etc/mosquitto/dronefleet \\
      --listener 0.0.0.0:1883
  dronefleet broker-config --broker rabbitmq --vhost fleet --state var/ground.db --out var
"""


def register(sub: argparse._SubParsersAction) -> None:
    c = sub.add_parser(
        "credentials",
        help="broker users of the fleet (drones, ground services)",
        epilog=CREDENTIALS_EXAMPLES,
    )
    actions = c.add_subparsers(dest="action", metavar="ACTION", required=True)
    for action, what in (("add-drone", "a drone (its id)"), ("add-ground", "a ground service")):
        a = actions.add_parser(
            action,
            help=f"make the broker user of {what}; prints its password",
            epilog=CREDENTIALS_EXAMPLES,
        )
        a.add_argument("name", help="the user: the drone's id, or the ground service's name")
        a.add_argument(
            "--state",
            type=state_spec,
            required=True,
            help="the ground state: SQLite file or postgresql:// URL",
        )
        a.add_argument("--password-file", type=Path, help="write the password here (0600)")
        a.set_defaults(func=run_credentials, role="drone" if action == "add-drone" else "ground")
    r = actions.add_parser("revoke", help="remove a broker user", epilog=CREDENTIALS_EXAMPLES)
    r.add_argument("name", help="the user to remove")
    r.add_argument(
        "--state",
        type=state_spec,
        required=True,
        help="the ground state: SQLite file or postgresql:// URL",
    )
    r.set_defaults(func=run_credentials, role=None)

    b = sub.add_parser(
        "broker-config",
        help="write the broker's users and rights: Mosquitto password and ACL files, or a "
        "RabbitMQ definitions file",
        epilog=BROKER_CONFIG_EXAMPLES,
    )
    b.add_argument(
        "--broker",
        choices=["mosquitto", "rabbitmq"],
        default="mosquitto",
        help="which broker the files are for",
    )
    b.add_argument(
        "--vhost", default="dronefleet", help="RabbitMQ: the fleet's vhost (clients: VHOST:USER)"
    )
    b.add_argument(
        "--state",
        type=state_spec,
        required=True,
        help="the ground state: SQLite file or postgresql:// URL",
    )
    b.add_argument(
        "--out", type=Path, required=True, help="folder for passwd, acl, dronefleet.conf"
    )
    b.add_argument(
        "--listener",
        type=_host_port,
        default="0.0.0.0:1883",
        metavar="HOST:PORT",
        help="Mosquitto: where the broker listens",
    )
    add_owner_argument(b)
    b.set_defaults(func=run_broker_config)


def run_credentials(args: argparse.Namespace) -> int:
    return asyncio.run(_credentials(args))


async def _credentials(args: argparse.Namespace) -> int:
    from dronefleet.ground.broker_credentials import BrokerCredentials
    from dronefleet.ground.state_pg import state_store
    from dronefleet.messaging.broker_users import BrokerRole

    state = await state_store(args.state).open()
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
        secret_file(args.password_file, password + "\n")
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
    try:
        owner = broker_owner(args.owner)
        check_reachable(out, owner)
        make_folder(out)
    except (OSError, ValueError) as exc:
        print(f"dronefleet broker-config: {exc}", file=sys.stderr)
        return 2
    passwords, acl = mosquitto_files(users)
    for name, text in (("passwd", passwords), ("acl", acl)):
        secret_file(out / name, text, owner)
    host, port = args.listener
    conf = out / "dronefleet.conf"
    conf.write_text(
        "# Written by dronefleet broker-config: every client has a user (no anonymous access).\n"
        f"listener {port} {host}\nallow_anonymous false\n"
        f"password_file {out / 'passwd'}\nacl_file {out / 'acl'}\n"
    )
    conf.chmod(0o644)  # no secret in it; Mosquitto reads it again as its own user on a reload
    whose = f", owned by {owner.pw_name}" if owner is not None else ""
    print(
        f"wrote {out}/passwd and {out}/acl (0600{whose}) and {out}/dronefleet.conf "
        f"({len(users.all())} users)"
    )
    return 0


def _rabbitmq(users: BrokerUsers, vhost: str, out: Path) -> int:
    import json

    from dronefleet.errors import InvalidInput
    from dronefleet.messaging.rabbit_acl import rabbit_login, rabbitmq_definitions
    from dronefleet.messaging.url import BrokerUrl

    try:
        definitions = rabbitmq_definitions(users, vhost)
    except InvalidInput as exc:
        print(f"dronefleet broker-config: {exc}", file=sys.stderr)
        return 2
    path = out / "rabbitmq-definitions.json"
    secret_file(path, json.dumps(definitions, indent=2) + "\n")
    print(f"wrote {path} ({len(users.all())} users in vhost {vhost!r}); load it with:")
    # On stdin: the RabbitMQ node, not rabbitmqctl, opens a named file, and cannot read a 0600 one.
    print(f"  rabbitmqctl import_definitions < {path}")
    print("MQTT clients log in as VHOST:USER, ':' written %3A in a broker URL:")
    for user in users.all():
        url = BrokerUrl("HOST", 1883, username=rabbit_login(vhost, user.name)).full()
        print(f"  {user.name}: --broker {url} --broker-password-file {user.name}.secret")
    return 0


async def _users(path: str | Path) -> BrokerUsers:
    from dronefleet.ground.broker_credentials import BrokerCredentials
    from dronefleet.ground.state_pg import state_store

    state = await state_store(path).open()
    try:
        return await (await BrokerCredentials(state).open()).users()
    finally:
        await state.close()
