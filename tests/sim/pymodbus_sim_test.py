"""Debian's pymodbus (an independent Modbus implementation) as a client of `gonio sim`.

Starts the virtual rig in its own process, reads the Modbus TCP address it prints, and checks with
pymodbus: the four drives' positions in the generic profile's layout (docs/profiles.md: 40013-40014
actual position, 32 bits low word first; 40011 status), the exception codes the Modbus Application
Protocol V1.1b3 prescribes (2 for an absent or read-only register), a complete move through the
command block, and the shutter coil. Usage: pymodbus_sim_test.py GONIO_EXE
"""

import os
import re
import signal
import subprocess
import sys
import time

from pymodbus.client import ModbusTcpClient

GENERIC_STATUS = 40011 - 40001
GENERIC_POSITION = 40013 - 40001
COMPARE_CONTROL = 40019 - 40001
COMPARE_COUNT = 40020 - 40001
COMPARE_FIRED = 40021 - 40001
COMPARE_TABLE = 45001 - 40001
STEPS_PER_DEG = 1000  # data/devices/generic.json


def position(client, unit):
    r = client.read_holding_registers(GENERIC_POSITION, 2, slave=unit)
    assert not r.isError(), r
    v = r.registers[0] | (r.registers[1] << 16)
    return v - (1 << 32) if v >= (1 << 31) else v


def main():
    exe = sys.argv[1]
    sim = subprocess.Popen([exe, "sim", "--time-scale", "20", "--camera-ip", "auto"], stdout=subprocess.PIPE, text=True)
    try:
        address = None
        deadline = time.monotonic() + 60
        while address is None and time.monotonic() < deadline:
            line = sim.stdout.readline()
            if not line:
                break
            m = re.match(r"motors: tcp://127\.0\.0\.1:(\d+)", line.strip())
            if m:
                address = int(m.group(1))
        assert address is not None, "gonio sim printed no motor address"
        client = ModbusTcpClient("127.0.0.1", port=address, timeout=5)
        assert client.connect()

        # data/rigs/sim4.json: light 0 deg, detector 45 deg, tilt 0, spin 0, all homed.
        assert position(client, 1) == 0
        assert position(client, 2) == 45 * STEPS_PER_DEG
        st = client.read_holding_registers(GENERIC_STATUS, 1, slave=2)
        assert not st.isError(), st
        assert st.registers[0] & 0b10 and not st.registers[0] & 0b1, st.registers  # in position

        # Exception 2: an absent register, and the read-only status register.
        r = client.read_holding_registers(0x1234, 1, slave=1)
        assert r.isError() and r.exception_code == 2, r
        r = client.write_register(GENERIC_STATUS, 1, slave=1)
        assert r.isError() and r.exception_code == 2, r

        # A move of the light arm to -12.5 deg through the command block 40001-40009.
        def words(v):
            v &= 0xFFFFFFFF
            return [v & 0xFFFF, v >> 16]

        # The position compare: three entries on the way, written low word first, then armed.
        table = [-2000, -5000, -9000]
        r = client.write_registers(COMPARE_TABLE, sum((words(v) for v in table), []), slave=1)
        assert not r.isError(), r
        assert not client.write_register(COMPARE_COUNT, len(table), slave=1).isError()
        assert not client.write_register(COMPARE_CONTROL, 1, slave=1).isError()
        fired = client.read_holding_registers(COMPARE_FIRED, 1, slave=1)
        assert not fired.isError() and fired.registers[0] == 0, fired
        r = client.write_register(COMPARE_FIRED, 5, slave=1)  # the drive's own count
        assert r.isError() and r.exception_code == 2, r

        target = -12500
        block = words(target) + words(30000) + words(60000) + words(60000) + [1]
        r = client.write_registers(0, block, slave=1)
        assert not r.isError(), r
        for _ in range(20000):
            st = client.read_holding_registers(GENERIC_STATUS, 1, slave=1).registers[0]
            if st & 0b10 and not st & 0b1 and position(client, 1) == target:
                break
        assert position(client, 1) == target, position(client, 1)
        fired = client.read_holding_registers(COMPARE_FIRED, 1, slave=1)
        assert not fired.isError() and fired.registers[0] == len(table), fired
        assert not client.write_register(COMPARE_CONTROL, 0, slave=1).isError()

        # The lamp shutter: coil 0 of unit 5.
        assert not client.write_coil(0, True, slave=5).isError()
        r = client.read_coils(0, 1, slave=5)
        assert not r.isError() and r.bits[0], r
        client.close()
        print("pymodbus against gonio sim: positions, exceptions 2, move, position compare, coil: ok")
    finally:
        sim.send_signal(signal.SIGINT)
        try:
            sim.wait(timeout=20)
        except subprocess.TimeoutExpired:
            sim.kill()
            sim.wait()
    return 0


if __name__ == "__main__":
    sys.exit(main())
