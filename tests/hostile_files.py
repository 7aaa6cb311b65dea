"""Hostile input files for the tests (the bad-input tests and tests/contracts/test_hostile_properties.py):
image headers that promise more pixels than any budget allows, meshes whose faces name
vertices that do not exist. Each is built from its format's specification in a few hundred
bytes, so no test allocates what the file promises."""
from __future__ import annotations

import base64
import json
import struct
import zlib
from pathlib import Path


def png_header(width: int, height: int, rows: int = 4, padding: int = 0) -> bytes:
    """An 8-bit RGB PNG that declares width × height and carries `rows` rows of zeros (a
    decoder reaches the end of the data long before the declared size), and `padding` bytes
    in a private ancillary chunk: a file as large as a real, well-compressed image of that
    size (OpenImageIO refuses a header that promises over ~1000× the file's size)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    scanlines = b"".join(b"\x00" + bytes(3 * width) for _ in range(min(rows, height)))
    pad = chunk(b"clSh", bytes(padding)) if padding else b""
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + pad + chunk(b"IDAT", zlib.compress(scanlines))
            + chunk(b"IEND", b""))


def exr_header(width: int, height: int) -> bytes:
    """A scanline OpenEXR file (HALF R, G, B; no compression) that declares width × height
    and holds no pixel data: the header and a zero line-offset table."""
    def attribute(name: str, kind: str, value: bytes) -> bytes:
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 1, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join([
        attribute("channels", "chlist", channels),
        attribute("compression", "compression", b"\0"),
        attribute("dataWindow", "box2i", window),
        attribute("displayWindow", "box2i", window),
        attribute("lineOrder", "lineOrder", b"\0"),
        attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
    ]) + b"\0"
    return b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + header + bytes(8 * height)


def ply_triangle(indices: tuple[int, int, int]) -> str:
    """An ASCII PLY of three vertices and one face with these vertex indices."""
    return ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
            "-1 -1 0\n1 -1 0\n0 1 0\n" + "3 {} {} {}\n".format(*indices))


def obj_triangle(indices: tuple[int, int, int]) -> str:
    """An OBJ of three vertices and one face with these (1-based) indices."""
    return "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf {} {} {}\n".format(*indices)


def gltf_triangle(indices: tuple[int, int, int]) -> str:
    """A glTF 2.0 file (embedded buffer) of three vertices and one triangle whose index
    accessor holds these (unsigned 16-bit) indices."""
    positions = struct.pack("<9f", -1, -1, 0, 1, -1, 0, 0, 1, 0)
    index_bytes = struct.pack("<3H", *indices) + b"\0\0"
    data = positions + index_bytes
    doc = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "buffers": [{"byteLength": len(data),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [-1, -1, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    }
    return json.dumps(doc)


def write(path: Path, content: str | bytes) -> Path:
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    return path
