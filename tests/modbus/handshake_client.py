#!/usr/bin/python3
"""The PLC's handshake with pymodbus (Debian python3-pymodbus 3.0) against the test server.

usage: handshake_client.py SERVER_EXE
Starts SERVER_EXE (palletd_modbus_test_server) once with high-word-first and once with
--low-word-first on a free loopback port, runs trigger/result/ack cycles, decodes the result
block with pymodbus' BinaryPayloadDecoder in the advertised word order, and compares it with the
fixture's fake result (tests/modbus/fake_result.hpp). Exit status 0 = pass.
"""
import subprocess
import sys
import time

from pymodbus.client import ModbusTcpClient
from pymodbus.constants import Endian
from pymodbus.payload import BinaryPayloadDecoder

READY, BUSY, TRIGGER_ACK, RESULT_READY, ERROR, MISSED = 1, 2, 4, 8, 16, 32
UNIT = 1


def fake_result(recipe, request_id):
    """Mirror of fake_result() in fake_result.hpp, in engineering units."""
    if recipe == 99:
        return {"status": 2, "boxes": [], "found": 0}
    n = min(recipe, 40)
    boxes = []
    for i in range(n):
        boxes.append({
            "x": (request_id % 100) * 0.01 - 0.5 + 0.1 * i,
            "y": -0.3 - 0.0123 * i,
            "z": 1.2345,
            "yaw": -179.0 + 7.5 * i,
            "format": i % 3,
            "score": ((i * 37) % 1000) / 1000.0,
            "pick": i + 1,
        })
    return {"status": 0 if n else 1, "boxes": boxes[:32], "found": n,
            "layer_z": -1.5 + 0.0001 * request_id, "coverage": 0.875,
            "ambiguous": request_id % 2 == 1}


class Plc:
    def __init__(self, port):
        self.client = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
        if not self.client.connect():
            raise SystemExit("cannot connect")

    def read(self, address, count, fc=3):
        call = self.client.read_holding_registers if fc == 3 else self.client.read_input_registers
        rsp = call(address, count, slave=UNIT)
        if rsp.isError():
            raise SystemExit(f"read {address}+{count} failed: {rsp}")
        return rsp.registers

    def write(self, address, values):
        rsp = self.client.write_registers(address, values, slave=UNIT)
        if rsp.isError():
            raise SystemExit(f"write {address} failed: {rsp}")

    def status(self):
        return self.read(100, 1)[0]

    def wait(self, mask, want, what):
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline:
            if self.status() & mask == want:
                return
            time.sleep(0.005)
        raise SystemExit(f"timed out waiting for {what} (status word {self.status():#06x})")

    def result_block(self):
        """200..530 in three reads (125 + 125 + 81 registers), as a PLC would."""
        regs = self.read(200, 125) + self.read(325, 125) + self.read(450, 81)
        assert len(regs) == 331
        return regs


def decoder(regs, wordorder):
    return BinaryPayloadDecoder.fromRegisters(regs, byteorder=Endian.Big, wordorder=wordorder)


def check(cond, message):
    if not cond:
        raise SystemExit("FAIL: " + message)


def decode_result(regs, wordorder):
    d = {"id": regs[0], "request": regs[1], "status": regs[2], "found": regs[3],
         "reported": regs[4], "recipe": regs[5], "flags": regs[6], "copy": regs[330]}
    d["layer_z"] = decoder(regs[7:9], wordorder).decode_32bit_int() * 1e-4
    d["coverage"] = regs[9] / 1000.0
    boxes = []
    for i in range(d["reported"]):
        slot = regs[10 + 10 * i: 20 + 10 * i]
        dec = decoder(slot, wordorder)
        x, y, z = (dec.decode_32bit_int() * 1e-4 for _ in range(3))
        yaw = dec.decode_16bit_int() * 0.01
        boxes.append({"x": x, "y": y, "z": z, "yaw": yaw, "format": slot[7],
                      "score": slot[8] / 1000.0, "pick": slot[9]})
    d["boxes"] = boxes
    return d


