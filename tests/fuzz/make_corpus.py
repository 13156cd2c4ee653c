#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets into tests/fuzz/corpus/<target>/ (small files).

Run it again after changing an input format; the fuzzers add their own finds in a separate
folder (scripts/fuzz.sh), so this folder stays small and reviewed.
"""
import json
import pathlib
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent
CORPUS = HERE / "corpus"
ROOT = HERE.parent.parent


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


# --- Modbus: options byte, then 'S' u16 n <stream> / 'R' <20 bytes> / 'T' <4 bytes> records.
def mbap(tid, pdu, unit=1, protocol=0):
    return struct.pack(">HHHB", tid, protocol, len(pdu) + 1, unit) + pdu


def read(fn, addr, count):
    return struct.pack(">BHH", fn, addr, count)


def write_regs(addr, values):
    return struct.pack(">BHHB", 16, addr, len(values), 2 * len(values)) + b"".join(struct.pack(">H", v) for v in values)


def S(stream):
    return b"S" + struct.pack(">H", len(stream)) + stream


def R(status=0, boxes=3, z=1.2, cov=0.95, ms=40.0):
    return b"R" + struct.pack(">BHB", status, 0, boxes) + struct.pack(">fff", z, cov, ms) + b"\0" * 4


def T(flags=3, detail=0, acq=7):
    return b"T" + struct.pack(">BHB", flags, detail, acq)


READY = 3
put("fuzz_modbus", "read_blocks", bytes([READY]) + S(mbap(1, read(3, 0, 16)) + mbap(2, read(4, 100, 18)) + mbap(3, read(3, 200, 125))))
put("fuzz_modbus", "handshake",
    bytes([READY]) + S(mbap(1, write_regs(0, [0, 2, 77]))) + S(mbap(2, write_regs(0, [1, 2, 77]))) + R() +
    S(mbap(3, read(3, 100, 18)) + mbap(4, read(3, 200, 60))) + S(mbap(5, write_regs(0, [2])) + mbap(6, write_regs(0, [0]))))
put("fuzz_modbus", "handshake_failed",
    bytes([READY | 16]) + S(mbap(1, write_regs(0, [1, 1, 5]))) + R(status=2, boxes=0) + T(flags=1 | (4 << 3), detail=9) +
    S(mbap(2, read(4, 100, 18)) + mbap(3, write_regs(0, [4]))))
put("fuzz_modbus", "coils_and_single",
    bytes([READY]) + S(mbap(1, struct.pack(">BHH", 5, 0, 0xFF00)) + mbap(2, struct.pack(">BHHB", 15, 0, 4, 1) + b"\x05") +
                       mbap(3, read(1, 0, 16)) + mbap(4, read(2, 0, 16)) + mbap(5, struct.pack(">BHH", 6, 3, 1234))))
put("fuzz_modbus", "read_write_23",
    bytes([READY]) + S(mbap(1, struct.pack(">BHHHHB", 23, 100, 10, 0, 2, 4) + b"\x00\x01\x00\x02")))
put("fuzz_modbus", "exceptions",
    bytes([READY | 4]) + S(mbap(1, read(3, 600, 10)) + mbap(2, read(3, 0, 200)) + mbap(3, b"\x2b\x0e\x01\x00") +
                           mbap(4, write_regs(0, [1])) + mbap(5, read(3, 0, 1), unit=9) + mbap(6, read(3, 0, 1), protocol=7)))
put("fuzz_modbus", "pipelined_partial",
    bytes([READY | 8]) + S(b"".join(mbap(i, read(3, i, 4), unit=i) for i in range(1, 9)) + mbap(99, read(3, 0, 4))[:9]))
put("fuzz_modbus", "impossible_length", bytes([READY]) + S(mbap(1, read(3, 0, 2)) + b"\x00\x02\x00\x00\xff\xff\x01\x03"))

# --- Frame reader: u16 n JSON, u32 m depth PNG, rest intensity PNG.
def png(width, height, bits, pixels):
    raw = b""
    for y in range(height):
        row = pixels[y * width:(y + 1) * width]
        raw += b"\0" + b"".join(struct.pack(">H" if bits == 16 else ">B", p) for p in row)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bits, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def frame_input(meta, depth, intensity=b""):
    j = json.dumps(meta).encode()
    return struct.pack(">H", len(j)) + j + struct.pack(">I", len(depth)) + depth + intensity


W, H = 8, 6
meta = {"width": W, "height": H, "fx": 7.0, "fy": 7.5, "cx": 3.5, "cy": 2.5, "depth_scale": 0.001,
        "camera": "fuzz-1", "timestamp_ns": 5}
depth = png(W, H, 16, [1500 + 3 * i if i % 7 else 0 for i in range(W * H)])
put("fuzz_frame_reader", "plain", frame_input(meta, depth))
put("fuzz_frame_reader", "intensity8", frame_input(meta, depth, png(W, H, 8, [i * 5 % 256 for i in range(W * H)])))
put("fuzz_frame_reader", "intensity16", frame_input(meta, depth, png(W, H, 16, [i * 999 for i in range(W * H)])))
put("fuzz_frame_reader", "calibrated",
    frame_input(dict(meta, distortion=[0.1, -0.01, 0.001, 0.0, 0.0],
                     camera_to_base=[0, -1, 0, 0.1, -1, 0, 0, 0.2, 0, 0, -1, 2.5, 0, 0, 0, 1]), depth))
put("fuzz_frame_reader", "size_mismatch", frame_input(dict(meta, width=9), depth))
put("fuzz_frame_reader", "truncated_png", frame_input(meta, depth[:40]))
# Found by the fuzzer: a number beyond double range threw nlohmann out_of_range past the reader.
overflow = b'{"width": 8, "height": 6, "fx": 11E1111111111, "fy": 7, "cx": 3, "cy": 2, "depth_scale": 0.001}'
put("fuzz_frame_reader", "json_number_overflow", struct.pack(">H", len(overflow)) + overflow + struct.pack(">I", len(depth)) + depth)

# --- Config: the shipped files and a few small ones.
put("fuzz_config", "palletd.yaml", (ROOT / "config" / "palletd.yaml").read_text())
put("fuzz_config", "demo.yaml", (ROOT / "config" / "demo.yaml").read_text())
put("fuzz_config", "formats.yaml",
    "formats:\n  - {name: a, long_mm: 600, short_mm: 400}\n  - {name: b, long_mm: 315, short_mm: 232}\n"
    "recipes:\n  - {number: 1, name: one, formats: [a, b]}\npipeline: {default_recipe: 1}\n")
put("fuzz_config", "camera.yaml",
    "camera:\n  driver: aravis\n  aravis: {address: 192.168.0.10, pixel_format: Mono16, mono16_scale_m: 0.0001}\n"
    "  intrinsics: {width: 352, height: 264, fx: 210.5, fy: 210.5, cx: 175.5, cy: 131.5}\n"
    "camera_to_base: [1, 0, 0, 0.1, 0, -1, 0, 0.2, 0, 0, -1, 2.5, 0, 0, 0, 1]\n")
put("fuzz_config", "modbus.yaml",
    "modbus: {port: 1502, unit_id: 0, allow: [10.0.0.0/8, '::1'], read_only: [10.0.0.5], max_connections: 4}\n"
    "web: {enabled: true, port: 8081, allowed_hosts: [cell.local]}\nrecording: {enabled: true, directory: rec, max_bytes: 1000000}\n")

# --- Detection: base frame index, then 8-byte mutations (op, x, y, w, h, value u16, extra).
def op(kind, x=0, y=0, w=255, h=255, value=0, extra=0):
    return struct.pack(">BBBBBHB", kind, x, y, w, h, value, extra)


put("fuzz_detection", "untouched_0", b"\x00")
put("fuzz_detection", "untouched_2", b"\x02")
put("fuzz_detection", "dropout", b"\x00" + op(1, 60, 40, 80, 60))
put("fuzz_detection", "noise", b"\x01" + op(2, 0, 0, 255, 255, 0, 40))
put("fuzz_detection", "wall", b"\x03" + op(3, 0, 0, 255, 255, 1200, 140))
put("fuzz_detection", "bad_intrinsics", b"\x00" + op(5, extra=0) + op(6, extra=4))
put("fuzz_detection", "bad_formats", b"\x02" + op(8, value=0x0101) + op(9, value=100, extra=1))
put("fuzz_detection", "all_invalid", b"\x01" + op(1))
