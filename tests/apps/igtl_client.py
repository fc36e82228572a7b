#!/usr/bin/env python3
"""An OpenIGTLink client written from the protocol specification (openigtlink.org, protocol 2:
the 58-byte header, IMAGE, STATUS, TRANSFORM, STRING, POLYDATA bodies), independent of
brainshift's code and of libopenigtlink: it drives `brainshift serve` in tests/apps/test_serve.cpp.

Standard library only. Volumes are read from NIfTI-1 files (.nii or .nii.gz, sform) by a reader
of our own here, and sent as IMAGE messages with the image's centre as the position, as the
specification defines it (the mean of the first and last voxel centres).

  igtl_client.py session   --port P --pre-dura PD.nii.gz --bmode B.nii.gz --doppler D.nii.gz --out R.json
  igtl_client.py malformed --port P --doppler D.nii.gz --out R.json
  igtl_client.py latency   --port P --doppler D.nii.gz [--bmode B.nii.gz] [--repeat 5] --out R.json   (docs/BENCHMARKS.md)
  igtl_client.py queue     --port P --doppler D.nii.gz --out R.json   (the latest volume wins)
  igtl_client.py plus      --port-file F --doppler D.nii.gz --out R.json   (a PLUS server's role)

Writes what it received (types, devices, statuses, the transform, polydata counts, the report
JSON) to R.json; the C++ test asserts on it. Exit 0 when the conversation ran to its end.
"""

import argparse
import gzip
import json
import math
import os
import socket
import struct
import sys
import time

# ---------------------------------------------------------------- CRC-64 (ECMA-182, as specified)
_POLY = 0x42F0E1EBA9EA3693
_MASK = (1 << 64) - 1


def _crc_table():
    table = []
    for i in range(256):
        crc = i << 56
        for _ in range(8):
            crc = ((crc << 1) ^ _POLY) & _MASK if crc & (1 << 63) else (crc << 1) & _MASK
        table.append(crc)
    return table


_TABLE = _crc_table()


def crc64(data):
    crc = 0
    table = _TABLE
    for b in data:
        crc = table[((crc >> 56) ^ b) & 0xFF] ^ ((crc << 8) & _MASK)
    return crc


# ---------------------------------------------------------------- messages
HEADER = struct.Struct(">H12s20sQQQ")  # version, type, device, timestamp, body size, CRC


def message(mtype, device, body, version=1, crc=None, body_size=None):
    crc = crc64(body) if crc is None else crc
    size = len(body) if body_size is None else body_size
    return HEADER.pack(version, mtype.encode(), device.encode(), 0, size, crc) + body


def message_v2(mtype, device, content, metadata=None, ext_size=12, msg_id=7):
    """Header version 2 (protocol 3, what Slicer sends by default): extended header (its size,
    the metadata header's size, the metadata's size, a message id), the content, the metadata
    header (count, then per entry key size, value encoding, value size) and the metadata."""
    metadata = metadata or {}
    meta_header = struct.pack(">H", len(metadata))
    meta_body = b""
    for k, v in metadata.items():
        meta_header += struct.pack(">HHI", len(k), 3, len(v))  # 3: US-ASCII
        meta_body += k.encode() + v.encode()
    ext = struct.pack(">HHII", ext_size, len(meta_header), len(meta_body), msg_id)
    return message(mtype, device, ext + content + meta_header + meta_body, version=2)


def recv_exactly(sock, n):
    chunks = []
    while n > 0:
        c = sock.recv(min(n, 1 << 20))
        if not c:
            raise ConnectionError("the server closed the connection")
        chunks.append(c)
        n -= len(c)
    return b"".join(chunks)


def receive(sock):
    version, mtype, device, _, size, crc = HEADER.unpack(recv_exactly(sock, HEADER.size))
    body = recv_exactly(sock, size)
    if crc64(body) != crc:
        raise ValueError("CRC mismatch in a %s message" % mtype)
    return mtype.rstrip(b"\0").decode(), device.rstrip(b"\0").decode(), body, version


def parse(mtype, body):
    """The fields of the bodies this client understands."""
    if mtype == "STATUS":
        code, subcode = struct.unpack(">Hq", body[:10])
        name = body[10:30].split(b"\0")[0].decode()
        text = body[30:].split(b"\0")[0].decode()
        return {"code": code, "subcode": subcode, "name": name, "text": text}
    if mtype == "TRANSFORM":
        v = struct.unpack(">12f", body[:48])  # columns of the rotation, then the translation
        return {"matrix": [[v[0], v[3], v[6], v[9]], [v[1], v[4], v[7], v[10]],
                           [v[2], v[5], v[8], v[11]], [0.0, 0.0, 0.0, 1.0]]}
    if mtype == "STRING":
        _, length = struct.unpack(">HH", body[:4])
        return {"text": body[4:4 + length].decode("utf-8")}
    if mtype == "POLYDATA":
        h = struct.unpack(">10I", body[:40])
        npoints = h[0]
        pts = struct.unpack(">%df" % (3 * npoints), body[40:40 + 12 * npoints])
        return {"points": npoints, "lines": h[3], "polygons": h[5],
                "finite": all(math.isfinite(x) for x in pts)}
    if mtype == "IMAGE":
        v = struct.unpack(">HBBBB3H12f3H3H", body[:72])
        return {"components": v[1], "scalar_type": v[2], "coordinate": v[4],
                "size": list(v[5:8]), "matrix": list(v[8:20]),
                "data_bytes": len(body) - 72}
    return {}


