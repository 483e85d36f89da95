"""Secret files for a Mosquitto, readable by the user it runs as (``broker-config``,
``bridge-config --local-dir``).

Mosquitto 2.0 started as root reads its configuration, then drops to its own user (``user`` in
``mosquitto.conf``; ``mosquitto`` by default, the user Debian's package makes) *before* it opens
``password_file`` and ``acl_file``, and opens them again as that user on a reload. A root-owned
0600 file is then unreadable and Mosquitto exits. So the files go to that user, still 0600 (later
Mosquitto versions warn about a password file its user does not own or others can read), and
every folder above them must let that user through.
"""

from __future__ import annotations

import argparse
import contextlib
import grp
import os
import pwd
import stat
from pathlib import Path

#: The user Mosquitto runs as once started by root, unless its configuration names another.
MOSQUITTO_USER = "mosquitto"


def add_owner_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--owner",
        help="the user Mosquitto runs as, who must read its password and ACL files (0600, given "
        f"to it); default: {MOSQUITTO_USER} when run as root and that user exists, else the "
        "files stay yours",
    )


def broker_owner(name: str | None) -> pwd.struct_passwd | None:
    """Who gets the files: ``name``, or Mosquitto's own user when root runs this and that user
    exists; None keeps them the caller's (a Mosquitto run by the same user reads them)."""
    if name is None:
        if os.geteuid() != 0:
            return None
        with contextlib.suppress(KeyError):
            return pwd.getpwnam(MOSQUITTO_USER)
        return None
    try:
        owner = pwd.getpwnam(name)
    except KeyError:
        raise ValueError(f"--owner {name}: no such user") from None
    if os.geteuid() != 0 and owner.pw_uid != os.geteuid():
        raise ValueError(f"--owner {name}: only root may give files to another user")
    return owner


def check_reachable(folder: Path, owner: pwd.struct_passwd | None) -> None:
    """Refuse a folder ``owner`` cannot get through to: Mosquitto, running as that user, could
    not open the files in it and would exit. Folders still to be made are made 0755."""
    if owner is None or owner.pw_uid == 0:
        return
    groups = {owner.pw_gid, *(g.gr_gid for g in grp.getgrall() if owner.pw_name in g.gr_mem)}
    for above in (folder, *folder.parents):
        try:
            st = above.stat()
        except FileNotFoundError:
            continue
        if st.st_uid == owner.pw_uid:
            may_enter = st.st_mode & stat.S_IXUSR
        elif st.st_gid in groups:
            may_enter = st.st_mode & stat.S_IXGRP
        else:
            may_enter = st.st_mode & stat.S_IXOTH
        if not may_enter:
            raise ValueError(
                f"Mosquitto runs as {owner.pw_name}, which cannot enter {above} (mode "
                f"{stat.S_IMODE(st.st_mode):04o}): write the files elsewhere (e.g. "
                f"/etc/mosquitto/dronefleet) or let it through (chmod o+x {above})"
            )


def make_folder(folder: Path) -> None:
    """``folder`` and its missing parents, 0755 whatever the umask (the broker's user enters)."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    folder.mkdir(parents=True, exist_ok=True)
    for made in missing:
        made.chmod(0o755)


def secret_file(path: Path, text: str, owner: pwd.struct_passwd | None = None) -> None:
    """``text`` in ``path``, mode 0600, owned by ``owner`` (and its group) when given."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as out:
        out.write(text)
    os.chmod(path, 0o600)
    if owner is not None:
        os.chown(path, owner.pw_uid, owner.pw_gid)
