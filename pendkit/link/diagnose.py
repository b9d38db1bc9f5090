"""Why a connection to a broker or a rig did not happen, in one line with the fix.

MQTT says little when it fails: a refused login is a CONNACK code, a TLS problem or a wrong port is a
dropped socket, and an ACL that forbids a topic drops the messages without a word. The driver asks here
when it gives up; these functions probe the broker's address themselves (a TCP connect, a TLS handshake)
to tell the causes apart, and where nothing can tell, say what is likely and how to check.
"""

from __future__ import annotations

import json
import socket
import ssl

PROBE_TIMEOUT_S = 3.0
REFUSED_LOGIN = ("not authori", "bad user name or password", "bad username or password")


def rig_user_mismatch(rig: str, username: str | None) -> str | None:
    """A host user of the classroom config (`host-r02`) reaches only its own rig: say so before connecting."""
    if username and username.startswith("host-") and username[5:] != rig:
        return (f"user {username} may only reach rig {username[5:]}, not {rig}: use rig {username[5:]}, or the "
                f"host-{rig} user's password from the instructor's credentials.csv")
    return None


def why_no_connection(host: str, port: int, tls: bool, tls_ca: str | None, username: str | None,
                      refused: str | None, has_password: bool = True, tls_asked: bool = False) -> str:
    """The likely cause of a failed connection to `host:port`, with its fix. `tls_asked`: TLS because a CA was
    given with a plain mqtt:// address."""
    where = f"{host}:{port}"
    if refused is not None:
        if any(words in refused.lower() for words in REFUSED_LOGIN):
            if username and not has_password:
                return (f"the broker at {where} refused user {username!r} ({refused}): no password was given; set "
                        "PENDKIT_MQTT_PASSWORD or pass --password-file (a team's is its host-rNN.txt)")
            who = f"user {username!r}" if username else "a login without a username"
            return (f"the broker at {where} refused {who} ({refused}): the username or password is wrong, or no such "
                    "user is set up; check the password given (PENDKIT_MQTT_PASSWORD, or --password-file: a team's is "
                    "its host-rNN.txt, the instructor has every user's in broker/logins/ and credentials.csv)")
        return f"the broker at {where} refused the connection ({refused})"
    try:
        with socket.create_connection((host, port), timeout=PROBE_TIMEOUT_S) as raw:
            return _tls_problem(raw, host, where, tls_ca, tls_asked) if tls else _plain_problem(raw, host, where)
    except ConnectionRefusedError:
        return (f"nothing listens at {where}: start the broker there (`pendkit broker`, or the classroom's "
                "`mosquitto -c broker/mosquitto.conf`), or check the address and port")
    except socket.gaierror:
        return f"the name {host!r} is unknown here: check the broker's address (or use its IP)"
    except OSError as error:
        return (f"no answer from {where} ({error.strerror or error}): check the address, that this computer is on "
                "the room's network, and that the broker's firewall lets the port in")


def _tls_problem(raw: socket.socket, host: str, where: str, tls_ca: str | None, tls_asked: bool = False) -> str:
    context = ssl.create_default_context(cafile=tls_ca)
    try:
        with context.wrap_socket(raw, server_hostname=host):
            return (f"TLS to {where} works from here, yet MQTT did not connect: the broker may have dropped the login "
                    "(check its log) or be overloaded")
    except ssl.SSLCertVerificationError as error:
        message = str(error.verify_message or error)
        if "mismatch" in message.lower():
            return (f"the broker's certificate does not name {host}: on the broker's machine run `pendkit "
                    f"broker-config --tls --address {host}` (with the same --rigs) and restart Mosquitto, or connect "
                    "by a name the certificate lists")
        fix = ("pass --tls-ca with the classroom's CA (the ca.crt the instructor gave you; broker/ca.crt on the "
               "broker's machine)" if tls_ca is None else
               f"{tls_ca} is not the CA that signed this broker's certificate: use the broker's own ca.crt")
        return f"the broker at {where} is not trusted ({message}): {fix}"
    except (ssl.SSLError, ConnectionResetError, OSError) as error:
        why = getattr(error, "reason", None) or error
        if tls_asked:
            return (f"{where} does not speak TLS ({why}), and --tls-ca turns TLS on: drop --tls-ca for this plain "
                    "port, or use the broker's TLS port (mqtts://HOST:8883)")
        return (f"{where} does not speak TLS ({why}): use mqtt://{where} for a plain port, or the broker's TLS port "
                "(mqtts://HOST:8883)")


def _plain_problem(raw: socket.socket, host: str, where: str) -> str:
    context = ssl.create_default_context()
    context.check_hostname, context.verify_mode = False, ssl.CERT_NONE
    try:
        with context.wrap_socket(raw, server_hostname=host):
            return (f"{where} speaks TLS: connect with mqtts://{where} and --tls-ca broker/ca.crt (or use the "
                    "broker's plain port, 1883)")
    except (ssl.SSLError, OSError):
        return (f"the broker at {where} accepted the connection but MQTT did not start: is it an MQTT broker's "
                "port? (Mosquitto's log says why it dropped a client)")


def why_rig_silent(rig: str, username: str | None, connected: bool, address: str, status: str | None = None,
                   rigs_seen: list[str] | None = None) -> str:
    """A rig that does not answer on a working broker: what MQTT cannot tell apart, and how to check.
    `status`: the rig's retained status as the broker holds it (None: it has none); `rigs_seen`: the rigs whose
    status this user can read on the broker (`RigLink.rigs_reporting`), None when not asked."""
    mismatch = rig_user_mismatch(rig, username)
    if mismatch is not None:
        return mismatch
    if not connected:
        return f"rig {rig} did not answer, and the link to {address} is down (reconnecting): check the broker"
    if _says_offline(status):
        return (f"rig {rig} is offline: the broker at {address} holds its last will (it lost power or WiFi, or was "
                "stopped); power it on and watch its serial console for `mqtt connected`")
    if status is None and rigs_seen:
        return (f"no rig {rig!r} has ever reported to {address} (rigs that have: {', '.join(sorted(rigs_seen)[:12])}): "
                "check the id on the rig's label, or in its serial console's `status`")
    return (f"rig {rig} did not answer on {address}: it is off or not on this broker, or its id is not {rig!r} "
            "(the id is on the rig's label and in its serial console's `status`), or the broker's ACL does not let "
            f"your user reach {rig} (an ACL drops messages silently; the instructor's `mosquitto_sub -t "
            f"'pendulum-r/status/{rig}'` shows whether the rig is there)")


def _says_offline(status: str | None) -> bool:
    try:
        parsed = json.loads(status) if status else None
    except ValueError:
        return False
    return isinstance(parsed, dict) and parsed.get("online") is False