# ---------------------------------------------------------------- NIfTI-1 (sform) → IMAGE
_NIFTI_TO_IGTL = {2: (3, 1), 4: (4, 2), 8: (6, 4), 16: (10, 4), 64: (11, 8), 256: (2, 1),
                  512: (5, 2), 768: (7, 4)}  # NIfTI datatype → (IGTL scalar type, bytes)


def read_nifti(path):
    raw = gzip.open(path, "rb").read() if str(path).endswith(".gz") else open(path, "rb").read()
    if struct.unpack("<i", raw[:4])[0] != 348:
        raise ValueError("%s: not a little-endian NIfTI-1 file" % path)
    dim = struct.unpack("<8h", raw[40:56])
    datatype = struct.unpack("<h", raw[70:72])[0]
    vox_offset = int(struct.unpack("<f", raw[108:112])[0])
    slope, inter = struct.unpack("<2f", raw[112:120])
    sform_code = struct.unpack("<h", raw[254:256])[0]
    srow = [struct.unpack("<4f", raw[280 + 16 * r:296 + 16 * r]) for r in range(3)]
    if sform_code <= 0 or dim[0] < 3 or (dim[0] > 3 and any(d > 1 for d in dim[4:dim[0] + 1])):
        raise ValueError("%s: needs an sform and one 3-D volume" % path)
    if slope not in (0.0, 1.0) or inter != 0.0:
        raise ValueError("%s: scaled voxels are not sent as they are" % path)
    scalar, size = _NIFTI_TO_IGTL[datatype]
    n = dim[1] * dim[2] * dim[3]
    data = raw[vox_offset:vox_offset + n * size]
    return {"size": dim[1:4], "srow": srow, "scalar": scalar, "data": data}


def image_matrix(vol):
    """The IMAGE matrix of a volume: t, s, n (direction × spacing), then the centre position."""
    s = vol["srow"]
    cols = [[s[r][c] for r in range(3)] for c in range(3)]
    centre = [s[r][3] + sum(cols[c][r] * (vol["size"][c] - 1) / 2.0 for c in range(3))
              for r in range(3)]
    return cols[0] + cols[1] + cols[2] + centre


def image_body(vol, scalar=None, size=None, matrix=None, data=None, version=1):
    """IMAGE body: the image header (big-endian), then the voxels (little-endian as read)."""
    size = list(vol["size"]) if size is None else size
    matrix = image_matrix(vol) if matrix is None else matrix
    head = struct.pack(">HBBBB3H12f3H3H", version, 1, vol["scalar"] if scalar is None else scalar,
                       2, 1, *size, *matrix, 0, 0, 0, *size)
    return head + (vol["data"] if data is None else data)


