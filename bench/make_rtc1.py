"""Write an N-frame cyclic RTC1 pcap fast (templates + struct.pack_into; no scapy per frame).

Two directions at 1 ms (SendClockFactor 32, ReductionRatio 1 -> cycle counter +32 per frame
pair), 60-byte frames carrying a telegram-81-sized payload. Used by bench/run until the
simulator's fast path replaces it. Usage: python3 bench/make_rtc1.py FRAMES OUT.pcap
"""
import struct
import sys


def main(n: int, out: str) -> None:
    ctrl = bytes.fromhex("001b1b000001")
    dev = bytes.fromhex("000ec0000001")
    hdr_out = dev + ctrl + b"\x88\x92" + b"\x80\x01"   # controller -> device, FrameID 0x8001
    hdr_in = ctrl + dev + b"\x88\x92" + b"\x80\x00"    # device -> controller, FrameID 0x8000
    csdu = bytearray(40)
    rec = struct.Struct("<IIII")
    with open(out, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        buf = bytearray()
        t_us = 0
        for i in range(n):
            hdr = hdr_out if i & 1 == 0 else hdr_in
            cc = ((i >> 1) * 32) & 0xFFFF
            struct.pack_into(">I", csdu, 0, i >> 1)
            frame = hdr + bytes(csdu) + struct.pack(">HBB", cc, 0x35, 0)
            buf += rec.pack(t_us // 1_000_000, t_us % 1_000_000, len(frame), len(frame))
            buf += frame
            if i & 1:
                t_us += 1000
            if len(buf) > 1 << 22:
                f.write(buf)
                buf.clear()
        f.write(buf)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2])
