"""Test hosts on one machine: Linux network namespaces joined by veth pairs on a bridge. Each
host has its loopback and one address on the bridge's subnet, nothing else; the test itself
talks to them from the bridge's own address. File systems are shared (as a farm's shared
storage would be). Needs root and iproute2 (`ip`)."""

from __future__ import annotations

import os
import signal
import subprocess
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any


def ip(*args: str) -> str:
    done = subprocess.run(["ip", *args], check=True, capture_output=True, text=True)
    return done.stdout


@dataclass
class Host:
    name: str
    namespace: str
    address: str
    veth: str  # the root namespace's end, on the bridge
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)

    def start(self, cmd: list[str], env: dict[str, str], log: Path) -> subprocess.Popen[bytes]:
        log.parent.mkdir(parents=True, exist_ok=True)
        out: IO[bytes] = open(log, "ab")  # noqa: SIM115 - the child owns it
        proc = subprocess.Popen(["ip", "netns", "exec", self.namespace, *cmd], env=env, stdout=out,
                                stderr=subprocess.STDOUT)
        self.processes.append(proc)
        return proc

    def pids(self) -> list[int]:
        return [int(p) for p in ip("netns", "pids", self.namespace).split()]

    def power_off(self) -> None:
        """As a host that dies: its processes are killed outright and its link goes down."""
        for pid in self.pids():
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        for proc in self.processes:
            proc.wait(timeout=30)
        ip("link", "set", self.veth, "down")


class Network:
    """A bridge with hosts, torn down (processes killed, namespaces and links deleted) on exit."""

    def __init__(self, names: list[str]) -> None:
        tag = uuid.uuid4().hex[:6]
        self.subnet = f"10.{200 + int(tag[:2], 16) % 50}.{int(tag[2:4], 16)}"
        self.bridge = f"wbr{tag}"
        self.gateway = f"{self.subnet}.1"
        self.hosts = {name: Host(name, f"weft-{name}-{tag}", f"{self.subnet}.{2 + i}", f"wv{i}{tag}")
                      for i, name in enumerate(names)}

    def __enter__(self) -> Network:
        try:
            ip("link", "add", self.bridge, "type", "bridge")
            ip("addr", "add", f"{self.gateway}/24", "dev", self.bridge)
            ip("link", "set", self.bridge, "up")
            for host in self.hosts.values():
                peer = f"{host.veth}p"
                ip("netns", "add", host.namespace)
                ip("link", "add", host.veth, "type", "veth", "peer", "name", peer)
                ip("link", "set", peer, "netns", host.namespace)
                ip("link", "set", host.veth, "master", self.bridge)
                ip("link", "set", host.veth, "up")
                inside = ["netns", "exec", host.namespace, "ip"]
                ip(*inside, "link", "set", "lo", "up")
                ip(*inside, "addr", "add", f"{host.address}/24", "dev", peer)
                ip(*inside, "link", "set", peer, "up")
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *_: Any) -> None:
        for host in self.hosts.values():
            try:
                for pid in host.pids():
                    os.kill(pid, signal.SIGKILL)
            except (subprocess.CalledProcessError, ProcessLookupError):
                pass
            for proc in host.processes:
                try:
                    proc.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    pass
            subprocess.run(["ip", "netns", "del", host.namespace], capture_output=True)
            subprocess.run(["ip", "link", "del", host.veth], capture_output=True)
        subprocess.run(["ip", "link", "del", self.bridge], capture_output=True)
