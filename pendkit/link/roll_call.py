"""The room's roll call: every rig whose status the broker holds, whether it is online, and what its
firmware says it drives (`pendkit rigs`). A rig's status is retained, so the broker answers for rigs that
are off too: their last will says `"online": false`."""

from __future__ import annotations

import json

from pendkit.link.driver import RigLink


def rig_line(rig: str, status: str) -> str:
    """One rig's line: online or offline, the firmware's protocol, its servo range and on-device controller."""
    try:
        fields = json.loads(status)
    except ValueError:
        fields = None
    if not isinstance(fields, dict):
        return f"{rig:<8} status unreadable ({status[:40]!r}): restart the rig; on an open broker anyone may write it"
    if fields.get("online") is False:
        return f"{rig:<8} offline (its last will: power or WiFi lost, or stopped)"
    servo = fields.get("servo_counts_range")
    servo_text = f"servo counts {servo[0]}..{servo[1]}" if isinstance(servo, list) and len(servo) == 2 else "servo ?"
    controller = "on-device controllers" if "controller" in fields else "no on-device controllers"
    return f"{rig:<8} online, protocol {str(fields.get('protocol', '?'))[:8]}, {servo_text}, {controller}"


def roll_call(broker: str, username: str | None = None, password: str | None = None, tls_ca: str | None = None,
              wait_s: float = 1.5) -> dict[str, str]:
    """{rig: its retained status} for every rig this user may read (`RigLinkError` naming the cause when the
    broker cannot be reached)."""
    link = RigLink("roll-call", broker, username, password, tls_ca, check_user=False)
    link.connect()
    try:
        return link.rigs_reporting(wait_s)
    finally:
        link.close()


def is_online(status: str) -> bool:
    try:
        fields = json.loads(status)
    except ValueError:
        return False
    return isinstance(fields, dict) and fields.get("online") is not False
