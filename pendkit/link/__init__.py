"""The host's side of the rig link: MQTT driver, rig backend, virtual rigs, brokers."""

DEFAULT_BROKER = "mqtt://127.0.0.1:1883"
