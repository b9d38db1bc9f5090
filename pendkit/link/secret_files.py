"""Files that hold secrets (keys, password hashes, plain credentials): written readable by their owner only,
and passwords hashed in Mosquitto's own format whether or not `mosquitto_passwd` is installed.

Mosquitto started as root reads its password file and TLS key after dropping to its own user: there the
kit gives those files to the `mosquitto` group, readable by it (0640) and no one else.
"""

from __future__ import annotations

import base64
import hashlib
import os
import secrets
from pathlib import Path

PBKDF2_ITERATIONS = 101  # Mosquitto 2's `$7$` (sha512-pbkdf2) default
SALT_BYTES = 12
BROKER_GROUP = "mosquitto"


def mosquitto_hash(password: str, salt: bytes | None = None) -> str:
    """`$7$101$<salt>$<hash>`, as `mosquitto_passwd` writes it (PBKDF2-HMAC-SHA512, 64 bytes)."""
    salt = secrets.token_bytes(SALT_BYTES) if salt is None else salt
    digest = hashlib.pbkdf2_hmac("sha512", password.encode(), salt, PBKDF2_ITERATIONS, 64)
    return f"$7${PBKDF2_ITERATIONS}${base64.b64encode(salt).decode()}${base64.b64encode(digest).decode()}"


def mosquitto_password_check(password: str, hashed: str) -> bool:
    """Whether `password` matches a `$7$` line's hash (for tests and `pendkit broker-config`'s own checks)."""
    parts = hashed.split("$")
    if len(parts) != 5 or parts[1] != "7":
        return False
    digest = hashlib.pbkdf2_hmac("sha512", password.encode(), base64.b64decode(parts[3]), int(parts[2]), 64)
    return secrets.compare_digest(base64.b64encode(digest).decode(), parts[4])


def keep_private(path: str | Path, broker_reads: bool = False) -> None:
    """0600; with `broker_reads`, where this runs as root and Mosquitto's group exists, 0640 to that group."""
    path = Path(path)
    os.chmod(path, 0o600)
    if not broker_reads or not hasattr(os, "geteuid") or os.geteuid() != 0:
        return
    try:
        import grp

        gid = grp.getgrnam(BROKER_GROUP).gr_gid
    except (ImportError, KeyError):
        return  # no mosquitto user to drop to: it stays root and reads 0600
    os.chown(path, 0, gid)
    os.chmod(path, 0o640)


def write_private(path: str | Path, text: str, broker_reads: bool = False) -> None:
    """Create or replace `path` with `text`, never readable by others for a moment (0600 from its creation)."""
    path = Path(path)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.unlink(missing_ok=True)
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    with os.fdopen(handle, "w", newline="") as file:
        file.write(text)
    keep_private(temporary, broker_reads)
    os.replace(temporary, path)


def folder_closed_to_broker(folder: str | Path) -> Path | None:
    """The first folder on the way to `folder` that Mosquitto's own user cannot enter, where it will run as that
    user (this runs as root and the user exists); None when it can enter them all, or runs as whoever we are."""
    if not hasattr(os, "geteuid") or os.geteuid() != 0:
        return None
    try:
        import grp

        gid = grp.getgrnam(BROKER_GROUP).gr_gid
    except (ImportError, KeyError):
        return None
    for step in reversed([Path(folder).resolve(), *Path(folder).resolve().parents]):
        mode, owner_gid = step.stat().st_mode, step.stat().st_gid
        if not (mode & 0o001 or (owner_gid == gid and mode & 0o010)):
            return step
    return None
