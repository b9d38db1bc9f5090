"""A classroom's own certificate authority for the broker's TLS listener (`pendkit broker-config --tls`).

The kit makes a CA and a server certificate with the `openssl` command (Debian, macOS and Git for Windows
have it). Hosts pass `--tls-ca broker/ca.crt` (or `rig_options={"tls_ca": ...}`) and connect to
`mqtts://<broker>:8883`; rigs get the CA in their settings (docs/instructor-guide.md). The CA's key stays
with the instructor: whoever holds it can impersonate the broker.
"""

from __future__ import annotations

import ipaddress
import os
import shutil
import socket
import subprocess
from pathlib import Path

from pendkit.errors import ConfigError

CERT_DAYS = 400  # a school year and some


def broker_names() -> list[str]:
    """What the server certificate vouches for: this machine's name and addresses, and loopback."""
    names = {"localhost", socket.gethostname(), "127.0.0.1"}
    try:
        names |= {info[4][0] for info in socket.getaddrinfo(socket.gethostname(), None)}
    except OSError:
        pass
    return sorted(names)


def make_classroom_ca(out: str | Path, names: list[str] | None = None) -> dict[str, Path]:
    """ca.crt, ca.key (keep it private), server.crt and server.key in `out`; made once, then kept."""
    openssl = shutil.which("openssl")
    if openssl is None:
        raise ConfigError("--tls needs the openssl command (apt-get install openssl; macOS has it)")
    out = Path(out)
    paths = {"ca": out / "ca.crt", "ca_key": out / "ca.key", "cert": out / "server.crt", "key": out / "server.key"}
    if all(path.exists() for path in paths.values()):
        return paths  # adding a rig keeps the CA every rig and host already trusts

    def run(*args: str) -> None:
        result = subprocess.run([openssl, *args], cwd=out, capture_output=True, text=True)
        if result.returncode != 0:
            raise ConfigError(f"openssl {args[0]} failed: {result.stderr.strip().splitlines()[-1:]}")

    subject_names = []
    for name in names or broker_names():
        try:
            subject_names.append(f"IP:{ipaddress.ip_address(name.split('%')[0])}")
        except ValueError:
            subject_names.append(f"DNS:{name}")
    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", str(CERT_DAYS), "-subj", "/CN=pendkit classroom CA",
        "-keyout", "ca.key", "-out", "ca.crt")
    run("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=pendkit classroom broker", "-keyout", "server.key",
        "-out", "server.csr")
    (out / "san.ext").write_text("subjectAltName=" + ",".join(subject_names) + "\n")
    run("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial", "-days",
        str(CERT_DAYS), "-extfile", "san.ext", "-out", "server.crt")
    os.chmod(paths["ca_key"], 0o600)
    for name in ("ca", "cert", "key"):
        os.chmod(paths[name], 0o644)  # mosquitto reads them after dropping root
    return paths
