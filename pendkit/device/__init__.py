"""The device: what the rig's microcontroller does, in one place, for the twin, the virtual rig and the host.

- `protocol`: observations, device to host (v1 `S...`, v2 `R...`), decoded against physical limits;
- `commands`: commands, host to device, parsed strictly and encoded (v1 letters, v2 framing);
- `logic`: servo command, velocity estimation, settings and safety stops (`McuLogic.apply`);
- `scheduler`: the loop around the logic: acting and streaming periods, streaming on/off, the v2 echo
  and sequence numbers, the status;
- `twin`: that device on the MuJoCo physics (the realistic twin and the virtual rig).

What runs it from the laptop (export, uploads to a twin or a rig, the device's designs) is `pendkit.deploy`.

The firmware's C++ core (firmware/lib/pendcore) follows the same rules; tests/vectors holds both to them.
"""
