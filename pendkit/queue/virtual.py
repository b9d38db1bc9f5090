"""The twin as rigs in the queue: an embedded broker and virtual rigs (`pendkit.link.virtual_rig`) in this
process, at a speed, so that a class without hardware (and the tests) use the queue exactly as with rigs."""

from __future__ import annotations

from pendkit.link.broker import EmbeddedBroker, free_port
from pendkit.link.driver import RigLink
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup
from pendkit.rig import RigParams


class VirtualRigs:
    """`rig_ids` as virtual rigs of `params` on an embedded broker at `speed`; `links()` gives the host side's
    `RigLink`s. A context manager; `kill(rig)` cuts one rig off as a power cut would (its readings stop)."""

    def __init__(self, rig_ids: list[str], speed: float = 1.0, params: RigParams | None = None,
                 port: int | None = None) -> None:
        self.rig_ids, self.speed, self.params = list(rig_ids), speed, params
        self.broker = EmbeddedBroker(port=port or free_port())
        self.group: VirtualRigGroup | None = None

    @property
    def url(self) -> str:
        return self.broker.url

    def start(self) -> VirtualRigs:
        self.broker.start()
        try:
            rigs = [VirtualRig(rig, self.url, params=self.params, seed=k) for k, rig in enumerate(self.rig_ids)]
            self.group = VirtualRigGroup(rigs, self.speed).start()
        except BaseException:
            self.broker.stop()
            raise
        return self

    def links(self) -> list:
        return [RigLink(rig, self.url) for rig in self.rig_ids]

    def kill(self, rig: str) -> None:
        """Rig `rig` stops stepping and leaves the broker without a word: silent from now on."""
        found = next(r for r in self.group.rigs if r.rig == rig)
        self.group.rigs = [r for r in self.group.rigs if r is not found]  # rebound whole: the group's loop reads it
        found.client.loop_stop()
        found.client.disconnect()

    def stop(self) -> None:
        if self.group is not None:
            self.group.stop()
        self.broker.stop()

    def __enter__(self) -> VirtualRigs:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
