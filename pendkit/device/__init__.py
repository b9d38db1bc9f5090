"""The device: what the rig's microcontroller does, in one place, for the twin, the virtual rig and the firmware.

- `protocol`: the observation lines the device writes (v1 `S...`, v2 `R...`);
- `commands`: commands, host to device, parsed strictly and encoded (v1 letters, v2 framing);
- `logic`: servo command, velocity estimation, settings and safety stops (`McuLogic.apply`);
- `scheduler`: the loop around the logic: acting and streaming periods, streaming on/off, the v2 echo
  and sequence numbers, the status;
- the controllers it runs itself: blobs, their runtimes and the upload (`onboard`).

The device on the MuJoCo physics is `pendkit.sim.twin_device`; the host's parsing and logging of what it
sends is `pendkit.telemetry`; what runs it from the laptop (export, uploads, the device's designs) is
`pendkit.deploy`.

The firmware's C++ core (firmware/lib/pendcore) follows the same rules; tests/vectors holds both to them.
"""
