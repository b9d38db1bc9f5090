"""A classroom on one Mosquitto: N virtual rigs (one process) streaming at 40 Hz to N hosts.

Loss is the fraction of observations missing from the v2 sequence numbers; age is one way, from the
rig's reading to the host's receipt (both on this machine's monotonic clock: the rigs publish their clock
origin in their status). Goal: 0 loss.

    python benchmarks/bench_classroom.py [--rigs 30] [--seconds 20]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time

import numpy as np

from pendkit.link.broker import MosquittoBroker
from pendkit.link.driver import RigLink


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rigs", type=int, default=30)
    parser.add_argument("--seconds", type=float, default=20.0)
    args = parser.parse_args()
    names = [f"r{k:02d}" for k in range(1, args.rigs + 1)]
    with tempfile.TemporaryDirectory() as work, MosquittoBroker(work) as broker:
        command = [sys.executable, "-m", "pendkit.cli", "virtual-rig", "--broker", broker.url]
        for name in names:
            command += ["--rig", name]
        rigs = subprocess.Popen(command, stdout=subprocess.DEVNULL)
        links = []
        try:
            ages: list[float] = []
            for name in names:
                link = RigLink(name, broker.url)
                link.client.on_message = _measuring(link, ages)
                link.connect()
                links.append(link)
            deadline = time.monotonic() + 15
            while any(link.status is None for link in links) and time.monotonic() < deadline:
                time.sleep(0.1)
            for link in links:  # switch every rig to v2 (sequence numbers)
                link.publish("#1:h")
            time.sleep(1.0)
            for link in links:
                link.counters.received, link.counters.dropped = 0, 0
            ages.clear()
            time.sleep(args.seconds)
            received = sum(link.counters.received for link in links)
            dropped = sum(link.counters.dropped for link in links)
        finally:
            for link in links:
                link.close()
            rigs.terminate()
            rigs.wait(timeout=10)
    ages_ms = np.array(ages) * 1000
    rate = received / args.seconds / max(1, args.rigs)
    print(f"observations_received={received} per_rig_hz={rate:.1f} obs_age_p50_ms={np.percentile(ages_ms, 50):.2f}")
    loss = dropped / max(1, received + dropped)
    print(f"rigs={args.rigs} loss={loss:.5f} obs_age_p99_ms={np.percentile(ages_ms, 99):.2f}")


def _measuring(link: RigLink, ages: list[float]):
    """The link's own decoding plus a one-way age from the rig's published clock origin."""
    original = link._on_message

    def on_message(client, userdata, message):
        original(client, userdata, message)
        if message.topic == link.obs_topic and link.status and link.newest is not None:
            status = json.loads(link.status)
            if "clock_origin_s" in status:
                sent = status["clock_origin_s"] + link.newest.received.observation.millis / 1000 / status["speed"]
                ages.append(link.newest.receive_time_s - sent)

    return on_message


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
