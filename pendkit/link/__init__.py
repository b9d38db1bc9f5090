"""The rig link: the MQTT protocol, episode logs (and, with the rig-link work, the driver and virtual rig)."""
