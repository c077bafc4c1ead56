# SPDX-License-Identifier: MIT
"""A Modbus TCP device for the modbus source's tests: pymodbus's server with
holding and input registers set from the command line, until killed.

  python3 modbus_peer.py PORT [h:ADDR=V,V,...] [i:ADDR=V,V,...] ...

Addresses are the protocol's 0-based ones (zero_mode); registers 0-999 exist,
others are answered with ILLEGAL DATA ADDRESS."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from busutil import import_pymodbus  # noqa: E402

import_pymodbus()
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusSlaveContext  # noqa: E402
from pymodbus.server import StartTcpServer  # noqa: E402


def main():
    port = int(sys.argv[1])
    hr, ir = [0] * 1000, [0] * 1000
    for arg in sys.argv[2:]:
        kind, rest = arg.split(":", 1)
        addr, values = rest.split("=", 1)
        regs = hr if kind == "h" else ir
        for i, v in enumerate(values.split(",")):
            regs[int(addr) + i] = int(v, 0) & 0xFFFF
    store = ModbusSlaveContext(hr=ModbusSequentialDataBlock(0, hr), ir=ModbusSequentialDataBlock(0, ir),
                               di=ModbusSequentialDataBlock(0, [0] * 10), co=ModbusSequentialDataBlock(0, [0] * 10),
                               zero_mode=True)
    StartTcpServer(context=ModbusServerContext(slaves=store, single=True), address=("127.0.0.1", port),
                   allow_reuse_address=True)


if __name__ == "__main__":
    main()