def run(server_exe, low_word_first):
    args = [server_exe, "--port", "0", "--delay-ms", "40"]
    if low_word_first:
        args.append("--low-word-first")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline().split()
        check(len(line) == 2 and line[0] == "PORT", f"server printed {line}")
        plc = Plc(int(line[1]))
        status = plc.read(100, 18, fc=4)
        check(status[8] == 1, "interface version 1")
        check((status[9] & 1) == (1 if low_word_first else 0), "format flags bit0 = word order")
        order = Endian.Little if status[9] & 1 else Endian.Big
        other = Endian.Big if order == Endian.Little else Endian.Little
        check(decoder(status[10:12], order).decode_32bit_uint() == 0x12345678, "test pattern")
        check(decoder(status[10:12], other).decode_32bit_uint() != 0x12345678, "word order matters")
        check(decoder(status[15:17], order).decode_32bit_uint() == 0x00010002, "frames grabbed")

        last_id = plc.read(200, 1)[0]
        for n, recipe in enumerate([3, 0, 40, 99, 7]):
            request = 1000 + 17 * n
            plc.wait(READY | BUSY, READY, "Ready and not Busy")
            plc.write(0, [1, recipe, request])         # Trigger + recipe + request id, one FC16
            plc.wait(TRIGGER_ACK, TRIGGER_ACK, "TriggerAck")
            plc.write(0, [0])
            plc.wait(TRIGGER_ACK, 0, "TriggerAck dropped")
            plc.wait(RESULT_READY | BUSY, RESULT_READY, "ResultReady")
            regs = plc.result_block()
            got = decode_result(regs, order)
            want = fake_result(recipe, request)
            check(got["id"] == got["copy"], "result id copy in 530")
            check(got["id"] == (last_id + 1) & 0xFFFF, f"result id {got['id']} after {last_id}")
            last_id = got["id"]
            check(plc.read(106, 2) == [got["id"], request], "status block result id / request id")
            check(got["request"] == request and got["recipe"] == recipe, "request id / recipe echo")
            check(got["status"] == want["status"], f"status {got['status']}")
            check(got["found"] == want["found"], "boxes found")
            check(got["reported"] == len(want["boxes"]), "boxes reported")
            if recipe == 99:
                check(plc.status() & ERROR, "Error bit on failure")
                check(plc.read(101, 2) == [3, 3], "error code 3 (detection failed), detail 3 (no layout)")
            else:
                check(plc.status() & ERROR == 0, "no Error bit on success")
            if want["boxes"]:
                check(abs(got["layer_z"] - want["layer_z"]) < 1e-4, "layer z")
                check(abs(got["coverage"] - want["coverage"]) < 1e-3, "coverage")
                check((got["flags"] & 1) == (1 if want["ambiguous"] else 0), "ambiguous flag")
            for g, w in zip(got["boxes"], want["boxes"]):
                for key, tol in (("x", 1e-4), ("y", 1e-4), ("z", 1e-4), ("yaw", 0.01), ("score", 1e-3)):
                    check(abs(g[key] - w[key]) <= tol, f"box {key}: {g[key]} vs {w[key]}")
                check(g["format"] == w["format"] and g["pick"] == w["pick"], "box format / pick")
            # unused slots read 0
            check(all(v == 0 for v in regs[10 + 10 * got["reported"]:330]), "unused slots zero")
            plc.write(0, [2])                            # ResultAck
            plc.wait(RESULT_READY, 0, "ResultReady cleared")
            plc.write(0, [0])

        # A trigger while Busy is missed and counted; ClearError clears the bit.
        missed_before = plc.read(112, 1)[0]
        plc.write(0, [1, 3, 5000])
        plc.write(0, [0])
        plc.write(0, [1, 3, 5001])
        check(plc.status() & MISSED, "MissedTrigger")
        check(plc.read(112, 1)[0] == missed_before + 1, "missed-trigger count")
        check(plc.read(107, 1)[0] == 5000, "the missed trigger did not latch")
        plc.write(0, [0])
        plc.wait(RESULT_READY | BUSY, RESULT_READY, "ResultReady")
        plc.write(0, [4])                                # ClearError
        check(plc.status() & (MISSED | ERROR) == 0, "ClearError")
        plc.write(0, [0])
        plc.client.close()
        print(f"pymodbus handshake ok ({'low' if low_word_first else 'high'} word first)")
    finally:
        proc.terminate()
        proc.wait(timeout=5)
    check(proc.returncode == 0, f"server exit status {proc.returncode}")


def main():
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    run(sys.argv[1], low_word_first=False)
    run(sys.argv[1], low_word_first=True)


if __name__ == "__main__":
    main()