def dump(obj, path):
    """Writes JSON whole (a temporary name, then a rename): a reader never sees half of it."""
    with open(path + ".tmp", "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(path + ".tmp", path)


# ---------------------------------------------------------------- conversations
class Client:
    def __init__(self, port, sock=None):
        self.sock = sock or socket.create_connection(("127.0.0.1", port), timeout=300)
        self.log = []  # every message received: type, device, parsed fields

    def send(self, raw):
        self.sock.sendall(raw)
        return time.monotonic()

    def until_status(self, device="BrainshiftStatus"):
        """Receives until a STATUS of `device`; returns it (all messages are logged)."""
        while True:
            mtype, dev, body, _ = receive(self.sock)
            entry = {"type": mtype, "device": dev, "at": time.monotonic()}
            entry.update(parse(mtype, body))
            self.log.append(entry)
            if mtype == "STATUS" and dev == device:
                return entry


def session(a):
    c = Client(a.port)
    out = {}
    pre = read_nifti(a.pre_dura)
    c.send(message("IMAGE", "PreDuraDoppler", image_body(pre)))
    out["pose_status"] = c.until_status()
    out["pose_messages"] = c.log
    c.log = []
    c.send(message("IMAGE", "BMode", image_body(read_nifti(a.bmode))))
    sent = c.send(message("IMAGE", "Doppler", image_body(read_nifti(a.doppler))))
    out["status"] = c.until_status()
    out["messages"] = c.log
    if a.mri:  # what the warped MRI's IMAGE should say: the MRI's own grid
        mri = read_nifti(a.mri)
        out["expected_warped_mri"] = {"size": list(mri["size"]), "matrix": image_matrix(mri)}
    for m in c.log:
        if m["type"] == "TRANSFORM" and "latency_to_transform_s" not in out:
            out["latency_to_transform_s"] = m["at"] - sent
        if m["type"] == "STRING" and m["device"] == "BrainshiftReport":
            out["report"] = json.loads(m["text"])
    dump(out, a.out)


def malformed(a):
    vol = read_nifti(a.doppler)
    # The bad messages carry a small volume on the Doppler's grid (refused before any work).
    small = {"size": (8, 8, 8), "srow": vol["srow"], "scalar": 10, "data": bytes(8 * 8 * 8 * 4)}
    out = {"answers": {}}
    c = Client(a.port)

    def answer(name, raw):
        c.send(raw)
        out["answers"][name] = c.until_status()

    answer("unknown_type", message("FROBNICATE", "Doppler", b"hello"))
    answer("bad_crc", message("IMAGE", "Doppler", image_body(small), crc=12345))
    answer("short_data", message("IMAGE", "Doppler", image_body(small, data=small["data"][:-100])))
    answer("scalar_type_13", message("IMAGE", "Doppler", image_body(small, scalar=13)))
    s = vol["srow"]
    matrix = [s[0][0], s[1][0], s[2][0], s[0][0], s[1][0] + s[0][0], s[2][0],
              s[0][2], s[1][2], s[2][2], s[0][3], s[1][3], s[2][3]]  # j not orthogonal to i
    answer("sheared_matrix", message("IMAGE", "Doppler", image_body(small, matrix=matrix)))
    answer("zero_size", message("IMAGE", "Doppler", image_body(small, size=[0, 4, 4], data=b"")))
    answer("header_version_3", message("IMAGE", "Doppler", image_body(small), version=3))
    answer("v2_bad_extended_header",
           message_v2("IMAGE", "Doppler", image_body(small), ext_size=60000))
    answer("short_body", message("IMAGE", "Doppler", b"\0" * 10))
    # After all that, a good volume is still registered: sent with header version 2 and metadata,
    # as Slicer sends by default.
    c.send(message_v2("IMAGE", "Doppler", image_body(vol), {"Modality": "US", "Sweep": "1"}))
    out["answers"]["valid_after"] = c.until_status()
    # A body claimed far above any volume: refused without allocating, connection closed.
    c.send(message("IMAGE", "Doppler", b"", body_size=1 << 50))
    out["answers"]["huge_body"] = c.until_status()
    try:
        c.sock.settimeout(30)
        closed = c.sock.recv(1) == b""
    except (ConnectionError, socket.timeout):
        closed = True
    out["closed_after_huge_body"] = closed
    # The server still accepts a new client.
    d = Client(a.port)
    d.send(message("FROBNICATE", "X", b""))
    out["answers"]["new_client"] = d.until_status()
    dump(out, a.out)


def latency(a):
    """The same Doppler volume `--repeat` times (packed once): the server's latency from the last
    byte received to the TRANSFORM sent (its report), and the client's from the last byte sent."""
    c = Client(a.port)
    if a.bmode:  # one B-mode first: its footprint is extracted while the server waits
        c.send(message("IMAGE", "BMode", image_body(read_nifti(a.bmode))))
        time.sleep(2.0)
    raw = message("IMAGE", "Doppler", image_body(read_nifti(a.doppler)))
    rows = []
    for _ in range(a.repeat):
        c.log = []
        sent = c.send(raw)
        status = c.until_status()
        row = {"status": status["name"]}
        for m in c.log:
            if m["type"] == "TRANSFORM" and "client_to_transform_s" not in row:
                row["client_to_transform_s"] = m["at"] - sent
            if m["type"] == "STRING" and m["device"] == "BrainshiftReport":
                r = json.loads(m["text"])
                row.update({k: r[k] for k in ("frame", "latency_to_transform_s", "latency_s",
                                              "registration_s", "iterations")})
        rows.append(row)
    dump(rows, a.out)


def queue(a):
    """Three Doppler volumes back to back: the first is registered, the third replaces the second
    while it waits; the two final statuses are collected (the test stops the server meanwhile)."""
    c = Client(a.port)
    raw = message("IMAGE", "Doppler", image_body(read_nifti(a.doppler)))
    for _ in range(3):
        c.send(raw)
    finals = [c.until_status(), c.until_status()]
    dump({"finals": finals, "messages": c.log}, a.out)


def plus(a):
    """Plays a PLUS server: listens (the port written to --port-file), waits for brainshift to
    connect, sends the reconstructed Doppler volume under PLUS's device name RecVol_Reference."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    with open(a.port_file + ".tmp", "w") as f:
        f.write(str(server.getsockname()[1]))
    os.replace(a.port_file + ".tmp", a.port_file)
    server.settimeout(300)
    conn, _ = server.accept()
    conn.settimeout(300)
    c = Client(0, conn)
    c.send(message("IMAGE", "RecVol_Reference", image_body(read_nifti(a.doppler))))
    out = {"status": c.until_status(), "messages": c.log}
    dump(out, a.out)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scenario", choices=["session", "malformed", "latency", "queue", "plus"])
    p.add_argument("--port", type=int, default=0)
    p.add_argument("--port-file")
    p.add_argument("--doppler", required=True)
    p.add_argument("--bmode")
    p.add_argument("--pre-dura")
    p.add_argument("--mri")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--out", required=True)
    a = p.parse_args()
    {"session": session, "malformed": malformed, "latency": latency, "queue": queue,
     "plus": plus}[a.scenario](a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
