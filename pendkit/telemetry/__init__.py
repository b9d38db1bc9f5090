"""The device's telemetry on the host's side: its observation lines parsed (`parse`) and episodes logged and
read back (`log`). Below the twin and the link, which both log what the device sends."""
