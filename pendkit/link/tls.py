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
from pendkit.link.secret_files import keep_private

CERT_DAYS = 400  # a school year and some


def broker_names(extra: list[str] | tuple[str, ...] = ()) -> list[str]:
    """What the server certificate vouches for: this machine's name and every address it has (so a laptop
    across the room can check the broker it reaches), loopback, and `extra` (a Pi's name, the room's IP)."""
    names = {"localhost", socket.gethostname(), "127.0.0.1", *extra}
    try:
        names |= {info[4][0] for info in socket.getaddrinfo(socket.gethostname(), None)}
    except OSError:
        pass
    try:
        import psutil

        for addresses in psutil.net_if_addrs().values():
            names |= {a.address for a in addresses if a.family in (socket.AF_INET, socket.AF_INET6)}
    except ImportError:
        pass
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:  # the route out: no packet is sent
            probe.connect(("192.0.2.1", 9))
            names.add(probe.getsockname()[0])
    except OSError:
        pass
    return sorted(n for n in names if n and not n.lower().startswith("fe80"))  # link-local: no use to a client


def _subject_names(names: list[str]) -> list[str]:
    """subjectAltName entries. An IPv4 address is listed twice, as IP and as DNS text: a rig's Mbed TLS 2.x
    (arduino-esp32 2.x) compares the host it was given only with DNS entries, so a rig set up with the broker's
    IP address could not check an IP-only certificate (Mbed-TLS/mbedtls#5082). OpenSSL clients (hosts, paho)
    match an IP against IP entries only, so the DNS twin changes nothing for them."""
    subject_names = []
    for name in names:
        try:
            address = ipaddress.ip_address(name.split('%')[0])
        except ValueError:
            subject_names.append(f"DNS:{name}")
            continue
        subject_names.append(f"IP:{address}")
        if address.version == 4:
            subject_names.append(f"DNS:{address}")
    return subject_names


def _san_line(names: list[str]) -> str:
    return "subjectAltName=" + ",".join(_subject_names(names)) + "\n"


def make_classroom_ca(out: str | Path, names: list[str] | None = None, extra_names: list[str] | tuple = (),
                      new_ca: bool = False) -> dict[str, Path]:
    """ca.crt, ca.key (keep it private), server.crt and server.key in `out`. The CA is made once and kept (every
    rig and host trusts it); the server certificate is issued again from it whenever it does not name every
    address wanted. Without ca.key beside ca.crt a new CA is made only with `new_ca`."""
    openssl = shutil.which("openssl")
    if openssl is None:
        raise ConfigError("--tls needs the openssl command (apt-get install openssl; macOS has it)")
    out = Path(out)
    paths = {"ca": out / "ca.crt", "ca_key": out / "ca.key", "cert": out / "server.crt", "key": out / "server.key"}
    wanted = sorted(set(names or broker_names(list(extra_names))) | set(extra_names))
    listed = out / "server-names.txt"
    named = set(listed.read_text().split()) if listed.exists() else set()
    if paths["ca"].exists() and not paths["ca_key"].exists():
        if set(wanted) <= named and paths["cert"].exists() and paths["key"].exists():
            return paths  # nothing to issue: the CA's key may stay away
        if not new_ca:
            raise ConfigError(f"{paths['ca_key']} is missing, and the server certificate must be issued again (for "
                              f"{', '.join(sorted(set(wanted) - named)) or 'its key'}): put ca.key back and run "
                              "again, or pass --new-ca to make a new CA (every rig and host then needs the new ca.crt)")
    san_file = out / "san.ext"
    current = san_file.exists() and san_file.read_text() == _san_line(sorted(named))  # else issued before the DNS twins
    if set(wanted) <= named and current and all(path.exists() for path in paths.values()):
        return paths  # adding a rig keeps the CA and the certificate every rig and host already trusts

    def run(*args: str) -> None:
        result = subprocess.run([openssl, *args], cwd=out, capture_output=True, text=True)
        if result.returncode != 0:
            raise ConfigError(f"openssl {args[0]} failed: {result.stderr.strip().splitlines()[-1:]}")

    previous = os.umask(0o077)  # keys private from the moment openssl creates them
    try:
        if new_ca or not (paths["ca"].exists() and paths["ca_key"].exists()):
            run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", str(CERT_DAYS), "-subj",
                "/CN=pendkit classroom CA", "-keyout", "ca.key", "-out", "ca.crt")
        run("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=pendkit classroom broker", "-keyout", "server.key",
            "-out", "server.csr")
        san_file.write_text(_san_line(wanted))
        run("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial", "-days",
            str(CERT_DAYS), "-extfile", "san.ext", "-out", "server.crt")
    finally:
        os.umask(previous)
    listed.write_text("\n".join(wanted) + "\n")
    keep_private(paths["ca_key"])
    keep_private(paths["key"], broker_reads=True)
    for name in ("ca", "cert"):
        os.chmod(paths[name], 0o644)  # certificates are public
    return paths
