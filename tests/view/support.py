"""Starting ``tensegrity view`` as a user does, and reading where it listens; a raw
websocket client of it; a robot bag written by another tool."""

from __future__ import annotations

import base64
import os
import re
import socket
from pathlib import Path

BAGS = Path(__file__).resolve().parents[2] / "bags"

VIEW_READY = re.compile(r"view ready: (http://[^\s:]+:(\d+))")

#: Patience for one answer of the view on a loaded machine [s] (an event ends every wait before it).
PATIENCE = 60.0


def subprotocol() -> str:
    """The websocket subprotocol the page asks for (viser refuses another version's)."""
    import viser

    return f"viser-v{viser.__version__}"


def handshake(port: int) -> socket.socket:
    """A raw socket to the view on ``port``, past the websocket handshake (the page's
    subprotocol); it reads nothing more unless its caller does."""
    s = socket.create_connection(("127.0.0.1", port), timeout=PATIENCE)
    key = base64.b64encode(os.urandom(16))
    s.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
              b"Sec-WebSocket-Key: %s\r\nSec-WebSocket-Version: 13\r\n"
              b"Sec-WebSocket-Protocol: %s\r\n\r\n" % (port, key, subprotocol().encode()))
    head = b""
    while b"\r\n\r\n" not in head:
        head += s.recv(1)
    assert head.startswith(b"HTTP/1.1 101"), head
    return s


def start_view(cli, *args: str, timeout: float = 120.0) -> tuple[object, str, int]:
    """``tensegrity view ARGS --port 0``: the process, its URL and port once it is ready."""
    proc = cli("view", *args, "--port", "0", log_name="view")
    proc.wait_for("view ready: ", timeout=timeout)
    m = VIEW_READY.search(proc.stderr())
    assert m, proc.stderr()
    return proc, m.group(1), int(m.group(2))


#: A malformed ``tensegrity_custom_data`` record: a scene name over the 4096 characters a bag's text may hold.
MALFORMED = {"tensegrity_custom_data": {"scene": "s" * 5000}}


def foreign_roll(folder: Path, records: dict, topics: tuple[str, ...], seconds: float = 1.0) -> None:
    """A bag folder (no ``metadata.yaml``) of one MCAP file written by ``mcap``'s own writer:
    ``records`` as metadata records after the header (where a recorder writes its
    custom_data), then the messages of ``topics`` of the 6-bar's roll from its start to
    ``seconds`` after every one of them has begun (the shipped recording's topics begin at
    different times: its markers 0.8 s after its states)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    folder.mkdir()
    with open(BAGS / "six_bar_roll" / "six_bar_roll_0.mcap", "rb") as f, open(folder / f"{folder.name}_0.mcap", "wb") as out:
        reader = make_reader(f)
        names = [f"/six_bar/{t}" for t in topics]
        first: dict[str, int] = {}
        for _schema, channel, m in reader.iter_messages(topics=names, log_time_order=True):
            first.setdefault(channel.topic, m.log_time)
            if len(first) == len(names):
                break
        end = max(first.values()) + seconds * 1e9
        writer = Writer(out)
        writer.start(profile="ros2", library="another tool")
        for name, data in records.items():
            writer.add_metadata(name, data)
        schemas, channels = {}, {}
        for schema, channel, m in reader.iter_messages(topics=names, log_time_order=True):
            if m.log_time > end:
                break
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(channel.topic, channel.message_encoding,
                                                               schemas[schema.id])
            writer.add_message(channels[channel.id], m.log_time, m.data, m.publish_time, sequence=m.sequence)
        writer.finish()


class Page:
    """A websocket client speaking viser's protocol as the page does: it reports its camera
    first (viser runs a client's control callbacks only from then on), reads the controls
    the server sends (label -> uuid) and sends control updates."""

    def __init__(self, port: int):
        import msgspec
        from websockets.sync.client import connect

        self.ws = connect(f"ws://127.0.0.1:{port}/", subprotocols=[subprotocol()], open_timeout=PATIENCE)
        self.controls: dict[str, str] = {}
        self.ws.send(msgspec.msgpack.encode({
            "type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, 0.0, 3.0], "fov": 1.0,
            "near": 0.01, "far": 100.0, "image_height": 500, "image_width": 800, "look_at": [0.0, 0.0, 0.0],
            "up_direction": [0.0, 0.0, 1.0]}))

    def control(self, label: str) -> str:
        """The uuid of the control labelled ``label`` (read from the server's messages)."""
        import msgspec
        import zstandard

        while label not in self.controls:
            frame = self.ws.recv(timeout=PATIENCE)
            size, packed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
            inner = zstandard.ZstdDecompressor().decompress(frame[16:16 + packed], max_output_size=size)
            for message in msgspec.msgpack.decode(inner)["messages"]:
                if message["type"].startswith("Gui") and "label" in message.get("props", {}):
                    self.controls[message["props"]["label"]] = message["uuid"]
        return self.controls[label]

    def update(self, label: str, updates: dict) -> None:
        """Send the update of the control ``label`` as the page's ``GuiUpdateMessage``."""
        import msgspec

        self.ws.send(msgspec.msgpack.encode({"type": "GuiUpdateMessage", "uuid": self.control(label),
                                             "updates": updates}))

    def close(self) -> None:
        self.ws.close()
